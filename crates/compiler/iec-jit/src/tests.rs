//! Machine code against the VM: small ST programs run scan by scan on both, every variable
//! equal after every scan, faults with the same message; and the VM behind the JIT when it
//! does not compile.

use std::sync::Arc;

use petriplc_iec_sema::{Options, Overflow};
use petriplc_iec_syntax::{Diagnostics, SourceMap};
use petriplc_iec_vm::{display, native, Backend, Engine, InstanceSpec, Machine};

use crate::{compile, compile_limited};

/// `source` checked and compiled for its only PROGRAM, with `max_ops` as the JIT's limit.
fn engine(source: &str, max_ops: usize) -> Arc<Engine> {
    engine_in(source, max_ops, Overflow::default())
}

/// [`engine`] with an overflow rule.
fn engine_in(source: &str, max_ops: usize, overflow: Overflow) -> Arc<Engine> {
    let mut map = SourceMap::new();
    let f = map.add("t.st", source);
    let mut diags = Diagnostics::new();
    let lib = petriplc_iec_syntax::parse(f, source, &mut diags);
    assert!(!diags.has_errors(), "{}", diags.render(&map));
    let options = Options {
        overflow,
        ..Options::default()
    };
    let (project, diags) = petriplc_iec_sema::check(&lib, &options);
    let project = project.unwrap_or_else(|| panic!("{}", diags.render(&map)));
    let (pou, program) = project.programs().next().expect("a PROGRAM");
    let spec = InstanceSpec {
        name: program.name.clone(),
        pou,
        task: None,
        inputs: Vec::new(),
        outputs: Vec::new(),
    };
    let mut engine =
        Engine::new(project, &[spec], native::standard(), &map).unwrap_or_else(|e| panic!("{e}"));
    Arc::get_mut(&mut engine)
        .expect("no machine yet")
        .set_compiler(Box::new(move |e| {
            compile_limited(e, max_ops)
                .ok()
                .map(|j| Box::new(j) as Box<dyn petriplc_iec_vm::Compiled>)
        }));
    engine
}

/// Every variable of the program instance, rendered `name=value`; an aggregate (array,
/// structure, instance) as its raw slots.
fn state(m: &Machine) -> String {
    let e = m.engine();
    e.instance_vars(0)
        .iter()
        .map(|(name, _, _)| {
            let path = format!("{}.{name}", e.code.instances[0].name);
            let r = e.lookup(&path).unwrap_or_else(|| panic!("no {path}"));
            match m.get(r) {
                Some(v) => format!("{name}={}", display(&e.project, r.ty, &v)),
                None => {
                    let n = e.code.sizes.of(&e.project, r.ty).unwrap_or(1);
                    let slots: Vec<String> =
                        (0..n).map(|k| m.slot(r.addr + k).to_string()).collect();
                    format!("{name}=[{}]", slots.join(","))
                }
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Runs `source` for `scans` scans (10 ms apart) on machine code and on the VM, comparing
/// every variable after every scan; a fault ends both runs with the same message. Returns
/// the last state (or `fault: …`).
fn lockstep(source: &str, scans: usize) -> String {
    lockstep_in(source, scans, Overflow::default())
}

fn lockstep_in(source: &str, scans: usize, overflow: Overflow) -> String {
    let e = engine_in(source, crate::MAX_OPS, overflow);
    let mut jit = Machine::new(e.clone());
    assert!(e.is_compiled(), "no machine code for\n{source}");
    assert_eq!(jit.backend(), Backend::Compiled);
    let mut vm = Machine::new(e.clone());
    vm.set_backend(Backend::Vm);
    let mut last = String::new();
    for k in 0..scans {
        let now = k as i64 * 10_000_000;
        let (a, b) = (
            jit.scan(now, &mut || true).map_err(|f| f.to_string()),
            vm.scan(now, &mut || true).map_err(|f| f.to_string()),
        );
        assert_eq!(a, b, "scan {k} of\n{source}");
        if let Err(f) = a {
            return format!("fault: {f}");
        }
        last = state(&jit);
        assert_eq!(last, state(&vm), "after scan {k} of\n{source}");
    }
    last
}

fn program(vars: &str, body: &str) -> String {
    format!("PROGRAM main\nVAR\n{vars}\nEND_VAR\n{body}\nEND_PROGRAM\n")
}

#[test]
fn bool_logic_and_fused_instructions() {
    let s = lockstep(
        &program(
            "x : BOOL := TRUE; y, z, p, q, r, s, d, f : BOOL; n : INT;",
            "p := x AND y AND NOT z; q := x OR y OR z; r := x AND NOT y; s := z OR NOT y;
             IF p THEN d := TRUE; f := FALSE; END_IF;
             y := NOT y; z := x XOR y; n := n + 1;",
        ),
        4,
    );
    assert_eq!(s, "x=1 y=0 z=1 p=1 q=1 r=0 s=0 d=1 f=0 n=4");
}

#[test]
fn narrow_integers_loops_and_jumps() {
    let s = lockstep(
        &program(
            "i : INT; s : SINT; u : USINT := 250; n : DINT; w : INT; c : INT;",
            "FOR i := 1 TO 10 BY 3 DO n := n + i; END_FOR;
             s := s - 1; u := u + 1;
             WHILE w < 7 DO w := w + 2; IF w = 5 THEN EXIT; END_IF; END_WHILE;
             CASE n OF 0..20: c := 1; 21..50: c := 2; ELSE c := 3; END_CASE;",
        ),
        3,
    );
    assert_eq!(s, "i=13 s=-3 u=253 n=66 w=8 c=3");
}

#[test]
fn what_the_jit_hands_to_the_vm() {
    // Reals, conversions, strings, standard functions and a native timer run through the
    // VM's own instructions from machine code.
    let s = lockstep(
        &program(
            "r : REAL := 1.5; l : LREAL; t : TON; q : BOOL; str : STRING[10]; k : INT;
             a : ARRAY[1..3] OF INT; i : INT := 1;",
            "r := r * 2.0; l := SQRT(LREAL#16.0) + REAL_TO_LREAL(r);
             t(IN := TRUE, PT := T#15ms); q := t.Q; str := CONCAT(str, 'a');
             k := LEN(str); a[i] := k; i := i MOD 3 + 1;",
        ),
        3,
    );
    assert_eq!(
        s,
        "r=12.0 l=16.0 t=[1,15000000,1,15000000,1,0,0] q=1 str='aaa' k=3 a=[1,2,3] i=1"
    );
}

#[test]
fn calls_of_functions_and_blocks() {
    let s = lockstep(
        "FUNCTION twice : DINT VAR_INPUT x : DINT; END_VAR twice := x * 2; END_FUNCTION
         FUNCTION_BLOCK acc VAR_INPUT x : DINT; END_VAR VAR_OUTPUT sum : DINT; END_VAR
           sum := sum + twice(x);
         END_FUNCTION_BLOCK
         PROGRAM main VAR a : acc; bs : ARRAY[1..2] OF acc; s : DINT; END_VAR
           a(x := 3); bs[2](x := a.sum); s := bs[2].sum;
         END_PROGRAM",
        3,
    );
    assert!(s.ends_with("s=72"), "{s}");
}

#[test]
fn faults_are_the_vms() {
    let got = lockstep_in(
        &program("i : SINT := 126;", "i := i + 1;"),
        4,
        Overflow::Fault,
    );
    assert!(
        got.starts_with("fault: ") && got.contains("overflow: 127 + 1 = 128 leaves -128..127"),
        "{got}"
    );
    for (vars, body, expect) in [
        (
            "d : DINT; z : DINT := 3;",
            "z := z - 1; d := 6 / z;",
            "division by zero: 6 / 0",
        ),
        (
            "a : ARRAY[1..2] OF INT; i : INT;",
            "i := i + 1; a[i] := 1;",
            "index 3 is outside",
        ),
        (
            "n : DINT;",
            "WHILE TRUE DO n := n + 1; END_WHILE;",
            "iteration budget",
        ),
    ] {
        let got = lockstep(&program(vars, body), 4);
        assert!(got.starts_with("fault: ") && got.contains(expect), "{got}");
    }
}

/// Wrapping arithmetic compiled inline (narrow types through their width, 64-bit types) and
/// run by the VM (division, MOD, ABS, shifts) gives the VM's values, and division by zero
/// stays a fault.
#[test]
fn wrapping_is_the_vms() {
    let s = lockstep(
        &program(
            "a : SINT := 120; b : INT := -32760; c : DINT := 2147483000; d : USINT := 3;
             e : UINT := 65530; f : UDINT := 5; g : LINT := 9223372036854775800;
             h : ULINT := 3; m : DINT := 65536; n : SINT := -128; q : SINT; r : INT;
             k : INT := -1; w : WORD := 16#8001; x : WORD; y : SINT; z : DINT;",
            "a := a + 5; b := b - 7; c := c + 500; d := d - 2; e := e * 3; f := f - 3;
             g := g + 5; h := h - 2; m := m * m; q := n / -1; y := -n; r := -b;
             x := ROL(w, k); z := ABS(c);",
        ),
        3,
    );
    assert_eq!(
        s,
        "a=-121 b=32755 c=-2147482796 d=253 e=65374 f=4294967292 g=-9223372036854775801 \
         h=18446744073709551613 m=0 n=-128 q=-128 r=-32755 k=-1 w=32769 x=49152 y=-128 \
         z=2147482796"
    );
    let got = lockstep(
        &program("i : SINT := 1; d : SINT;", "i := i - 1; d := 5 / i;"),
        2,
    );
    assert!(got.contains("division by zero: 5 / 0"), "{got}");
}

/// Past its size limit the JIT makes nothing and the machine runs on the VM, with the same
/// results.
#[test]
fn the_vm_runs_what_is_not_compiled() {
    let source = program("n : DINT; b : BOOL;", "n := n + 2; b := n > 3;");
    let e = engine(&source, 1);
    let Err(err) = compile_limited(&e, 1) else {
        panic!("machine code over the limit")
    };
    assert!(err.to_string().contains("the VM runs faster"), "{err}");
    assert!(compile(&e).is_ok());
    let mut m = Machine::new(e.clone());
    assert!(!e.is_compiled());
    for k in 0..2 {
        m.scan(k * 10_000_000, &mut || true).unwrap();
    }
    assert_eq!(state(&m), "n=4 b=1");
}

/// ARRAY[*] in-outs: machine code hands the checked subscript (`Op::IndexV`) to the VM, so
/// the values and the out-of-range fault are the VM's.
#[test]
fn array_star_in_outs_are_the_vms() {
    let src =
        "FUNCTION Sum : DINT VAR_IN_OUT xs : ARRAY[*, *] OF INT; END_VAR VAR i, j : DINT; END_VAR
           Sum := 0;
           FOR i := LOWER_BOUND(xs, 1) TO UPPER_BOUND(xs, 1) DO
             FOR j := LOWER_BOUND(xs, 2) TO UPPER_BOUND(xs, 2) DO Sum := Sum + xs[i, j]; END_FOR;
           END_FOR;
           xs[UPPER_BOUND(xs, 1), UPPER_BOUND(xs, 2)] := 7;
         END_FUNCTION
         FUNCTION ElemAt : INT VAR_IN_OUT xs : ARRAY[*] OF INT; END_VAR VAR_INPUT i : DINT; END_VAR
           ElemAt := xs[i];
         END_FUNCTION
         PROGRAM main VAR m : ARRAY[0..1, 2..3] OF INT := [1, 2, 3, 4]; s : DINT;
           v : ARRAY[-1..1] OF INT := [5, 6, 8]; k : DINT := -1; r : INT; END_VAR
           s := s + Sum(m); r := ElemAt(v, k); k := k + 1;
         END_PROGRAM";
    let s = lockstep(src, 2);
    assert_eq!(s, "m=[1,2,3,7] s=23 v=[5,6,8] k=1 r=6", "{s}");
    let got = lockstep(src, 4);
    assert!(
        got.starts_with("fault: ") && got.contains("index 2 is outside the array's bounds -1..1"),
        "{got}"
    );
}
