//! Integer overflow, shift counts and REAL-to-integer conversions, property-tested in both
//! overflow modes: random programs of operations on random types with values drawn near
//! their edges run one scan on machine code and on the VM (the same memory after the scan,
//! the same fault), and every result is what `petriplc_iec_sema::ops`, the checker's
//! constant folding, computes for it; in fault mode the scan faults exactly when one of the
//! operations leaves its type.

use std::cell::Cell;

use petriplc_iec::sema::ir::Builtin;
use petriplc_iec::sema::ops::{self, OpError};
use petriplc_iec::sema::types::Elem;
use petriplc_iec::sema::value::Value;
use petriplc_iec::sema::Overflow;
use petriplc_iec::syntax::ast::BinaryOp;
use petriplc_iec::vm::{Backend, Machine};
use petriplc_iec::{build, Natives, Select, Sources};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

const INTEGERS: [Elem; 8] = [
    Elem::Sint,
    Elem::Int,
    Elem::Dint,
    Elem::Lint,
    Elem::Usint,
    Elem::Uint,
    Elem::Udint,
    Elem::Ulint,
];
const BITS: [Elem; 4] = [Elem::Byte, Elem::Word, Elem::Dword, Elem::Lword];

/// One statement `r := …` of a generated program.
#[derive(Clone, Debug)]
enum Stmt {
    Bin(BinaryOp, Elem, i128, i128),
    Neg(Elem, i128),
    Abs(Elem, i128),
    Shift(Builtin, Elem, i128, i128),
    RealTo(Elem, f64),
}

/// A value of `e`, half of the time at or next to an end of its range.
fn value(e: Elem) -> impl Strategy<Value = i128> {
    let (lo, hi) = e.range();
    let edges = vec![lo, lo + 1, hi, hi - 1, 0, 1, (-1i128).max(lo)];
    prop_oneof![
        proptest::sample::select(edges),
        (0u64..=u64::MAX).prop_map(move |r| lo + (r as i128) % (hi - lo + 1)),
    ]
}

fn stmt() -> impl Strategy<Value = Stmt> {
    let int = proptest::sample::select(INTEGERS.to_vec());
    let signed = proptest::sample::select(vec![Elem::Sint, Elem::Int, Elem::Dint, Elem::Lint]);
    let op = proptest::sample::select(vec![
        BinaryOp::Add,
        BinaryOp::Sub,
        BinaryOp::Mul,
        BinaryOp::Div,
        BinaryOp::Mod,
    ]);
    let shift =
        proptest::sample::select(vec![Builtin::Shl, Builtin::Shr, Builtin::Rol, Builtin::Ror]);
    prop_oneof![
        4 => (op, int.clone()).prop_flat_map(|(op, e)| (value(e), value(e))
            .prop_map(move |(a, b)| Stmt::Bin(op, e, a, b))),
        1 => signed.clone().prop_flat_map(|e| value(e).prop_map(move |a| Stmt::Neg(e, a))),
        1 => signed.prop_flat_map(|e| value(e).prop_map(move |a| Stmt::Abs(e, a))),
        2 => (shift, proptest::sample::select(BITS.to_vec()), -70i128..70)
            .prop_flat_map(|(f, e, n)| value(e).prop_map(move |v| Stmt::Shift(f, e, v, n))),
        1 => (int, prop_oneof![-1e20f64..1e20, -70000.0f64..70000.0])
            .prop_map(|(e, f)| Stmt::RealTo(e, (f * 4.0).round() / 4.0)),
    ]
}

fn literal(e: Elem, v: i128) -> String {
    format!("{}#{v}", e.name())
}

/// Per statement: its result type and what `ops` says it gives.
type Expected = Vec<(Elem, Result<i128, OpError>)>;

/// The program, and what each statement must give.
fn program(stmts: &[Stmt], mode: Overflow) -> (String, Expected) {
    let mut vars = String::new();
    let mut body = String::new();
    let mut expect = Vec::new();
    for (i, s) in stmts.iter().enumerate() {
        let (e, text, want) = match *s {
            Stmt::Bin(op, e, a, b) => {
                vars += &format!(
                    "a{i} : {0} := {1}; b{i} : {0} := {2};\n",
                    e.name(),
                    literal(e, a),
                    literal(e, b)
                );
                let sym = match op {
                    BinaryOp::Add => "+",
                    BinaryOp::Sub => "-",
                    BinaryOp::Mul => "*",
                    BinaryOp::Div => "/",
                    _ => "MOD",
                };
                (
                    e,
                    format!("a{i} {sym} b{i}"),
                    ops::int_binary_in(op, a, b, e, mode),
                )
            }
            Stmt::Neg(e, a) => {
                vars += &format!("a{i} : {} := {};\n", e.name(), literal(e, a));
                (
                    e,
                    format!("-a{i}"),
                    ops::int_binary_in(BinaryOp::Sub, 0, a, e, mode),
                )
            }
            Stmt::Abs(e, a) => {
                vars += &format!("a{i} : {} := {};\n", e.name(), literal(e, a));
                let want = ops::int_binary_in(BinaryOp::Sub, 0, -a.abs(), e, mode);
                (e, format!("ABS(a{i})"), want)
            }
            Stmt::Shift(f, e, v, n) => {
                vars += &format!(
                    "a{i} : {} := {}; n{i} : INT := {n};\n",
                    e.name(),
                    literal(e, v)
                );
                (
                    e,
                    format!("{}(a{i}, n{i})", f.name()),
                    ops::shift(f, v, n, e, mode),
                )
            }
            Stmt::RealTo(e, f) => {
                vars += &format!("f{i} : LREAL := {};\n", ops::format_real(f, Elem::Lreal));
                (
                    e,
                    format!("LREAL_TO_{}(f{i})", e.name()),
                    ops::real_to_int(f, e, mode),
                )
            }
        };
        vars += &format!("r{i} : {};\n", e.name());
        body += &format!("r{i} := {text};\n");
        expect.push((e, want));
    }
    (
        format!("PROGRAM main\nVAR\n{vars}END_VAR\n{body}END_PROGRAM\n"),
        expect,
    )
}

/// Runs one program in one mode; the problem found, if any.
fn check(stmts: &[Stmt], mode: Overflow) -> Result<(), String> {
    let (text, expect) = program(stmts, mode);
    let mut sources = Sources::new();
    sources.overflow = mode;
    sources.add_text("p.st", &text);
    let engine = build(&sources, &Select::Auto, Natives::default())
        .map_err(|e| format!("does not compile:\n{e}\n{text}"))?
        .engine;
    if !engine.is_compiled() {
        return Err(format!("no machine code for\n{text}"));
    }
    let mut jit = Machine::new(engine.clone());
    let mut vm = Machine::new(engine.clone());
    vm.set_backend(Backend::Vm);
    let a = jit.scan(0, &mut || true).map_err(|f| f.to_string());
    let b = vm.scan(0, &mut || true).map_err(|f| f.to_string());
    if a != b {
        return Err(format!("machine code gave {a:?}, the VM {b:?}\n{text}"));
    }
    let slots = engine.code.init.len() as u32;
    if let Some(s) = (0..slots).find(|&s| jit.slot(s) != vm.slot(s)) {
        return Err(format!("machine code and VM differ at slot {s}\n{text}"));
    }
    // The first statement that has no value faults the scan; those before it are stored.
    let first_err = expect.iter().position(|(_, w)| w.is_err());
    match (first_err, &a) {
        (None, Err(f)) => return Err(format!("faulted ({f}) where ops gives values\n{text}")),
        (Some(k), Ok(())) => {
            return Err(format!(
                "statement {k} should fault ({:?})\n{text}",
                expect[k].1
            ))
        }
        (Some(k), Err(f)) => {
            let kind = match expect[k].1 {
                Err(OpError::Overflow) => "overflow",
                Err(OpError::DivisionByZero) => "division by zero",
                Err(OpError::Conversion) => "conversion error",
                Err(OpError::Domain(w)) => w,
                Ok(_) => unreachable!(),
            };
            // PROGRAM, VAR, two declaration lines per statement, END_VAR, then the body.
            let line = 2 * stmts.len() + 4 + k;
            if !f.contains(kind) || !f.contains(&format!("p.st:{line}:")) {
                return Err(format!(
                    "statement {k}: `{f}`, expected {kind} at its line\n{text}"
                ));
            }
        }
        (None, Ok(())) => {}
    }
    for (i, (e, want)) in expect
        .iter()
        .enumerate()
        .take(first_err.unwrap_or(expect.len()))
    {
        let r = engine
            .lookup(&format!("main.r{i}"))
            .expect("a result variable");
        let got = jit.get(r);
        let want = Value::Int(*want.as_ref().expect("a value"));
        if got.as_ref() != Some(&want) {
            return Err(format!(
                "r{i} : {} = {got:?}, ops gives {want:?}\n{text}",
                e.name()
            ));
        }
    }
    Ok(())
}

#[test]
fn operations_give_what_ops_computes_on_machine_code_and_vm_in_both_modes() {
    let mut runner = TestRunner::new_with_rng(
        Config {
            cases: 160,
            failure_persistence: None,
            ..Config::default()
        },
        proptest::test_runner::TestRng::deterministic_rng(Config::default().rng_algorithm),
    );
    let faults = [Cell::new(0usize), Cell::new(0usize)];
    let stmts_run = Cell::new(0usize);
    runner
        .run(&proptest::collection::vec(stmt(), 1..12), |stmts| {
            stmts_run.set(stmts_run.get() + stmts.len());
            for (k, mode) in [Overflow::Wrap, Overflow::Fault].into_iter().enumerate() {
                let (_, expect) = program(&stmts, mode);
                let faulting = usize::from(expect.iter().any(|(_, w)| w.is_err()));
                faults[k].set(faults[k].get() + faulting);
                check(&stmts, mode).map_err(TestCaseError::fail)?;
            }
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
    let stmts_run = stmts_run.get();
    eprintln!(
        "overflow: {stmts_run} statements in 160 programs, run in both modes; programs that fault: {} wrapping, {} in fault mode",
        faults[0].get(),
        faults[1].get()
    );
    // The generator reaches both sides of the rule: wrap mode faults only on division by
    // zero and non-finite conversions, fault mode on every overflow too.
    assert!(
        faults[1].get() > faults[0].get(),
        "{faults:?} after {stmts_run} statements"
    );
}
