//! The IEC 61131-3 parser crates of crates.io (iec61131 0.7.0, iecst 0.5.1, ironplc-parser
//! 0.1.1, plcopen 0.3.1) against petriplc's parser: constructs parsed (the conformance
//! corpus), positions of errors (errors/*.st, each naming where its error is), how many
//! errors one run reports, and speed. Prints a Markdown table for docs/iec.md.
//!
//! Run from the repository root: `cargo run --release --manifest-path bench/iec-parsers/Cargo.toml`

use std::path::{Path, PathBuf};
use std::time::Instant;

/// What a parser says about one source: Ok, or the byte offsets of the errors it reports.
type Outcome = Result<(), Vec<usize>>;

struct Candidate {
    name: &'static str,
    parse: fn(&str) -> Outcome,
}

fn petriplc(src: &str) -> Outcome {
    use petriplc_iec_syntax::{parse, Diagnostics, FileId};
    let mut d = Diagnostics::new();
    parse(FileId(0), src, &mut d);
    if d.has_errors() {
        Err(d.errors().map(|e| e.span.start as usize).collect())
    } else {
        Ok(())
    }
}

fn iec61131(src: &str) -> Outcome {
    let mut p = iec61131::Parser::new(src);
    match p.parse() {
        Ok(_) => Ok(()),
        Err(e) => Err(vec![e.span.start]),
    }
}

/// iecst parses one POU or TYPE block at a time: the source is cut at its top-level
/// keywords; a CONFIGURATION (which it has no parser for) counts as a failure.
fn iecst(src: &str) -> Outcome {
    let mut starts = Vec::new();
    let mut offset = 0;
    for line in src.split_inclusive('\n') {
        let t = line.trim_start().to_ascii_uppercase();
        if ["PROGRAM ", "FUNCTION ", "FUNCTION_BLOCK ", "TYPE", "CONFIGURATION ", "VAR_GLOBAL"]
            .iter()
            .any(|k| t.starts_with(k))
        {
            starts.push(offset);
        }
        offset += line.len();
    }
    starts.push(src.len());
    for w in starts.windows(2) {
        let chunk = &src[w[0]..w[1]];
        let t = chunk.trim_start().to_ascii_uppercase();
        let r = if t.starts_with("TYPE") {
            iecst::parse_type_block(chunk).map(|_| ())
        } else if t.starts_with("CONFIGURATION") || t.starts_with("VAR_GLOBAL") {
            return Err(vec![w[0]]);
        } else {
            iecst::parse_pou(chunk).map(|_| ())
        };
        if let Err(e) = r {
            return Err(vec![w[0] + e.span.start]);
        }
    }
    Ok(())
}

fn ironplc(src: &str) -> Outcome {
    match ironplc_parser::parse_program(src) {
        Ok(_) => Ok(()),
        Err(e) => Err(vec![e.location.offset]),
    }
}

fn line_col(src: &str, offset: usize) -> (usize, usize) {
    let before = &src[..offset.min(src.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

fn files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    v
}

/// `(* error at L:C *)` / `(* errors at L:C, L:C *)`.
fn expected(src: &str) -> Vec<(usize, usize)> {
    let head = src.lines().next().unwrap_or("");
    let list = head.split(" at ").nth(1).unwrap_or("").trim_end_matches("*)").trim();
    list.split(',')
        .filter_map(|p| {
            let (l, c) = p.trim().split_once(':')?;
            Some((l.parse().ok()?, c.trim().parse().ok()?))
        })
        .collect()
}

fn main() {
    let corpus = files(Path::new("crates/compiler/iec/tests/corpus"), "st");
    let errors = files(Path::new("bench/iec-parsers/errors"), "st");
    let sources: Vec<(PathBuf, String)> = corpus
        .iter()
        .map(|p| (p.clone(), std::fs::read_to_string(p).unwrap()))
        .collect();
    let big = std::env::args().nth(1).map(|p| std::fs::read_to_string(p).unwrap());
    let candidates = [
        Candidate { name: "petriplc-iec-syntax", parse: petriplc },
        Candidate { name: "iec61131 0.7.0", parse: iec61131 },
        Candidate { name: "iecst 0.5.1", parse: iecst },
        Candidate { name: "ironplc-parser 0.1.1", parse: ironplc },
    ];
    println!("| parser | corpus programs parsed (of {}) | error lines right (of {}) | exact line:col | errors reported for the 3-error file | corpus parse time | large file |", sources.len(), errors.len());
    println!("|---|---|---|---|---|---|---|");
    for c in &candidates {
        let mut ok = 0;
        let mut refused = Vec::new();
        for (p, s) in &sources {
            match std::panic::catch_unwind(|| (c.parse)(s)) {
                Ok(Ok(())) => ok += 1,
                _ => refused.push(p.file_name().unwrap().to_string_lossy().into_owned()),
            }
        }
        let mut right_line = 0;
        let mut exact = 0;
        let mut multi = 0;
        for p in &errors {
            let s = std::fs::read_to_string(p).unwrap();
            let want = expected(&s);
            let got = match std::panic::catch_unwind(|| (c.parse)(&s)) {
                Ok(Err(offsets)) => offsets,
                _ => Vec::new(),
            };
            if want.len() > 1 {
                multi = got.len();
            }
            // The first error in the file (a parser may list lexical errors before syntax ones).
            if let (Some(w), Some(g)) = (want.first(), got.iter().min()) {
                let (l, col) = line_col(&s, *g);
                if l == w.0 {
                    right_line += 1;
                    if col == w.1 {
                        exact += 1;
                    }
                }
            }
        }
        let t = Instant::now();
        let reps = 20;
        for _ in 0..reps {
            for (_, s) in &sources {
                let _ = std::panic::catch_unwind(|| (c.parse)(s));
            }
        }
        let per = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
        let large = match &big {
            Some(b) => {
                let t = Instant::now();
                let r = (c.parse)(b);
                format!(
                    "{} in {:.0} ms",
                    if r.is_ok() { "parsed" } else { "refused" },
                    t.elapsed().as_secs_f64() * 1e3
                )
            }
            None => "-".into(),
        };
        println!(
            "| {} | {ok} | {right_line} | {exact} | {multi} | {per:.1} ms | {large} |",
            c.name
        );
        if std::env::var_os("SHOW_REFUSED").is_some() {
            eprintln!("{} refuses: {}", c.name, refused.join(" "));
        }
    }
    // PLCopen XML: the samples, what `petriplc compile` writes and a CODESYS-style export.
    let mut xml = files(Path::new("../shared/schemas/plcopen/samples"), "xml");
    xml.extend(files(Path::new("crates/compiler/iec/tests/data"), "xml"));
    let mut ours = 0;
    let mut theirs = 0;
    let mut their_st = 0;
    for p in &xml {
        let s = std::fs::read_to_string(p).unwrap();
        let mut map = petriplc_iec_syntax::SourceMap::new();
        let mut d = petriplc_iec_syntax::Diagnostics::new();
        let lib = petriplc_iec_syntax::plcopen::read(&mut map, "x.xml", &s, &mut d);
        if !d.has_errors() && !lib.elements.is_empty() {
            ours += 1;
        }
        if std::panic::catch_unwind(|| plcopen::from_str::<plcopen::Project>(&s).is_ok()).unwrap_or(false) {
            theirs += 1;
        }
        let bodies = plcopen::st::extract_all_st_from_xml(&s);
        if bodies.iter().all(|(_, st)| plcopen::st::parse_st(st).is_ok()) {
            their_st += 1;
        }
    }
    println!();
    println!(
        "PLCopen XML ({} files): petriplc reads {ours} without a syntax error; plcopen 0.3.1 deserialises {theirs}, and parses every ST body of {their_st} with iec61131",
        xml.len()
    );
}
