//! Textual SFC means what PLCopen XML's `<SFC>` means: one chart written both ways (a
//! simultaneous divergence and convergence, a selection by priority, a named transition with
//! a body, named actions, N, S, R, L, D, SD and P0) runs on the same inputs for 300 scans,
//! and every output and step flag is equal after every scan, on the VM and the machine code.

use petriplc_iec::{build_text, Build, Select};
use petriplc_iec_sema::value::Value;
use petriplc_iec_vm::{Backend, Machine};

const TEXT: &str = "PROGRAM main
VAR_INPUT i0, i1, i2 : BOOL; END_VAR
VAR_OUTPUT n, m : INT; lamp, q, d, sd : BOOL; END_VAR
INITIAL_STEP S0 : Cnt(N); END_STEP
TRANSITION FROM S0 TO (A, B) := i0; END_TRANSITION
STEP A : lamp(S); sd(SD, T#40ms); END_STEP
STEP B : q(L, T#30ms); END_STEP
TRANSITION FROM A TO A2 := i1; END_TRANSITION
STEP A2 : d(D, T#20ms); END_STEP
TRANSITION Join FROM (A2, B) TO S3 :
    Join := i2 AND NOT i0;
END_TRANSITION
STEP S3 : lamp(R); sd(R); END_STEP
TRANSITION (PRIORITY := 2) FROM S3 TO S0 := i0; END_TRANSITION
TRANSITION (PRIORITY := 1) FROM S3 TO S4 := i1; END_TRANSITION
STEP S4 : Leave(P0); END_STEP
TRANSITION FROM S4 TO S0 := TRUE; END_TRANSITION
ACTION Cnt : n := n + 1; END_ACTION
ACTION Leave : m := m + 1; END_ACTION
END_PROGRAM
";

/// An inline ST condition or body.
fn st(text: &str) -> String {
    format!(r#"<ST><xhtml:p><![CDATA[{text}]]></xhtml:p></ST>"#)
}

fn cond(text: &str) -> String {
    format!(
        r#"<condition><inline name="">{}</inline></condition>"#,
        st(text)
    )
}

fn from(id: u32) -> String {
    format!(r#"<connectionPointIn><connection refLocalId="{id}"/></connectionPointIn>"#)
}

fn action(q: &str, duration: &str, name: &str) -> String {
    let duration = if duration.is_empty() {
        String::new()
    } else {
        format!(r#" duration="{duration}""#)
    };
    format!(r#"<action localId="0" qualifier="{q}"{duration}><reference name="{name}"/></action>"#)
}

fn xml() -> String {
    let p = r#"<position x="0" y="0"/>"#;
    let var = |n: &str, t: &str| format!(r#"<variable name="{n}"><type><{t}/></type></variable>"#);
    let body = [
        format!(r#"<step localId="1" name="S0" initialStep="true">{p}</step>"#),
        format!(r#"<actionBlock localId="2">{p}{}{}</actionBlock>"#, from(1), action("N", "", "Cnt")),
        format!(r#"<transition localId="3">{p}{}{}</transition>"#, from(1), cond("i0")),
        format!(r#"<simultaneousDivergence localId="4">{p}{}<connectionPointOut formalParameter="0"/><connectionPointOut formalParameter="1"/></simultaneousDivergence>"#, from(3)),
        format!(r#"<step localId="5" name="A">{p}<connectionPointIn><connection refLocalId="4" formalParameter="0"/></connectionPointIn></step>"#),
        format!(r#"<actionBlock localId="6">{p}{}{}{}</actionBlock>"#, from(5), action("S", "", "lamp"), action("SD", "T#40ms", "sd")),
        format!(r#"<step localId="7" name="B">{p}<connectionPointIn><connection refLocalId="4" formalParameter="1"/></connectionPointIn></step>"#),
        format!(r#"<actionBlock localId="8">{p}{}{}</actionBlock>"#, from(7), action("L", "T#30ms", "q")),
        format!(r#"<transition localId="9">{p}{}{}</transition>"#, from(5), cond("i1")),
        format!(r#"<step localId="10" name="A2">{p}{}</step>"#, from(9)),
        format!(r#"<actionBlock localId="11">{p}{}{}</actionBlock>"#, from(10), action("D", "T#20ms", "d")),
        format!(r#"<simultaneousConvergence localId="12">{p}{}{}</simultaneousConvergence>"#, from(10), from(7)),
        format!(r#"<transition localId="13">{p}{}<condition><reference name="Join"/></condition></transition>"#, from(12)),
        format!(r#"<step localId="14" name="S3">{p}{}</step>"#, from(13)),
        format!(r#"<actionBlock localId="15">{p}{}{}{}</actionBlock>"#, from(14), action("R", "", "lamp"), action("R", "", "sd")),
        format!(r#"<selectionDivergence localId="16">{p}{}</selectionDivergence>"#, from(14)),
        format!(r#"<transition localId="17" priority="2">{p}{}{}</transition>"#, from(16), cond("i0")),
        format!(r#"<jumpStep localId="18" targetName="S0">{p}{}</jumpStep>"#, from(17)),
        format!(r#"<transition localId="19" priority="1">{p}{}{}</transition>"#, from(16), cond("i1")),
        format!(r#"<step localId="20" name="S4">{p}{}</step>"#, from(19)),
        format!(r#"<actionBlock localId="21">{p}{}{}</actionBlock>"#, from(20), action("P0", "", "Leave")),
        format!(r#"<transition localId="22">{p}{}{}</transition>"#, from(20), cond("TRUE")),
        format!(r#"<jumpStep localId="23" targetName="S0">{p}{}</jumpStep>"#, from(22)),
    ]
    .concat();
    let inputs = ["i0", "i1", "i2"].map(|n| var(n, "BOOL")).concat();
    let outputs = [var("n", "INT"), var("m", "INT")]
        .into_iter()
        .chain(["lamp", "q", "d", "sd"].map(|n| var(n, "BOOL")))
        .collect::<String>();
    format!(
        r#"<?xml version="1.0" encoding="utf-8"?>
<project xmlns="http://www.plcopen.org/xml/tc6_0201" xmlns:xhtml="http://www.w3.org/1999/xhtml">
<fileHeader companyName="petriplc" productName="test" productVersion="1" creationDateTime="2026-12-02T00:00:00"/>
<contentHeader name="test"><coordinateInfo><fbd><scaling x="1" y="1"/></fbd><ld><scaling x="1" y="1"/></ld><sfc><scaling x="1" y="1"/></sfc></coordinateInfo></contentHeader>
<types><dataTypes/><pous><pou name="main" pouType="program">
<interface><inputVars>{inputs}</inputVars><outputVars>{outputs}</outputVars></interface>
<actions>
<action name="Cnt"><body>{}</body></action>
<action name="Leave"><body>{}</body></action>
</actions>
<transitions><transition name="Join"><body>{}</body></transition></transitions>
<body><SFC>{body}</SFC></body>
</pou></pous></types>
<instances><configurations/></instances>
</project>"#,
        st("n := n + 1;"),
        st("m := m + 1;"),
        st("Join := i2 AND NOT i0;"),
    )
}

const WATCHED: &[&str] = &[
    "n", "m", "lamp", "q", "d", "sd", "S0.X", "A.X", "B.X", "A2.X", "S3.X", "S4.X", "S0.T", "A.T",
    "S3.T",
];

fn machines(b: &Build) -> [Machine; 2] {
    let mut vm = Machine::new(b.engine.clone());
    vm.set_backend(Backend::Vm);
    [Machine::new(b.engine.clone()), vm]
}

#[test]
fn a_chart_in_text_runs_as_the_same_chart_in_plcopen_xml() {
    let text = build_text("chart.st", TEXT, &Select::default()).expect("the text chart builds");
    let xml = build_text("chart.xml", &xml(), &Select::default()).expect("the XML chart builds");
    let (mut t, mut x) = (machines(&text), machines(&xml));
    let var = |b: &Build, n: &str| {
        let inst = &b.engine.instances()[0].name;
        b.engine
            .lookup(&format!("{inst}.{n}"))
            .unwrap_or_else(|| panic!("no variable {n}"))
    };
    // A fixed pseudo-random sequence of inputs, each held a few scans.
    let mut seed: u64 = 0x5fc_2026;
    let mut inputs = [false; 3];
    let mut moved = 0;
    for k in 0..300u64 {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        if (seed >> 60) < 5 {
            inputs[(seed >> 33) as usize % 3] ^= true;
        }
        for (b, ms) in [(&text, &mut t), (&xml, &mut x)] {
            for (n, v) in ["i0", "i1", "i2"].iter().zip(inputs) {
                for m in ms.iter_mut() {
                    m.set(var(b, n), &Value::Int(v as i128)).unwrap();
                }
            }
            for m in ms.iter_mut() {
                m.scan(k as i64 * 10_000_000, &mut || true).expect("scans");
            }
        }
        for n in WATCHED {
            let want = x[0].get(var(&xml, n));
            assert_eq!(
                x[1].get(var(&xml, n)),
                want,
                "after scan {}: {n}, XML VM",
                k + 1
            );
            for m in &t {
                assert_eq!(m.get(var(&text, n)), want, "after scan {}: {n}", k + 1);
            }
        }
        moved += (x[0].get(var(&xml, "S3.X")) == Some(Value::Int(1))) as u32;
    }
    // The inputs drive the chart through its branches, not only its first step.
    assert!(moved > 3, "step S3 was active in {moved} scans only");
}

/// Each source with a chart declares the chart types; a project of several is one program.
#[test]
fn charts_in_two_sources_of_one_project_build_together() {
    let mut s = petriplc_iec::Sources::new();
    s.add_text(
        "a.st",
        "FUNCTION_BLOCK blink\nVAR_OUTPUT q : BOOL; END_VAR\nINITIAL_STEP on : q(N); END_STEP\nTRANSITION FROM on TO off := on.T >= T#20ms; END_TRANSITION\nSTEP off : END_STEP\nTRANSITION FROM off TO on := off.T >= T#20ms; END_TRANSITION\nEND_FUNCTION_BLOCK",
    );
    s.add_text(
        "b.st",
        "PROGRAM main\nVAR b : blink; n : INT; END_VAR\nINITIAL_STEP s0 : count(N); END_STEP\nTRANSITION FROM s0 TO s0 := FALSE; END_TRANSITION\nACTION count : b(); IF b.q THEN n := n + 1; END_IF; END_ACTION\nEND_PROGRAM",
    );
    let b = petriplc_iec::build(&s, &Select::default(), petriplc_iec::Natives::default())
        .expect("two sources with charts build as one project");
    let mut m = Machine::new(b.engine.clone());
    for k in 0..10 {
        m.scan(k * 10_000_000, &mut || true).expect("scans");
    }
    let n = b.engine.lookup("main.n").expect("main.n");
    // blink is on for scans 1-3 of every 6 (on.T reaches 20 ms at its third scan).
    assert_eq!(m.get(n), Some(Value::Int(6)));
}
