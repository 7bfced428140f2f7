//! Conformance over OSCAT, real IEC 61131-3 code written by others (`../shared/corpora/oscat`,
//! not copied into the repository): every file of the three flavours is checked together with
//! the files it depends on (the corpus's manifest.json), and the share accepted may only grow.
//! Without `../shared` the test says in one line that it was skipped.
//!
//! `OSCAT_REPORT=1 cargo test -p petriplc-iec --test conformance_oscat -- --nocapture` prints
//! every refused file with its first error, and a table of first errors by code.

use std::collections::BTreeMap;
use std::path::Path;

use petriplc_iec::{check, Dialect, Natives, Sources};

mod oscat;
use oscat::{manifest, Entry};

/// Files accepted per flavour, at least: raise these when more is accepted, never lower them.
const ACCEPTED_AT_LEAST: &[(&str, usize)] = &[
    ("oscat_basic", 584),
    ("oscat_building", 56),
    ("tcoscat", 570),
];

/// `None` when the file and its dependencies check, else the first error line.
fn first_error(root: &Path, e: &Entry) -> Option<String> {
    let mut sources = Sources::new();
    // Each flavour in its vendor's dialect, which loads the vendor's library: the PCWorx
    // exports call PCWorx's functions (GET_CHAR, BYTE_TO_STRING(x, format)), the TwinCAT one
    // CODESYS's (TIME(), SIZEOF) and names CTU's inputs as CODESYS does.
    sources.dialect = Some(if e.set == "tcoscat" {
        Dialect::Twincat
    } else {
        Dialect::Pcworx
    });
    for f in e.deps.iter().chain(std::iter::once(&e.file)) {
        if let Err(err) = sources.add_file(&root.join(f)) {
            return Some(err.to_string());
        }
    }
    match check(&sources, &Natives::default()) {
        Ok(_) => None,
        Err(err) => {
            let text = err.to_string();
            // The file's own errors first: a dependency's are counted where it is checked.
            let own = text
                .lines()
                .find(|l| l.contains(&e.file) && l.contains("error["));
            Some(
                own.or_else(|| text.lines().find(|l| l.contains("error[")))
                    .unwrap_or(&text)
                    .to_string(),
            )
        }
    }
}

fn code(line: &str) -> &str {
    line.split_once("error[")
        .and_then(|(_, rest)| rest.split_once(']'))
        .map_or("other", |(c, _)| c)
}

#[test]
fn oscat_files_check() {
    let Some(root) = petriplc_testnet::data::conformance("oscat_files_check", "corpora/oscat")
    else {
        return;
    };
    let root = root.canonicalize().unwrap();
    let report = std::env::var_os("OSCAT_REPORT").is_some();
    let entries = manifest(&root);
    let mut accepted: BTreeMap<&str, (usize, usize)> = BTreeMap::new();
    let mut by_code: BTreeMap<String, usize> = BTreeMap::new();
    for e in &entries {
        let slot = accepted.entry(e.set.as_str()).or_default();
        slot.1 += 1;
        match first_error(&root, e) {
            None => slot.0 += 1,
            Some(line) => {
                *by_code.entry(code(&line).to_string()).or_default() += 1;
                if report {
                    println!("{}: {line}", e.file);
                }
            }
        }
    }
    let total: usize = accepted.values().map(|a| a.0).sum();
    println!(
        "OSCAT: {total} of {} files accepted ({:.1} %)",
        entries.len(),
        100.0 * total as f64 / entries.len() as f64
    );
    for (set, (ok, n)) in &accepted {
        println!("  {set}: {ok} of {n}");
    }
    if report {
        let mut codes: Vec<_> = by_code.into_iter().collect();
        codes.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        for (c, n) in codes {
            println!("  first error {c}: {n} files");
        }
    }
    for (set, least) in ACCEPTED_AT_LEAST {
        let ok = accepted.get(set).map_or(0, |a| a.0);
        assert!(
            ok >= *least,
            "{set}: {ok} files accepted, fewer than the {least} accepted before"
        );
    }
}
