//! Every kind of bad PNML, run through the real binary: exit code 2, the file, the line and
//! the element in the message, never a panic.

use assert_cmd::Command;
use predicates::prelude::*;

const HEAD: &str = "<?xml version=\"1.0\"?>\n<pnml xmlns=\"http://www.pnml.org/version-2009/grammar/pnml\">\n<net id=\"n\" type=\"http://www.pnml.org/version-2009/grammar/ptnet\"><page id=\"pg\">\n";
const TAIL: &str = "</page></net></pnml>\n";

/// Writes `body` (the page's content, starting on line 4) as a net and expects `petriplc sim`
/// to refuse it with exit code 2 and a message holding each of `expect`.
fn check(body: &str, expect: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.pnml");
    std::fs::write(&path, format!("{HEAD}{body}{TAIL}")).unwrap();
    let mut assert = Command::cargo_bin("petriplc")
        .unwrap()
        .arg("sim")
        .arg(&path)
        .assert()
        .code(2);
    for e in expect {
        assert = assert.stderr(predicate::str::contains(*e));
    }
    assert.stderr(predicate::str::contains("panicked").not());
}

#[test]
fn unknown_arc_end() {
    check(
        "<place id=\"p\"/><transition id=\"t\"/>\n<arc id=\"a1\" source=\"p\" target=\"nowhere\"/>\n",
        &["bad.pnml:5:", "a1", "nowhere"],
    );
}

#[test]
fn place_to_place_arc() {
    check(
        "<place id=\"p\"/><place id=\"q\"/>\n<arc id=\"a1\" source=\"p\" target=\"q\"/>\n",
        &["bad.pnml:5:", "a1", "two places"],
    );
}

#[test]
fn zero_and_negative_weights() {
    let net = |w: &str| {
        format!("<place id=\"p\"/><transition id=\"t\"/>\n<arc id=\"a1\" source=\"p\" target=\"t\"><inscription><text>{w}</text></inscription></arc>\n")
    };
    check(&net("0"), &["bad.pnml:5:", "a1", "weight 0"]);
    check(&net("-2"), &["bad.pnml:5:", "a1"]);
    check(&net("99999999999"), &["bad.pnml:5:", "a1", "4294967295"]);
}

#[test]
fn duplicate_ids() {
    check(
        "<place id=\"p\"/>\n<place id=\"p\"/>\n",
        &["bad.pnml:5:", "`p`"],
    );
}

#[test]
fn bad_guard_points_at_the_column() {
    check(
        "<transition id=\"t\"><toolspecific tool=\"petriplc\" version=\"1\"><guard>B1 AND</guard></toolspecific></transition>\n",
        &["bad.pnml:4:", "`t`", "column 7"],
    );
}

#[test]
fn not_xml() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.pnml");
    std::fs::write(&path, "this is not xml <<<").unwrap();
    Command::cargo_bin("petriplc")
        .unwrap()
        .arg("sim")
        .arg(&path)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("bad.pnml:1:"));
}

#[test]
fn every_problem_is_reported_not_just_the_first() {
    check(
        "<place id=\"p\"/><transition id=\"t\"/>\n<arc id=\"a1\" source=\"p\" target=\"x\"/>\n<arc id=\"a2\" source=\"t\" target=\"y\"/>\n",
        &["bad.pnml:5:", "a1", "bad.pnml:6:", "a2"],
    );
}
