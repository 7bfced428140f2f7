//! The front end's depth limits (petriplc_iec_syntax::depth) are safe on the smallest stack
//! the engine runs on — a module thread's 2 MiB — in a debug build (these tests' build):
//! programs at every limit are checked, compiled (VM and machine code) and scanned on such a
//! thread, and programs past them are refused with a coded error there.

use std::sync::Arc;

use petriplc_iec::{build_text, jit, Select};
use petriplc_iec_vm::{Backend, Machine};

/// The stack of a thread the PLC spawns for a module (Rust's default).
const SMALL_STACK: usize = 2 << 20;

fn on_small_stack<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .stack_size(SMALL_STACK)
            .spawn_scoped(s, f)
            .expect("a thread")
            .join()
            .expect("no panic")
    })
}

/// Builds `src` (machine code for any size) and scans it twice, on machine code and on the
/// VM; returns the fault or "ok".
fn build_and_scan(src: &str) -> String {
    let mut b = match build_text("t.st", src, &Select::Auto) {
        Ok(b) => b,
        Err(e) => return e.to_string(),
    };
    let engine = Arc::get_mut(&mut b.engine).expect("one owner");
    engine.set_compiler(Box::new(|e| {
        jit::compile_limited(e, usize::MAX)
            .ok()
            .map(|j| Box::new(j) as Box<dyn petriplc_iec_vm::Compiled>)
    }));
    let mut m = Machine::new(b.engine.clone());
    assert_eq!(m.backend(), Backend::Compiled);
    let compiled = m.scan(0, &mut || true);
    m.set_backend(Backend::Vm);
    let vm = m.scan(10_000_000, &mut || true);
    match (compiled, vm) {
        (Ok(()), Ok(())) => "ok".into(),
        (Err(a), Err(b)) => {
            assert_eq!(a.to_string(), b.to_string());
            format!("fault: {a}")
        }
        (a, b) => panic!("machine code {a:?}, VM {b:?}"),
    }
}

/// `n` function blocks, each holding and calling the next.
fn fb_chain(n: usize) -> String {
    let mut s = String::from("PROGRAM main VAR f : F0; END_VAR f(); END_PROGRAM\n");
    for i in 0..n {
        if i + 1 == n {
            s.push_str(&format!(
                "FUNCTION_BLOCK F{i} VAR x : INT; END_VAR x := x + 1; END_FUNCTION_BLOCK\n"
            ));
        } else {
            s.push_str(&format!(
                "FUNCTION_BLOCK F{i} VAR c : F{}; END_VAR c(); END_FUNCTION_BLOCK\n",
                i + 1
            ));
        }
    }
    s
}

#[test]
fn programs_at_every_limit_run_on_a_small_stack() {
    // Function blocks 99 deep in a program (100 levels of instances).
    assert_eq!(on_small_stack(|| build_and_scan(&fb_chain(99))), "ok");
    // Structures 98 deep, an initial value (nested as deep as the parser reads) and an access
    // through every level.
    let n = 98;
    let mut s = String::from("TYPE\n");
    for i in 0..n {
        let inner = if i + 1 == n {
            "INT".to_string()
        } else {
            format!("S{}", i + 1)
        };
        s.push_str(&format!("S{i} : STRUCT s : {inner}; END_STRUCT;\n"));
    }
    let path = ".s".repeat(n);
    s.push_str(&format!(
        "END_TYPE\nPROGRAM main VAR v : S0 := {}7{}; END_VAR v{path} := v{path} + 1; END_PROGRAM\n",
        "(s := ".repeat(n),
        ")".repeat(n),
    ));
    assert_eq!(on_small_stack(|| build_and_scan(&s)), "ok");
    // Arrays of arrays 98 deep.
    let src = format!(
        "PROGRAM main VAR v : {}INT; END_VAR v{} := 1; END_PROGRAM",
        "ARRAY[0..1] OF ".repeat(26),
        "[1]".repeat(26)
    );
    assert_eq!(on_small_stack(|| build_and_scan(&src)), "ok");
    let src = format!(
        "PROGRAM main VAR v : {}INT; END_VAR v{} := 1; END_PROGRAM",
        "ARRAY[0..0] OF ".repeat(97),
        "[0]".repeat(97)
    );
    assert_eq!(on_small_stack(|| build_and_scan(&src)), "ok");
    // Statements 98 deep around an expression as deep as the rest of the budget allows,
    // of every kind of operator the checker and compiler treat differently.
    for op in ["+", "AND", "<", "-", "*"] {
        let (ty, x) = match op {
            "AND" => ("BOOL", "b"),
            "<" => ("BOOL", "i < i"),
            _ => ("DINT", "i"),
        };
        let target = if ty == "BOOL" { "b" } else { "i" };
        let chain = vec![x; 850].join(&format!(" {} ", if op == "<" { "AND" } else { op }));
        let src = format!(
            "PROGRAM main VAR i : DINT; b : BOOL; END_VAR\n{}{target} := {chain};\n{}END_PROGRAM",
            "IF NOT b THEN\n".repeat(95),
            "END_IF;\n".repeat(95)
        );
        let r = on_small_stack(|| build_and_scan(&src));
        assert!(r == "ok" || r.starts_with("fault: "), "{op}: {r}");
    }
    // Parentheses and unary operators 98 deep.
    let src = format!(
        "PROGRAM main VAR i : DINT; END_VAR i := {}i{}; END_PROGRAM",
        "-(".repeat(48),
        ")".repeat(48)
    );
    assert_eq!(on_small_stack(|| build_and_scan(&src)), "ok");
}

/// Function calls nest at run time up to the VM's limit, in machine code too (its calls are
/// native calls); one more is a fault, not a crash.
#[test]
fn calls_as_deep_as_the_engine_allows_run_on_a_small_stack() {
    let chain = |n: usize| {
        let mut s = String::from("PROGRAM main VAR x : INT; END_VAR x := G0(x); END_PROGRAM\n");
        for i in 0..n {
            let body = if i + 1 == n {
                format!("G{i} := a;")
            } else {
                format!("G{i} := G{}(a);", i + 1)
            };
            s.push_str(&format!(
                "FUNCTION G{i} : INT VAR_INPUT a : INT; END_VAR {body} END_FUNCTION\n"
            ));
        }
        s
    };
    let depth = petriplc_iec_vm::exec::MAX_DEPTH;
    assert_eq!(on_small_stack(|| build_and_scan(&chain(depth - 2))), "ok");
    let r = on_small_stack(|| build_and_scan(&chain(depth + 10)));
    assert!(r.contains("calls nested too deeply"), "{r}");
}

#[test]
fn programs_past_the_limits_are_refused_on_a_small_stack() {
    let r = on_small_stack(|| build_and_scan(&fb_chain(10_000)));
    assert!(r.contains("error[E116]"), "{r}");
    let src = format!(
        "PROGRAM main VAR i : INT; END_VAR i := {}; END_PROGRAM",
        vec!["i"; 100_000].join(" + ")
    );
    let r = on_small_stack(|| build_and_scan(&src));
    assert!(r.contains("error[E014]"), "{r}");
}

/// A PLCopen project whose program `main` (BOOL `a`, `q`; INT `n`) has the LD body `ld`.
fn ld_project(ld: &str) -> String {
    format!(
        r#"<?xml version="1.0" encoding="utf-8"?>
<project xmlns="http://www.plcopen.org/xml/tc6_0201">
  <fileHeader companyName="t" productName="t" productVersion="1" creationDateTime="2026-01-01T00:00:00"/>
  <contentHeader name="t"><coordinateInfo><fbd><scaling x="1" y="1"/></fbd><ld><scaling x="1" y="1"/></ld><sfc><scaling x="1" y="1"/></sfc></coordinateInfo></contentHeader>
  <types><dataTypes/><pous>
    <pou name="main" pouType="program">
      <interface><localVars><variable name="a"><type><BOOL/></type></variable><variable name="q"><type><BOOL/></type></variable><variable name="n"><type><INT/></type></variable></localVars></interface>
      <body><LD>
        <leftPowerRail localId="1"><connectionPointOut formalParameter=""/></leftPowerRail>
{ld}
      </LD></body>
    </pou>
  </pous></types>
  <instances><configurations/></instances>
</project>"#
    )
}

/// `n` contacts in series from the rail, the last one driving a coil.
fn contacts_in_series(n: u64) -> String {
    let mut ld = String::new();
    for i in 0..n {
        ld.push_str(&format!(
            r#"<contact localId="{}"><connectionPointIn><connection refLocalId="{}"/></connectionPointIn><connectionPointOut/><variable>a</variable></contact>"#,
            i + 2,
            i + 1
        ));
    }
    ld.push_str(&format!(
        r#"<coil localId="{}"><connectionPointIn><connection refLocalId="{}"/></connectionPointIn><connectionPointOut/><variable>q</variable></coil>"#,
        n + 2,
        n + 1
    ));
    ld_project(&ld)
}

#[test]
fn graphical_bodies_at_and_past_their_limits() {
    let build = |xml: String| on_small_stack(move || build_and_scan_xml(&xml));
    // The longest chain of elements read (256).
    assert_eq!(build(contacts_in_series(250)), "ok");
    let r = build(contacts_in_series(20_000));
    assert!(
        r.contains("error[E054]") && r.contains("more than 256 elements"),
        "{r}"
    );
    // One input wired to 50 000 branches: an OR a few levels deep, not 50 000.
    let mut ld = String::new();
    ld.push_str(r#"<coil localId="2"><connectionPointIn>"#);
    for _ in 0..50_000 {
        ld.push_str(r#"<connection refLocalId="1"/>"#);
    }
    ld.push_str(r#"</connectionPointIn><connectionPointOut/><variable>q</variable></coil>"#);
    assert_eq!(build(ld_project(&ld)), "ok");
    // Functions each reading the one before on both inputs double the inlined work at every
    // level: refused past the work limit rather than expanded 2^60 times.
    let mut ld = String::from(
        r#"<inVariable localId="2"><connectionPointOut/><expression>n</expression></inVariable>"#,
    );
    let levels = 60;
    for i in 0..levels {
        let (id, prev) = (i + 3, i + 2);
        ld.push_str(&format!(
            r#"<block localId="{id}" typeName="ADD"><inputVariables><variable formalParameter="IN1"><connectionPointIn><connection refLocalId="{prev}"/></connectionPointIn></variable><variable formalParameter="IN2"><connectionPointIn><connection refLocalId="{prev}"/></connectionPointIn></variable></inputVariables><inOutVariables/><outputVariables><variable formalParameter="OUT"><connectionPointOut/></variable></outputVariables></block>"#
        ));
    }
    ld.push_str(&format!(
        r#"<outVariable localId="{}"><connectionPointIn><connection refLocalId="{}"/></connectionPointIn><expression>n</expression></outVariable>"#,
        levels + 3,
        levels + 2
    ));
    let r = build(ld_project(&ld));
    assert!(
        r.contains("error[E054]") && r.contains("more than 200000 values"),
        "{r}"
    );
}

/// As [`build_and_scan`], for a PLCopen project.
fn build_and_scan_xml(xml: &str) -> String {
    let mut s = petriplc_iec::Sources::new();
    s.add_text("t.xml", xml);
    match petriplc_iec::build(&s, &Select::Auto, petriplc_iec::Natives::default()) {
        Ok(b) => {
            let mut m = Machine::new(b.engine.clone());
            match m.scan(0, &mut || true) {
                Ok(()) => "ok".into(),
                Err(f) => format!("fault: {f}"),
            }
        }
        Err(e) => e.to_string(),
    }
}

/// A source is read only from a regular file: a directory is named as such, once, and a
/// device is refused before a byte is read (`/dev/zero` has no end).
#[test]
fn sources_that_are_not_files_are_refused() {
    let dir = std::env::temp_dir();
    let mut s = petriplc_iec::Sources::new();
    let e = s.add_file(&dir).unwrap_err().to_string();
    assert_eq!(
        e,
        format!(
            "cannot read {}: it is a directory; name a .st, .il or .xml file",
            dir.display()
        )
    );
    let e = s.add_file(std::path::Path::new("/dev/zero")).unwrap_err();
    assert!(
        e.to_string()
            .ends_with("it is a device, not a regular file; name a .st, .il or .xml file"),
        "{e}"
    );
    assert!(std::error::Error::source(&e).is_none());
}
