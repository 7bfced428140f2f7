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

/// A machine's whole scans on machine code (its fast path, prepared once per machine) run
/// every program instance once in order, each with the full loop budget, stop at the first
/// fault, call the watchdog's check as often as the VM does, and fail with the VM's
/// messages, leaving the same memory.
#[test]
fn whole_scans_on_machine_code_are_the_vms() {
    let src = "PROGRAM A
VAR_EXTERNAL n : DINT; order : DINT; END_VAR
VAR i : DINT; END_VAR
i := 0; WHILE i < n DO i := i + 1; END_WHILE;
order := order * 10 + 1;
END_PROGRAM
PROGRAM B
VAR_EXTERNAL n : DINT; order : DINT; d : DINT; END_VAR
VAR i : DINT; q : DINT; END_VAR
i := 0; WHILE i < n DO i := i + 1; END_WHILE;
q := 100 / d;
order := order * 10 + 2;
END_PROGRAM
CONFIGURATION c
VAR_GLOBAL n : DINT := 60; order : DINT; d : DINT := 1; END_VAR
RESOURCE r ON PLC
    PROGRAM pa : A;
    PROGRAM pb : B;
END_RESOURCE
END_CONFIGURATION";
    let b = build_text("t.st", src, &Select::Auto).unwrap();
    let e = b.engine.clone();
    assert!(e.is_compiled());
    let mut jit = Machine::new(e.clone());
    let mut vm = Machine::new(e.clone());
    vm.set_backend(petriplc_iec_vm::Backend::Vm);
    let var = |n: &str| e.lookup(n).unwrap();
    let int = |i: i128| petriplc_iec_sema::value::Value::Int(i);
    // (n, d, budget, watchdog says stop): what the scan ends with, and `order` after it.
    let check = |jit: &mut Machine, vm: &mut Machine, set: (i128, i128, u64, bool)| {
        let mut outcome = Vec::new();
        for m in [jit, vm] {
            m.set(var("n"), &int(set.0)).unwrap();
            m.set(var("d"), &int(set.1)).unwrap();
            m.iterations = set.2;
            let mut calls = 0;
            let r = m.scan(0, &mut || {
                calls += 1;
                !set.3
            });
            let order = m.get(var("order")).unwrap();
            let slots: Vec<u64> = (0..e.code.init.len() as u32).map(|a| m.slot(a)).collect();
            outcome.push((r.map_err(|f| f.to_string()), calls, order, slots));
        }
        assert_eq!(outcome[0], outcome[1], "machine code against the VM");
        let (r, calls, order, _) = outcome.swap_remove(0);
        (r, calls, order)
    };
    // Each instance has its own budget of 100 iterations: 60 each fit.
    let (r, calls, order) = check(&mut jit, &mut vm, (60, 1, 100, false));
    assert_eq!((r, calls, order), (Ok(()), 0, int(12)));
    // A fault in the second instance: the first has run.
    let (r, _, order) = check(&mut jit, &mut vm, (60, 0, 100, false));
    let msg = r.unwrap_err();
    assert!(
        msg.contains("PROGRAM B") && msg.contains("t.st:11"),
        "{msg}"
    );
    assert_eq!(order, int(121));
    // An endless loop in the first: the second does not run.
    let (r, _, order) = check(&mut jit, &mut vm, (200, 1, 100, false));
    assert!(r.unwrap_err().contains("PROGRAM A"));
    assert_eq!(order, int(121));
    // The watchdog's check, every 65 536 iterations, in both instances.
    let (r, calls, order) = check(&mut jit, &mut vm, (200_000, 1, 10_000_000, false));
    assert_eq!((r, calls, order), (Ok(()), 6, int(12112)));
    let (r, calls, order) = check(&mut jit, &mut vm, (200_000, 1, 10_000_000, true));
    assert!(r.unwrap_err().contains("watchdog"));
    assert_eq!((calls, order), (1, int(12112)));
}

/// With tasks, a scan in which every task is due takes the whole-scan path (by priority);
/// one that stops on a fault leaves the clocks of the tasks it did not reach as the task path
/// does, so later scans run the same tasks on both.
#[test]
fn whole_scans_with_tasks_keep_the_task_clocks() {
    let src = "PROGRAM A
VAR_EXTERNAL d : DINT; na : DINT; log : DINT; END_VAR
VAR q : DINT; END_VAR
na := na + 1;
q := 100 / d;
log := log * 10 + 1;
END_PROGRAM
PROGRAM B
VAR_EXTERNAL nb : DINT; log : DINT; END_VAR
nb := nb + 1;
log := log * 10 + 2;
END_PROGRAM
CONFIGURATION c
VAR_GLOBAL d : DINT := 0; na, nb, log : DINT; END_VAR
RESOURCE r ON PLC
    TASK slow (INTERVAL := T#20ms, PRIORITY := 2);
    TASK fast (INTERVAL := T#10ms, PRIORITY := 1);
    PROGRAM pb WITH slow : B;
    PROGRAM pa WITH fast : A;
END_RESOURCE
END_CONFIGURATION";
    let b = build_text("t.st", src, &Select::Auto).unwrap();
    let e = b.engine.clone();
    let mut jit = Machine::new(e.clone());
    let mut vm = Machine::new(e.clone());
    vm.set_backend(petriplc_iec_vm::Backend::Vm);
    let mut seen = Vec::new();
    for k in 0..6i64 {
        let mut outcome = Vec::new();
        for m in [&mut jit, &mut vm] {
            m.set(
                e.lookup("d").unwrap(),
                &petriplc_iec_sema::value::Value::Int((k > 0) as i128),
            )
            .unwrap();
            let r = m
                .scan(k * 10_000_000, &mut || true)
                .map_err(|f| f.to_string());
            let slots: Vec<u64> = (0..e.code.init.len() as u32).map(|a| m.slot(a)).collect();
            outcome.push((r, slots));
        }
        assert_eq!(
            outcome[0], outcome[1],
            "scan {k}: machine code against the VM"
        );
        let log = jit.get(e.lookup("log").unwrap()).unwrap();
        seen.push(format!("{:?} {log:?}", outcome[0].0.is_ok()));
    }
    // Scan 0: A (higher priority) faults, B not reached; scan 1: both due (B's clock was not
    // advanced), A then B; then B every other scan.
    assert_eq!(
        seen,
        [
            "false Int(0)",
            "true Int(12)",
            "true Int(121)",
            "true Int(12112)",
            "true Int(121121)",
            "true Int(12112112)"
        ]
    );
}

/// A fault inside a POU guarded against re-entry (W050) releases its busy flag: once the
/// instances no longer make a cycle, the next scans run (on machine code and on the VM).
#[test]
fn a_recursion_fault_leaves_the_next_scan_free_to_run() {
    let src = "INTERFACE I_Count
METHOD Count : INT
END_METHOD
END_INTERFACE
FUNCTION_BLOCK List IMPLEMENTS I_Count
VAR_INPUT n : INT; next : I_Count; END_VAR
METHOD Count : INT
Count := n;
IF next <> 0 THEN
  Count := n + next.Count();
END_IF;
END_METHOD
END_FUNCTION_BLOCK
FUNCTION_BLOCK Wrapper IMPLEMENTS I_Count
VAR_INPUT inner : I_Count; END_VAR
METHOD Count : INT
Count := 1 + inner.Count();
END_METHOD
END_FUNCTION_BLOCK
PROGRAM main
VAR_INPUT cycle : BOOL; END_VAR
VAR items : List; w : Wrapper; total : INT; END_VAR
items(n := 30);
w(inner := items);
IF cycle THEN items(next := w); ELSE items(next := 0); END_IF;
total := w.Count();
END_PROGRAM";
    let b = build_text("t.st", src, &Select::Auto).unwrap_or_else(|e| panic!("{e}"));
    for backend in [
        petriplc_iec_vm::Backend::Compiled,
        petriplc_iec_vm::Backend::Vm,
    ] {
        let mut m = Machine::new(b.engine.clone());
        m.set_backend(backend);
        let cycle = b.engine.lookup("main.cycle").unwrap();
        let total = b.engine.lookup("main.total").unwrap();
        let mut outcome = Vec::new();
        for (k, on) in [false, true, false, true, false].into_iter().enumerate() {
            m.set(cycle, &petriplc_iec_sema::value::Value::Int(i128::from(on)))
                .unwrap();
            outcome.push(match m.scan(k as i64 * 10_000_000, &mut || true) {
                Ok(()) => {
                    petriplc_iec_vm::display(&b.engine.project, total.ty, &m.get(total).unwrap())
                        .to_string()
                }
                Err(f) => format!("{:?}", f.kind),
            });
        }
        assert_eq!(
            outcome,
            [
                "31",
                "Op(Domain(\"recursion\"))",
                "31",
                "Op(Domain(\"recursion\"))",
                "31"
            ],
            "{backend:?}"
        );
    }
}
