//! docs/diagnostics.md is generated from the code tables of the front ends (each crate's
//! `codes.rs`): the file must equal the page, every code the sources define must have an
//! entry, and every entry's code must be emitted somewhere. `UPDATE_DOCS=1` rewrites the file.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

use petriplc_diag::doc::{page, Entry, Group};

const REGENERATE: &str = "UPDATE_DOCS=1 cargo test -p petriplc --test diagnostics_doc";

const TITLE: &str = "Diagnostics";

const INTRO: &str = "\
Every problem petriplc finds in what it reads — IEC 61131-3 programs, PLCopen XML projects,
PNML nets, PLC configurations — is reported with a stable code, at the place of the fault,
with what to write instead:

```text
bad.st:4:6: error[E110]: the value assigned to `x` is REAL but INT is needed; convert explicitly: REAL_TO_INT(…) rounds, TRUNC(…) truncates
plant.conf:7: error[C021]: point a is declared twice (first at plant.conf:3): a point has one owner and one place, so rename or remove one of them
plant.conf:3: note: point a first declared here
```

A line is `file:line:col: error[CODE]: message` (`file:line` for a configuration, the POU and
element for a graphical body, the file alone when it could not be read); `warning[CODE]` for a
warning. A `note` line after it points at another place that explains it (the first
declaration of a duplicate), a `help` line says how to fix it when the message does not.
Every problem is reported at once; a command prints at most 50, then one line counting the
rest, and exits with code 2 (bad input) without running anything.

Codes are never reused for another meaning. This page is generated from the tables beside the
code that emits them (`codes.rs` of `crates/compiler/iec-syntax`, `crates/plc/config` and
`crates/petri/pnml`); do not edit it: change a table and run
`UPDATE_DOCS=1 cargo test -p petriplc --test diagnostics_doc`. Each example is checked to get
its code, except where a section says it has none.";

fn groups() -> Vec<Group> {
    vec![
        Group {
            heading: "IEC 61131-3 sources (E, W)",
            intro: "Structured Text and Instruction List sources and the checker (`petriplc check`, `sim`, `run` of an IEC program; docs/iec.md). E0xx are syntax, E1xx names, types, statements and configurations, E190 what the engine does not support yet; W codes are warnings, which do not stop a program.",
            example_lang: "st",
            entries: petriplc_iec::syntax::codes::CODES,
        },
        Group {
            heading: "PLCopen XML projects (E050–E054)",
            intro: "PLCopen TC6 XML projects and their LD, FBD and SFC bodies (docs/iec.md, \"PLCopen XML\"); their ST bodies get the codes above, placed at their line in the XML file.",
            example_lang: "xml",
            entries: petriplc_iec::syntax::codes::PLCOPEN_CODES,
        },
        Group {
            heading: "TwinCAT 3 files and projects (E055–E069)",
            intro: "TwinCAT 3 `.TcPOU`, `.TcDUT`, `.TcGVL`, `.TcTTO` files and `.plcproj` projects (docs/migrating.md); their declarations and ST bodies get the codes above, placed at their line in the XML file. Each example is a whole `.TcPOU` file.",
            example_lang: "xml",
            entries: petriplc_iec::syntax::codes::TWINCAT_CODES,
        },
        Group {
            heading: "PLC configurations (C)",
            intro: "The configuration files of `petriplc run` and `petriplc check` (docs/runtime.md, docs/configuration.md); each example is a whole file.",
            example_lang: "conf refused",
            entries: petriplc_config::CODES,
        },
        Group {
            heading: "PNML nets (P)",
            intro: "Petri nets in PNML (docs/pnml.md). An example that is not a whole document is the content of a `<page>`: put it inside `<pnml><net id=\"n\" type=\"http://www.pnml.org/version-2009/grammar/ptnet\"><page id=\"pg\">…</page></net></pnml>`.",
            example_lang: "xml",
            entries: petriplc_pnml::CODES,
        },
    ]
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn the_page_is_generated_from_the_tables() {
    let want = page(TITLE, INTRO, &groups());
    let path = root().join("docs/diagnostics.md");
    if std::env::var_os("UPDATE_DOCS").is_some() {
        fs::write(&path, &want).unwrap();
    }
    let got = fs::read_to_string(&path).unwrap_or_default();
    if got != want {
        let line = got
            .lines()
            .zip(want.lines())
            .position(|(a, b)| a != b)
            .unwrap_or_else(|| got.lines().count().min(want.lines().count()))
            + 1;
        panic!(
            "docs/diagnostics.md is not the page the code tables give (first difference at \
             line {line}); regenerate it with `{REGENERATE}`"
        );
    }
}

/// The folders whose sources emit codes.
const EMITTERS: &[&str] = &[
    "crates/compiler/iec-syntax/src",
    "crates/compiler/iec-sema/src",
    "crates/compiler/iec-vm/src",
    "crates/compiler/iec/src",
    "crates/plc/config/src",
    "crates/petri/pnml/src",
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") && p.file_name().unwrap() != "codes.rs" {
            out.push(p);
        }
    }
}

/// `"E110"`-like literals of a text with the name of the constant its line defines, if any
/// (`NAME = "E110"`, `const NAME: &str = "P001"`).
fn code_literals(text: &str) -> Vec<(String, Option<String>)> {
    let mut out = Vec::new();
    for line in text.lines() {
        let b = line.as_bytes();
        for i in 0..b.len().saturating_sub(5) {
            let lit = &b[i..i + 6];
            if lit[0] == b'"'
                && lit[5] == b'"'
                && b"EWCP".contains(&lit[1])
                && lit[2..5].iter().all(u8::is_ascii_digit)
            {
                let code = String::from_utf8(lit[1..5].to_vec()).unwrap();
                let before = line[..i].trim_start().trim_start_matches("pub ");
                let before = before.trim_start_matches("const ");
                let name: String = before
                    .chars()
                    .take_while(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || *c == '_')
                    .collect();
                let rest = before[name.len()..].trim_start();
                let defines = !name.is_empty() && (rest.starts_with('=') || rest.starts_with(':'));
                out.push((code, defines.then_some(name)));
            }
        }
    }
    out
}

#[test]
fn every_code_has_an_entry_and_every_entry_is_emitted() {
    let entries: BTreeSet<&str> = groups()
        .iter()
        .flat_map(|g| g.entries.iter().map(|e: &Entry| e.code))
        .collect();
    let mut files = Vec::new();
    for dir in EMITTERS {
        rust_files(&root().join(dir), &mut files);
    }
    files.sort();
    let texts: Vec<(PathBuf, String)> = files
        .into_iter()
        .map(|f| {
            let t = fs::read_to_string(&f).unwrap();
            (f, t)
        })
        .collect();
    let mut problems = Vec::new();
    // Code → the constant that names it.
    let mut defined: BTreeMap<String, String> = BTreeMap::new();
    let mut literal: BTreeSet<String> = BTreeSet::new();
    for (file, text) in &texts {
        for (code, name) in code_literals(text) {
            if !entries.contains(code.as_str()) {
                problems.push(format!(
                    "{}: {code} has no entry in a codes.rs table",
                    file.display()
                ));
            }
            if let Some(name) = name {
                defined.insert(code.clone(), name);
            }
            literal.insert(code);
        }
    }
    for code in &entries {
        let Some(name) = defined.get(*code) else {
            if !literal.contains(*code) {
                problems.push(format!(
                    "{code} has an entry but no source defines or emits it"
                ));
            }
            continue;
        };
        // Used: the name appears more often than its one definition.
        let uses: usize = texts
            .iter()
            .map(|(_, t)| {
                t.match_indices(name.as_str())
                    .filter(|(i, _)| {
                        let before = t[..*i].chars().next_back();
                        let after = t[i + name.len()..].chars().next();
                        !before.is_some_and(|c| c.is_alphanumeric() || c == '_')
                            && !after.is_some_and(|c| c.is_alphanumeric() || c == '_')
                    })
                    .count()
            })
            .sum();
        if uses < 2 {
            problems.push(format!(
                "{code} ({name}) has an entry but nothing emits it: remove the code and its entry, or emit it"
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn scanning_finds_definitions_and_uses() {
    assert_eq!(
        code_literals("    BAD_CHAR = \"E001\",\npub const XML: &str = \"P001\";\nx(\"C021\")"),
        [
            ("E001".to_string(), Some("BAD_CHAR".to_string())),
            ("P001".to_string(), Some("XML".to_string())),
            ("C021".to_string(), None),
        ]
    );
}
