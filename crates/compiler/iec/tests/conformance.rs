//! The conformance corpus: small Structured Text programs (tests/corpus/*.st) and Instruction
//! List programs (tests/corpus-il/*.il), each with the values its variables must have after
//! given scans, written in its first comment:
//!
//! ```text
//! (* What the program shows.
//!    period: T#100ms                  scan period (default T#10ms)
//!    set 2: go = TRUE                 before scan 2
//!    after 3: n = 5, s = 'ab', t = T#1s, r = 1.5
//!    fault 4: division by zero        scan 4 fails with a message containing this
//!    overflow fault 3: leaves 0..255  run again with `overflow = fault`: the same values
//!                                     before scan 3, and scan 3 fails so
//! *)
//! ```
//!
//! Programs run with the default overflow rule (wrap); a program with an `overflow fault`
//! line runs a second time in fault mode, so both rules are tested by the same program.
//!
//! Names are the program's variables (`x`, `inst.q`, `a[2]`), or `instance.var` and globals
//! for a configuration. BOOL is 1/0 (TRUE/FALSE accepted), reals compare with a relative
//! tolerance of 1e-6 (`NaN`, `inf`, `-inf` as written), everything else as the trace prints it.
//!
//! Every ST program must also parse with blark, a third-party IEC 61131-3 grammar (pinned;
//! scripts/test-all.sh installs it): a program blark refuses is not standard. blark has no
//! CONFIGURATION grammar (TwinCAT configures tasks outside the source), so the CONFIGURATION
//! block of a corpus file is left out of what blark reads.

use std::path::{Path, PathBuf};
use std::process::Command;

use petriplc_iec::{build, Natives, Select, Sources};
use petriplc_iec_sema::types::{Elem, Type};
use petriplc_iec_sema::Overflow;
use petriplc_iec_vm::{display, Backend, Machine};

const CORPUS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/corpus");
/// Instruction List programs (`*.il`), with the same header format.
const CORPUS_IL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/corpus-il");
/// ST programs using standard or widely accepted forms that blark's grammar refuses (AND,
/// OR, XOR, MOD called as functions), with the same header format; not given to blark.
const CORPUS_LENIENT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/corpus-lenient");
/// Programs with the standard's `REF_TO`, which blark's grammar (TwinCAT's, with `POINTER TO`
/// instead) lacks: run like the others, not given to blark.
const CORPUS_REF: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/corpus-ref");

#[derive(Debug, Default)]
struct Spec {
    period_ns: i64,
    sets: Vec<(usize, String, String)>,
    checks: Vec<(usize, String, String)>,
    fault: Option<(usize, String)>,
    /// The fault in `overflow = fault` mode.
    overflow_fault: Option<(usize, String)>,
    scans: usize,
}

/// Splits `a = 1, s = 'x, y'` at the commas outside quotes.
fn assignments(text: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut cur = String::new();
    // The quote a STRING ('…') or WSTRING ("…") value is in.
    let mut quote: Option<char> = None;
    let mut escaped = false;
    let mut depth = 0;
    for c in text.chars() {
        let quoted = quote.is_some();
        if escaped {
            escaped = false;
            cur.push(c);
            continue;
        }
        match c {
            '$' if quoted => {
                escaped = true;
                cur.push(c);
            }
            '\'' | '"' if quote.is_none_or(|q| q == c) => {
                quote = if quoted { None } else { Some(c) };
                cur.push(c);
            }
            '[' if !quoted => {
                depth += 1;
                cur.push(c);
            }
            ']' if !quoted => {
                depth -= 1;
                cur.push(c);
            }
            ',' if !quoted && depth == 0 => {
                out.push(std::mem::take(&mut cur));
            }
            _ => cur.push(c),
        }
    }
    out.push(cur);
    out.into_iter()
        .filter(|a| !a.trim().is_empty())
        .map(|a| {
            let (n, v) = a
                .split_once('=')
                .unwrap_or_else(|| panic!("`{a}` is not name = value"));
            (n.trim().to_string(), v.trim().to_string())
        })
        .collect()
}

fn parse_spec(path: &Path, text: &str) -> Spec {
    let start = text
        .find("(*")
        .unwrap_or_else(|| panic!("{}: no header comment", path.display()));
    let end = text[start..].find("*)").map(|e| start + e).unwrap();
    let mut spec = Spec {
        period_ns: 10_000_000,
        ..Spec::default()
    };
    for line in text[start + 2..end].lines() {
        let line = line.trim();
        let scan = |rest: &str| -> (usize, String) {
            let (n, body) = rest
                .split_once(':')
                .unwrap_or_else(|| panic!("{}: `{line}`", path.display()));
            (
                n.trim()
                    .parse()
                    .unwrap_or_else(|_| panic!("{}: `{line}`", path.display())),
                body.trim().to_string(),
            )
        };
        if let Some(rest) = line.strip_prefix("period:") {
            let d = petriplc_net::time::parse_duration(rest.trim()).unwrap();
            spec.period_ns = d.as_nanos() as i64;
        } else if let Some(rest) = line.strip_prefix("after ") {
            let (n, body) = scan(rest);
            for (name, value) in assignments(&body) {
                spec.checks.push((n, name, value));
            }
            spec.scans = spec.scans.max(n);
        } else if let Some(rest) = line.strip_prefix("set ") {
            let (n, body) = scan(rest);
            for (name, value) in assignments(&body) {
                spec.sets.push((n, name, value));
            }
        } else if let Some(rest) = line.strip_prefix("overflow fault ") {
            spec.overflow_fault = Some(scan(rest));
        } else if let Some(rest) = line.strip_prefix("fault ") {
            let (n, body) = scan(rest);
            spec.fault = Some((n, body));
            spec.scans = spec.scans.max(n);
        }
    }
    assert!(
        spec.scans > 0,
        "{}: no `after N:` or `fault N:` line",
        path.display()
    );
    spec
}

/// An integer written as an IEC literal (`16#FF`, `2#1010`, `1_000`, `-5`).
fn iec_int(text: &str) -> Option<i128> {
    let t = text.replace('_', "");
    let (neg, t) = match t.strip_prefix('-') {
        Some(r) => (true, r.to_string()),
        None => (false, t),
    };
    let v = match t.split_once('#') {
        Some((base, digits)) => i128::from_str_radix(digits, base.parse().ok()?).ok()?,
        None => t.parse().ok()?,
    };
    Some(if neg { -v } else { v })
}

fn same(expected: &str, actual: &str, real: bool) -> bool {
    let e = match expected.to_ascii_uppercase().as_str() {
        "TRUE" => "1".to_string(),
        "FALSE" => "0".to_string(),
        _ => match iec_int(expected) {
            Some(v) if expected.contains('#') || expected.contains('_') => v.to_string(),
            _ => expected.to_string(),
        },
    };
    if real {
        if let (Ok(a), Ok(b)) = (e.parse::<f64>(), actual.parse::<f64>()) {
            return a == b
                || (a.is_nan() && b.is_nan())
                || (a - b).abs() <= 1e-12
                || (a - b).abs() <= 1e-6 * a.abs().max(b.abs());
        }
    }
    e == actual
}

/// Runs one corpus program (and again in fault mode when it says what that does); returns
/// its problems.
fn run(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let spec = parse_spec(path, &text);
    let mut problems = run_in(path, &spec, Overflow::Wrap);
    if let Some((n, text)) = spec.overflow_fault.clone() {
        let faulting = Spec {
            checks: spec.checks.iter().filter(|c| c.0 < n).cloned().collect(),
            sets: spec.sets.iter().filter(|c| c.0 <= n).cloned().collect(),
            fault: Some((n, text)),
            scans: n,
            ..spec
        };
        for p in run_in(path, &faulting, Overflow::Fault) {
            problems.push(format!("with overflow = fault: {p}"));
        }
    }
    problems
}

fn run_in(path: &Path, spec: &Spec, overflow: Overflow) -> Vec<String> {
    let mut sources = Sources::new();
    sources.overflow = overflow;
    let built = sources
        .add_file(path)
        .and_then(|()| build(&sources, &Select::Auto, Natives::default()));
    let build = match built {
        Ok(b) => b,
        Err(e) => return vec![format!("does not compile:\n{e}")],
    };
    let engine = build.engine.clone();
    if !engine.is_compiled() {
        return vec!["no machine code was made for it".into()];
    }
    let mut m = Machine::new(engine.clone());
    // Endless loops are caught after 100 000 iterations (the default budget is larger).
    m.iterations = 100_000;
    // The bytecode VM runs it in step with the machine code: the same memory after every
    // scan, the same faults with the same messages.
    let mut vm = Machine::new(engine.clone());
    vm.set_backend(Backend::Vm);
    vm.iterations = 100_000;
    let slots = engine.code.init.len() as u32;
    let only = (engine.instances().len() == 1).then(|| engine.instances()[0].name.clone());
    let lookup = |name: &str| {
        only.as_ref()
            .and_then(|i| engine.lookup(&format!("{i}.{name}")))
            .or_else(|| engine.lookup(name))
    };
    let mut problems = Vec::new();
    for k in 1..=spec.scans {
        for (_, name, value) in spec.sets.iter().filter(|s| s.0 == k) {
            let Some(v) = lookup(name) else {
                problems.push(format!("set {k}: no variable {name}"));
                continue;
            };
            let val = match value.to_ascii_uppercase().as_str() {
                "TRUE" => petriplc_iec_sema::value::Value::Int(1),
                "FALSE" => petriplc_iec_sema::value::Value::Int(0),
                _ => match value.parse::<i128>() {
                    Ok(i) => petriplc_iec_sema::value::Value::Int(i),
                    Err(_) => match value.parse::<f64>() {
                        Ok(f) => petriplc_iec_sema::value::Value::Real(f),
                        Err(_) => petriplc_iec_sema::value::Value::Str(
                            value.trim_matches('\'').as_bytes().to_vec(),
                        ),
                    },
                },
            };
            if let Err(e) = m.set(v, &val) {
                problems.push(format!("set {k}: {name} = {value}: {e}"));
            }
            let _ = vm.set(v, &val);
        }
        let now = (k as i64 - 1) * spec.period_ns;
        let r = m.scan(now, &mut || true);
        let rv = vm.scan(now, &mut || true);
        let (a, b) = (
            r.as_ref().map_err(|f| f.to_string()),
            rv.as_ref().map_err(|f| f.to_string()),
        );
        if a != b {
            problems.push(format!("scan {k}: machine code gave {a:?}, the VM {b:?}"));
        }
        if let Some(a) = (0..slots).find(|&a| m.slot(a) != vm.slot(a)) {
            problems.push(format!(
                "scan {k}: machine code and VM differ at slot {a}: {} vs {}",
                m.slot(a),
                vm.slot(a)
            ));
        }
        match (&spec.fault, r) {
            (Some((n, text)), Err(f)) if *n == k => {
                let msg = f.to_string();
                if !msg.contains(text.as_str()) {
                    problems.push(format!(
                        "scan {k} faulted with `{msg}`, expected one containing `{text}`"
                    ));
                }
                return problems;
            }
            (Some((n, _)), Ok(())) if *n == k => {
                problems.push(format!("scan {k} should fault but did not"));
                return problems;
            }
            (_, Err(f)) => {
                problems.push(format!("scan {k} faulted: {f}"));
                return problems;
            }
            _ => {}
        }
        for (_, name, expected) in spec.checks.iter().filter(|c| c.0 == k) {
            let Some(v) = lookup(name) else {
                problems.push(format!("after {k}: no variable {name}"));
                continue;
            };
            let real = matches!(
                engine.project.types.get(v.ty),
                Type::Elem(Elem::Real | Elem::Lreal)
            );
            let actual = m
                .get(v)
                .map_or_else(|| "?".into(), |x| display(&engine.project, v.ty, &x));
            if !same(expected, &actual, real) {
                problems.push(format!("after {k}: {name} = {actual}, expected {expected}"));
            }
        }
    }
    problems
}

fn corpus() -> Vec<PathBuf> {
    files_of(CORPUS, "st")
}

fn files_of(dir: &str, ext: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    files.sort();
    files
}

#[test]
fn every_corpus_program_gives_its_expected_values() {
    check_corpus(&corpus(), 150);
}

#[test]
fn every_lenient_corpus_program_gives_its_expected_values() {
    check_corpus(&files_of(CORPUS_LENIENT, "st"), 1);
}

#[test]
fn every_ref_to_corpus_program_gives_its_expected_values() {
    check_corpus(&files_of(CORPUS_REF, "st"), 3);
}

#[test]
fn every_il_corpus_program_gives_its_expected_values() {
    check_corpus(&files_of(CORPUS_IL, "il"), 60);
}

fn check_corpus(files: &[PathBuf], at_least: usize) {
    let mut failures = Vec::new();
    for f in files {
        let t = std::time::Instant::now();
        let problems = run(f);
        if std::env::var_os("CORPUS_TIMES").is_some() {
            eprintln!(
                "{:>8.1} ms {}",
                t.elapsed().as_secs_f64() * 1e3,
                f.display()
            );
        }
        if !problems.is_empty() {
            failures.push(format!("{}:\n  {}", f.display(), problems.join("\n  ")));
        }
    }
    eprintln!("conformance: {} programs", files.len());
    assert!(
        files.len() >= at_least,
        "the corpus has {} programs; it needs at least {at_least}",
        files.len()
    );
    assert!(
        failures.is_empty(),
        "{} of {} programs fail:\n{}",
        failures.len(),
        files.len(),
        failures.join("\n")
    );
}

/// The program text blark reads: the file without its CONFIGURATION.
fn for_blark(text: &str) -> String {
    let mut out = String::new();
    let mut skipping = false;
    for line in text.lines() {
        let upper = line.trim_start().to_ascii_uppercase();
        if upper.starts_with("CONFIGURATION ") {
            skipping = true;
        }
        if !skipping {
            out.push_str(line);
        }
        // Keep the line count, so blark's line numbers stay those of the file.
        out.push('\n');
        if skipping && upper.contains("END_CONFIGURATION") {
            skipping = false;
        }
    }
    out
}

/// blark's Python, with its parser run on every file separately in one process (one file's
/// lexical state must not leak into the next: blark's comment stripper mistakes `'$$'` for
/// an escaped quote, harmless within a file's last string but not across files).
fn python() -> PathBuf {
    std::env::var_os("PETRIPLC_PYTHON").map_or_else(
        || {
            PathBuf::from(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../../target/py/bin/python"
            ))
        },
        PathBuf::from,
    )
}

const BLARK_DRIVER: &str = r#"
import sys
from blark import parse
failed = 0
for path in sys.argv[1:]:
    for res in parse.parse(path):
        if res.exception is not None:
            failed += 1
            print(f"{path}: {res.exception}")
sys.exit(1 if failed else 0)
"#;

#[test]
fn blark_parses_every_corpus_program() {
    let py = python();
    assert!(
        py.exists(),
        "{} not found: scripts/test-all.sh installs blark 0.8.3 into target/py (or set PETRIPLC_PYTHON)",
        py.display()
    );
    let dir = std::env::temp_dir().join(format!("petriplc-corpus-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut paths = Vec::new();
    for f in corpus() {
        let to = dir.join(f.file_name().unwrap());
        std::fs::write(&to, for_blark(&std::fs::read_to_string(&f).unwrap())).unwrap();
        paths.push(to);
    }
    // Two processes, one per half of the corpus (blark takes a while per file).
    let half = paths.len().div_ceil(2);
    let children: Vec<_> = paths
        .chunks(half.max(1))
        .map(|chunk| {
            Command::new(&py)
                .arg("-c")
                .arg(BLARK_DRIVER)
                .args(chunk)
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .expect("python runs")
        })
        .collect();
    let outs: Vec<_> = children
        .into_iter()
        .map(|c| c.wait_with_output().expect("python runs"))
        .collect();
    let _ = std::fs::remove_dir_all(&dir);
    let mut report = String::new();
    for out in &outs {
        report.push_str(&String::from_utf8_lossy(&out.stdout));
        report.push_str(&String::from_utf8_lossy(&out.stderr));
    }
    assert!(
        outs.iter().all(|o| o.status.success()),
        "blark refuses corpus programs:\n{report}"
    );
    eprintln!("blark parsed {} corpus programs", paths.len());
}

/// The LD and SFC corpus: PLCopen XML projects (tests/corpus-graphical/*.xml), each with its
/// expected values in the same header, inside an XML comment (`<!-- (* … *) -->`).
fn graphical_corpus() -> Vec<PathBuf> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/corpus-graphical");
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    files.sort();
    files
}

#[test]
fn every_graphical_corpus_project_gives_its_expected_values() {
    let files = graphical_corpus();
    let failures: Vec<String> = files
        .iter()
        .filter_map(|f| {
            let problems = run(f);
            (!problems.is_empty()).then(|| format!("{}:\n  {}", f.display(), problems.join("\n  ")))
        })
        .collect();
    let count = |prefix: &str| {
        files
            .iter()
            .filter(|f| f.file_name().unwrap().to_string_lossy().starts_with(prefix))
            .count()
    };
    eprintln!(
        "conformance: {} LD and {} SFC projects",
        count("ld"),
        count("sfc")
    );
    assert!(
        files.len() >= 20,
        "the LD/SFC corpus has {} projects; it needs at least 20",
        files.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Every LD/SFC corpus project is valid TC6 v2.01 XML (xmllint against the schema).
#[test]
fn graphical_corpus_projects_are_valid_tc6_xml() {
    let schema = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../testdata/schemas/plcopen/tc6_xml_v201.xsd"
    );
    let files = graphical_corpus();
    let out = Command::new("xmllint")
        .args(["--noout", "--schema", schema])
        .args(&files)
        .output()
        .unwrap_or_else(|e| {
            panic!("cannot run xmllint ({e}); the corpus is validated with it: apt-get install libxml2-utils")
        });
    assert!(
        out.status.success(),
        "xmllint --schema {schema}:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
