//! Hostile sizes and depths through the real binary (issue 27): sources, nets and
//! configurations nested far deeper than any real one are refused with exit 2 and a coded
//! error at their place — never a stack overflow (exit 134), and `run` leaves nothing in
//! /dev/shm — and the front ends' papercuts: a byte order mark, a cascade of errors after the
//! real one, floods of errors, huge names, a directory named as a source.

use std::path::{Path, PathBuf};

use assert_cmd::Command;

fn petriplc() -> Command {
    Command::cargo_bin("petriplc").unwrap()
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs `petriplc ARGS…`; returns its exit code and standard error.
fn run(args: &[&str]) -> (i32, String) {
    let out = petriplc().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    (out.status.code().unwrap_or(-1), err)
}

/// Expects exit 2 and a standard error holding every one of `expect`, without a crash.
fn refused(args: &[&str], expect: &[&str]) -> String {
    let (code, err) = run(args);
    assert_eq!(code, 2, "{args:?}: {}", &err[..err.len().min(3000)]);
    for e in expect {
        assert!(
            err.contains(e),
            "{args:?}: `{e}` not in {}",
            &err[..err.len().min(3000)]
        );
    }
    assert!(
        !err.contains("overflow") && !err.contains("panicked"),
        "{err}"
    );
    err
}

/// What a PLC with this id left in /dev/shm.
fn shm_left(id: &str) -> Vec<String> {
    let prefix = format!("petriplc-{id}");
    std::fs::read_dir("/dev/shm")
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(&prefix))
        .collect()
}

/// `petriplc check`, `sim` and `run --for 1s` (through a configuration with an `iec` module)
/// all refuse `source` with exit 2 and each of `expect`; `run` leaves nothing behind.
fn refused_everywhere(source: &Path, expect: &[&str]) {
    let s = source.to_str().unwrap();
    refused(&["check", s], expect);
    refused(&["sim", s], expect);
    let dir = source.parent().unwrap();
    let name = source.file_name().unwrap().to_str().unwrap();
    let conf = write(
        dir,
        &format!("{name}.conf"),
        &format!("[PLC]\nmodule m iec\n[m]\nprogram = {name}\n"),
    );
    let id = format!("deep-{}-{}", std::process::id(), name.replace('.', "-"));
    refused(
        &[
            "run",
            conf.to_str().unwrap(),
            "--for",
            "1s",
            "--plc-id",
            &id,
        ],
        expect,
    );
    assert_eq!(shm_left(&id), Vec::<String>::new());
}

/// F0 holds an F1, which holds an F2, … `n` deep; each calls the one it holds.
fn fb_chain(n: usize) -> String {
    let mut s = String::from("PROGRAM main\nVAR f : F0; END_VAR\nf();\nEND_PROGRAM\n");
    for i in 0..n {
        if i + 1 == n {
            s.push_str(&format!(
                "FUNCTION_BLOCK F{i}\nVAR x : INT; END_VAR\nx := x + 1;\nEND_FUNCTION_BLOCK\n"
            ));
        } else {
            s.push_str(&format!(
                "FUNCTION_BLOCK F{i}\nVAR c : F{}; END_VAR\nc();\nEND_FUNCTION_BLOCK\n",
                i + 1
            ));
        }
    }
    s
}

#[test]
fn function_blocks_10000_deep_are_refused_not_a_crash() {
    let dir = tempfile::tempdir().unwrap();
    let src = write(dir.path(), "fbs.st", &fb_chain(10_000));
    // F99's declaration (line 401): the 101st level.
    refused_everywhere(
        &src,
        &["fbs.st:401:16: error[E116]: `F99` is used more than 100 levels deep"],
    );
}

#[test]
fn structures_20000_deep_are_refused_not_a_crash() {
    let dir = tempfile::tempdir().unwrap();
    let n = 20_000;
    let mut s = String::from("TYPE\n");
    for i in 0..n - 1 {
        s.push_str(&format!("S{i} : STRUCT s : S{}; END_STRUCT;\n", i + 1));
    }
    s.push_str(&format!(
        "S{} : STRUCT x : INT; END_STRUCT;\nEND_TYPE\n",
        n - 1
    ));
    s.push_str("PROGRAM main\nVAR v : S0; END_VAR\nv.s.s.s := v.s.s.s;\nEND_PROGRAM\n");
    let src = write(dir.path(), "structs.st", &s);
    refused_everywhere(
        &src,
        &["structs.st:101:18: error[E116]: `S100` is used more than 100"],
    );
}

#[test]
fn deep_expressions_and_arrays_are_refused_not_a_crash() {
    let dir = tempfile::tempdir().unwrap();
    let n = 100_000;
    let parens = write(
        dir.path(),
        "parens.st",
        &format!(
            "PROGRAM main\nVAR x : INT; END_VAR\nx := {}1{};\nEND_PROGRAM\n",
            "(".repeat(n),
            ")".repeat(n)
        ),
    );
    refused_everywhere(
        &parens,
        &["parens.st:3:105: error[E014]: nesting deeper than 100 levels"],
    );
    let chain = write(
        dir.path(),
        "chain.st",
        &format!(
            "PROGRAM main\nVAR x : INT; END_VAR\nx := {};\nEND_PROGRAM\n",
            vec!["x"; n].join(" + ")
        ),
    );
    refused(
        &["check", chain.to_str().unwrap()],
        &[
            "chain.st:3:",
            "error[E014]: an expression more than 1000 levels deep",
        ],
    );
    let arrays = write(
        dir.path(),
        "arrays.st",
        &format!(
            "PROGRAM main\nVAR v : {}INT; END_VAR\nEND_PROGRAM\n",
            "ARRAY[0..1] OF ".repeat(20_000)
        ),
    );
    refused_everywhere(
        &arrays,
        &[
            "arrays.st:2:",
            "error[E014]: nesting deeper than 100 levels",
        ],
    );
    // Named array types, each of the next: their depth, and their size (2^100 elements).
    let mut s = String::from("TYPE\n");
    for i in 0..20_000 {
        s.push_str(&format!("A{i} : ARRAY[0..1] OF A{};\n", i + 1));
    }
    s.push_str(
        "A20000 : ARRAY[0..1] OF INT;\nEND_TYPE\nPROGRAM main\nVAR v : A0; END_VAR\nEND_PROGRAM\n",
    );
    let named = write(dir.path(), "named.st", &s);
    refused(
        &["check", named.to_str().unwrap()],
        &["named.st:101:", "error[E116]"],
    );
    let big = write(
        dir.path(),
        "big.st",
        "PROGRAM main\nVAR v : ARRAY[0..9999] OF ARRAY[0..9999] OF ARRAY[0..9999] OF INT; END_VAR\nEND_PROGRAM\n",
    );
    refused(
        &["check", big.to_str().unwrap(), "--pou", "main"],
        &["big.st:2:9: error[E109]: this array takes 1000000000000 values"],
    );
    // 100 000 IL instructions on one current result are a long program, not a deep one.
    let il = write(
        dir.path(),
        "long.il",
        &format!(
            "PROGRAM main\nVAR x : INT; END_VAR\nLD x\n{}ST x\nEND_PROGRAM\n",
            "ADD 1\n".repeat(100_000)
        ),
    );
    let (code, err) = run(&["check", il.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn deep_nets_and_guards_are_refused_not_a_crash() {
    let dir = tempfile::tempdir().unwrap();
    let head = r#"<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml"><net id="n" type="http://www.pnml.org/version-2009/grammar/ptnet"><page id="pg">"#;
    let pages = write(
        dir.path(),
        "pages.pnml",
        &format!("{head}\n{}", "<page>".repeat(100_000)),
    );
    for cmd in ["sim", "analyze"] {
        refused(
            &[cmd, pages.to_str().unwrap()],
            &[
                "pages.pnml:2:",
                "error[P001]: elements are nested more than 256 deep",
            ],
        );
    }
    let guard = |g: &str| {
        format!(
            "{head}\n<place id=\"p\"><initialMarking><text>1</text></initialMarking></place><transition id=\"t\"><toolspecific tool=\"petriplc\" version=\"1\"><guard>{g}</guard></toolspecific></transition><arc id=\"a\" source=\"p\" target=\"t\"/></page></net></pnml>\n"
        )
    };
    let parens = write(
        dir.path(),
        "parens.pnml",
        &guard(&format!("{}B1{}", "(".repeat(100_000), ")".repeat(100_000))),
    );
    refused(
        &["sim", parens.to_str().unwrap()],
        &["parens.pnml:2:", "error[P013]"],
    );
    let chain = write(
        dir.path(),
        "chain.pnml",
        &guard(&vec!["B1"; 100_000].join(" AND ")),
    );
    refused(
        &["sim", chain.to_str().unwrap()],
        &["chain.pnml:2:", "error[P013]"],
    );
    // PLCopen XML nested deeper than any project.
    let xml = write(
        dir.path(),
        "deep.xml",
        &format!(
            "<project xmlns=\"http://www.plcopen.org/xml/tc6_0201\">{}",
            "<types>".repeat(100_000)
        ),
    );
    refused(
        &["check", xml.to_str().unwrap()],
        &["deep.xml:1:", "error[E050]"],
    );
}

#[test]
fn a_long_include_chain_is_refused_not_a_crash() {
    let dir = tempfile::tempdir().unwrap();
    let n = 10_000;
    for i in 0..n {
        let text = if i + 1 < n {
            format!("*include c{}.conf\n", i + 1)
        } else {
            "[PLC]\nmodule s shutdown\n".to_string()
        };
        write(dir.path(), &format!("c{i}.conf"), &text);
    }
    let id = format!("deep-{}-include", std::process::id());
    let first = dir.path().join("c0.conf");
    refused(
        &[
            "run",
            first.to_str().unwrap(),
            "--for",
            "1s",
            "--plc-id",
            &id,
        ],
        &["c63.conf:1: error[C009]: `*include` nested more than 64 files deep"],
    );
    assert_eq!(shm_left(&id), Vec::<String>::new());
}

#[test]
fn a_byte_order_mark_starts_st_and_il_sources() {
    let dir = tempfile::tempdir().unwrap();
    let st = write(
        dir.path(),
        "bom.st",
        "\u{feff}PROGRAM main\nVAR x : INT; END_VAR\nx := x + 1;\nEND_PROGRAM\n",
    );
    let (code, err) = run(&["check", st.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let il = write(
        dir.path(),
        "bom.il",
        "\u{feff}PROGRAM main\nVAR x : INT; END_VAR\nLD x\nADD 1\nST x\nEND_PROGRAM\n",
    );
    let (code, err) = run(&["check", il.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    // Columns on the first line count from after the mark.
    let bad = write(
        dir.path(),
        "bad.st",
        "\u{feff}PROGRAM main x := ; END_PROGRAM\n",
    );
    refused(
        &["check", bad.to_str().unwrap()],
        &["bad.st:1:19: error[E010]"],
    );
}

#[test]
fn too_deep_is_the_one_error_not_a_cascade() {
    let dir = tempfile::tempdir().unwrap();
    let src = write(
        dir.path(),
        "ifs.st",
        &format!(
            "PROGRAM main\nVAR x : BOOL; END_VAR\n{}x := FALSE;\n{}END_PROGRAM\n",
            "IF x THEN\n".repeat(150),
            "END_IF;\n".repeat(150)
        ),
    );
    let err = refused(&["check", src.to_str().unwrap()], &[]);
    assert_eq!(
        err,
        format!(
            "{}:102:4: error[E014]: nesting deeper than 100 levels; split the expression or statement\n\
             error: 1 problem found; nothing was run\n",
            src.display()
        )
    );
}

#[test]
fn a_flood_of_errors_is_capped_with_a_count() {
    let dir = tempfile::tempdir().unwrap();
    // One error per line: 1059 of them.
    let garbage = write(dir.path(), "garbage.st", &"§\n".repeat(1059));
    let err = refused(&["check", garbage.to_str().unwrap()], &[]);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 52, "{err}");
    assert!(
        lines[49].starts_with(&format!("{}:50:1: error[E001]", garbage.display())),
        "{err}"
    );
    assert_eq!(lines[50], "… and 1009 more errors");
    assert_eq!(lines[51], "error: 1059 problems found; nothing was run");
    // The same through a module of `run`.
    let conf = write(
        dir.path(),
        "g.conf",
        "[PLC]\nmodule m iec\n[m]\nprogram = garbage.st\n",
    );
    let id = format!("deep-{}-flood", std::process::id());
    let err = refused(
        &[
            "run",
            conf.to_str().unwrap(),
            "--for",
            "1s",
            "--plc-id",
            &id,
        ],
        &["… and 1009 more errors\n"],
    );
    assert!(err.lines().count() < 60, "{err}");
    // And a flood of IL errors.
    let il = write(
        dir.path(),
        "bad.il",
        &format!(
            "PROGRAM main\n{}END_PROGRAM\n",
            "FOO BAR BAZ\n".repeat(100_000)
        ),
    );
    let err = refused(&["check", il.to_str().unwrap()], &[]);
    assert!(err.lines().count() <= 52, "{}", err.lines().count());
}

#[test]
fn long_names_are_shortened_in_messages() {
    let dir = tempfile::tempdir().unwrap();
    let name = "a".repeat(10_000);
    let src = write(
        dir.path(),
        "long.st",
        &format!("PROGRAM main\nVAR x : INT; END_VAR\nx := {name};\nEND_PROGRAM\n"),
    );
    let err = refused(
        &["check", src.to_str().unwrap()],
        &[&format!(
            "`{}…(10000 characters)` is not declared",
            "a".repeat(40)
        )],
    );
    assert!(err.len() < 400, "{err}");
}

#[test]
fn a_directory_named_as_a_source_is_said_once() {
    // A folder is a project (docs/migrating.md); one without sources is refused once, by
    // `check` and by `sim`, whatever its name.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let empty = |p: &str| {
        format!("error: cannot read {p}: the folder holds no IEC 61131-3 source (.st, .il, PLCopen .xml, .TcPOU, .TcDUT, .TcGVL, .TcTTO); name a folder that does, or the files themselves\n")
    };
    let err = refused(&["check", d], &[]);
    assert_eq!(err, empty(d));
    let src = write(dir.path(), "d.st", "");
    std::fs::remove_file(&src).unwrap();
    std::fs::create_dir(&src).unwrap();
    let err = refused(&["sim", src.to_str().unwrap()], &[]);
    assert_eq!(err, empty(src.to_str().unwrap()));
    std::fs::remove_dir(&src).unwrap();
    let err = refused(&["sim", d], &[]);
    assert_eq!(err, empty(d));
}
