use petriplc_iec::{build_text, Select};
use petriplc_iec_vm::Machine;

fn run(src: &str, scans: usize, vars: &[&str]) -> Vec<String> {
    let b = match build_text("t.st", src, &Select::Auto) {
        Ok(b) => b,
        Err(e) => panic!("{e}"),
    };
    let mut m = Machine::new(b.engine.clone());
    for k in 0..scans {
        if let Err(f) = m.scan(k as i64 * 10_000_000, &mut || true) {
            return vec![format!("fault: {f}")];
        }
    }
    vars.iter()
        .map(|v| {
            let r = b.engine.lookup(v).unwrap_or_else(|| panic!("no {v}"));
            let val = m.get(r).unwrap();
            format!(
                "{v}={}",
                petriplc_iec_vm::display(&b.engine.project, r.ty, &val)
            )
        })
        .collect()
}

#[test]
fn smoke() {
    let r = run(
        "PROGRAM main
VAR i : INT; s : DINT; r : REAL; b : BOOL; t : TON; a : ARRAY[1..5] OF INT; str : STRING[10]; END_VAR
s := 0;
FOR i := 1 TO 5 DO a[i] := i * i; s := s + a[i]; END_FOR;
r := INT_TO_REAL(i) / 2.0;
b := s > 50 AND NOT b;
t(IN := TRUE, PT := T#30ms);
str := CONCAT('ab', 'cd');
END_PROGRAM",
        5,
        &["main.s", "main.i", "main.r", "main.b", "main.t.Q", "main.t.ET", "main.str", "main.a[3]"],
    );
    assert_eq!(
        r,
        vec![
            "main.s=55",
            "main.i=6",
            "main.r=3.0",
            "main.b=1",
            "main.t.Q=1",
            "main.t.ET=T#30ms",
            "main.str='abcd'",
            "main.a[3]=9"
        ]
    );
}

/// Machine code is made for small programs and left to the VM past the size limit; either
/// way the machine runs.
#[test]
fn machine_code_or_the_vm_past_the_size_limit() {
    let b = build_text(
        "t.st",
        "PROGRAM main\nVAR x : INT; END_VAR\nx := x + 1;\nEND_PROGRAM",
        &Select::Auto,
    )
    .unwrap();
    assert!(petriplc_iec::jit::compile(&b.engine).is_ok());
    let e = petriplc_iec::jit::compile_limited(&b.engine, 1).unwrap_err();
    assert!(e.to_string().contains("the VM runs faster"), "{e}");
    let mut m = Machine::new(b.engine.clone());
    assert_eq!(m.backend(), petriplc_iec_vm::Backend::Compiled);
    m.scan(0, &mut || true).unwrap();
    m.set_backend(petriplc_iec_vm::Backend::Vm);
    assert_eq!(m.backend(), petriplc_iec_vm::Backend::Vm);
    m.scan(0, &mut || true).unwrap();
    let x = b.engine.lookup("main.x").unwrap();
    assert_eq!(m.get(x), Some(petriplc_iec_sema::value::Value::Int(2)));
}
