//! The engine on the ST (and the IL, `iec/scan-il`) `petriplc compile` writes for N copies of seed 002's mixer
//! (examples/mixer/mixer.pnml with SIPN names, copy k's names suffixed _k): one scan with
//! every input TRUE (each copy fires a transition every scan), and the compile time of the
//! 1000-copy program (parse, check, compile). bench/iec_scan.sh runs the C that
//! `petriplc compile --lang c` writes for the same nets beside it.
//!
//! Run: `cargo bench -p petriplc-iec --bench scan`

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use petriplc_codegen::{generate, Form, Language, Options, Request};
use petriplc_iec::{build_text, Select};
use petriplc_iec_sema::ir::VarClass;
use petriplc_iec_sema::value::Value;
use petriplc_iec_vm::Machine;
use petriplc_pnml::{Naming, ReadOptions};

const MIXER: &str = include_str!("../../../../examples/mixer/mixer.pnml");

/// N copies of the mixer's places, transitions and arcs, ids and names suffixed `_k`
/// (what bench/iec/mixer_copies.py writes).
fn mixer_copies(n: usize) -> String {
    let (head, rest) = MIXER.split_once("<page id=\"page0\">").unwrap();
    let (body, tail) = rest.rsplit_once("</page>").unwrap();
    let mut out = format!("{head}<page id=\"page0\">");
    for k in 0..n {
        let mut b = String::new();
        let mut rest = body;
        // ids and arc ends, then the names (upper-case words in <text>).
        while let Some(i) = rest.find("=\"") {
            let attr_start = rest[..i].rfind(' ').map_or(0, |s| s + 1);
            let attr = &rest[attr_start..i];
            let end = i + 2 + rest[i + 2..].find('"').unwrap();
            b.push_str(&rest[..i + 2]);
            b.push_str(&rest[i + 2..end]);
            if matches!(attr, "id" | "source" | "target") {
                b.push_str(&format!("_{k}"));
            }
            rest = &rest[end..];
        }
        b.push_str(rest);
        let mut named = String::new();
        let mut r = b.as_str();
        while let Some(i) = r.find("<text>") {
            let end = i + 6 + r[i + 6..].find("</text>").unwrap();
            let word = &r[i + 6..end];
            named.push_str(&r[..i + 6]);
            named.push_str(word);
            if word.chars().next().is_some_and(|c| c.is_ascii_uppercase()) {
                named.push_str(&format!("_{k}"));
            }
            r = &r[end..];
        }
        named.push_str(r);
        out.push_str(&named);
    }
    out.push_str("</page>");
    out.push_str(tail);
    out
}

/// The plain ST `petriplc compile --names sipn --lang st --plain` writes for N copies.
fn st(n: usize) -> String {
    text(n, Language::St)
}

/// The plain ST or IL `petriplc compile --names sipn --plain` writes for N copies.
fn text(n: usize, language: Language) -> String {
    let net = petriplc_pnml::read_str(
        &mixer_copies(n),
        "mixer.pnml",
        &ReadOptions {
            naming: Naming::Sipn,
        },
    )
    .unwrap()
    .net;
    let request = Request {
        language,
        form: Form::Plain,
        options: Options::of(&net),
        created: "2026-01-01T00:00:00".into(),
    };
    generate(&net, &request).unwrap().text
}

fn scan(c: &mut Criterion) {
    for (group_name, language, file) in [
        ("iec/scan", Language::St, "mixer.st"),
        ("iec/scan-il", Language::Il, "mixer.il"),
    ] {
        scan_group(c, group_name, language, file);
    }
    compile(c);
}

/// One scan of N copies in one language.
fn scan_group(c: &mut Criterion, group_name: &str, language: Language, file: &str) {
    let mut group = c.benchmark_group(group_name);
    for n in [1usize, 100, 1000] {
        let text = text(n, language);
        let build = build_text(file, &text, &Select::Auto).unwrap();
        let engine = build.engine.clone();
        let mut m = Machine::new(engine.clone());
        let inst = engine.instances()[0].name.clone();
        for (name, class, _) in engine.instance_vars(0) {
            if class == VarClass::Input {
                let v = engine.lookup(&format!("{inst}.{name}")).unwrap();
                m.set(v, &Value::Int(1)).unwrap();
            }
        }
        let mut now = 0i64;
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                now += 10_000_000;
                m.scan(black_box(now), &mut || true).unwrap();
            })
        });
    }
    group.finish();
}

fn compile(c: &mut Criterion) {
    let text = st(1000);
    let mut group = c.benchmark_group("iec/compile");
    group.sample_size(10);
    group.bench_function("1000", |b| {
        b.iter(|| build_text("mixer.st", black_box(&text), &Select::Auto).unwrap())
    });
    group.finish();
}

criterion_group!(benches, scan);
criterion_main!(benches);
