//! The Instruction List backend: projects validate against the PLCopen schema, the text is
//! well formed (labels, jumps, declared identifiers), conditions render as intended, and a
//! small IL interpreter running the generated code agrees with the net's own scanner.
mod common;

use std::collections::{HashMap, HashSet};
use std::time::Duration;

use petriplc_codegen::lower::{Atom, Cond, Markings, Options, Program};
use petriplc_codegen::{il, plcopen};
use petriplc_net::scan::{ScanOptions, Scanner};
use petriplc_net::{Evolution, Net, SignalDirection, StepRule};
use petriplc_testnet::net;

const STEPS: [StepRule; 2] = [StepRule::MaximalStep, StepRule::Sequential];
const EVOLUTIONS: [Evolution; 2] = [Evolution::OnePass, Evolution::UntilStable];

fn options(step: StepRule, evolve: Evolution, markings: Markings) -> Options {
    Options {
        step,
        evolve,
        max_passes: 50,
        markings,
        pou: None,
        period: Duration::from_millis(10),
    }
}

/// Every program a net gives: both step rules, both evolutions, BOOL markings when the net
/// is safe, and integer markings.
fn programs(net: &Net) -> Vec<Program> {
    let mut out = Vec::new();
    for step in STEPS {
        for evolve in EVOLUTIONS {
            for markings in [Markings::Bool, Markings::Int] {
                if let Ok(p) = Program::lower(net, &options(step, evolve, markings)) {
                    out.push(p);
                }
            }
        }
    }
    out
}

/// Small nets that between them use every kind of arc, guard and signal.
fn small_nets() -> Vec<(&'static str, Net)> {
    vec![
        (
            "chain",
            net("
                p p1 1 >L1
                p p2 0 >L2 cap=1
                p p3 0 >L2 cap=1
                t t1 p1 -> p2
                t t2 p2 -> p3
                t t3 p3 -> p1
            "),
        ),
        (
            "guards",
            net("
                s B1 in bool
                s B2 in bool
                s Level in int
                p a 1 >Lamp cap=1
                p b 0 cap=1
                t go a -> b if B1 AND NOT B2 OR Level >= 3 XOR B2
                t back b -> a if NOT (B1 OR B2) AND Level <> 7 AND B1 = 0 AND 5000000000 > Level
                t idle ?a !b -> if Level
            "),
        ),
        (
            "inputs",
            net("
                s B1 in bool
                s Count in int
                s Big in int
                s Out out int
                p i1 0 <B1
                p i2 0 <Count cap=5
                p i3 0 <Big
                p q 0 >Out
                p r 0 cap=1
                t t1 ?i1 ?i2*2 !r -> q*2
                t t2 ?i3*3 q -> r
                t t3 !i1 r -> q
            "),
        ),
        (
            "weights",
            net("
                s N out int
                p a 3 cap=4
                p b 0 cap=3 >N
                p c 0
                t t1 a*2 -> b
                t t2 b -> a c*2
                t t3 c*3 !a*4 -> a
                t t4 ?b*2 b -> b
            "),
        ),
        (
            "timers",
            net("
                p a 1 >A
                p b 0 cap=1 >B
                p c 2
                t t1 a@30ms -> b
                t t2 b@20ms -> a
                t t3 c*2@40ms -> c*2
            "),
        ),
        (
            "conflict",
            net("
                s IF in bool
                p shared 1 cap=1
                p left 0 cap=1 >Done
                p right 0 cap=1 >Done
                t first shared -> left if IF
                t second shared -> right
                t back1 left -> shared
                t back2 right -> shared
            "),
        ),
        (
            "cycle",
            net("
                p a 1
                p b 0
                t ab a -> b
                t ba b -> a
            "),
        ),
    ]
    .into_iter()
    .chain(common::degenerate_nets())
    .collect()
}

/// Every program of every example and small net.
fn all_programs() -> Vec<(String, Program)> {
    let mut out = Vec::new();
    for (name, _, _) in common::EXAMPLE_NETS {
        let n = common::example(name);
        for p in programs(&n) {
            out.push((name.to_string(), p));
        }
    }
    for (name, n) in small_nets() {
        for p in programs(&n) {
            out.push((name.to_string(), p));
        }
    }
    out
}

fn describe(name: &str, p: &Program) -> String {
    format!(
        "{name} ({}, {}, {} markings)",
        p.step.as_str(),
        p.evolve.as_str(),
        if p.boolean { "BOOL" } else { "integer" }
    )
}

#[test]
fn every_program_has_bool_and_int_variants() {
    // The matrix below is only meaningful if it covers what it claims.
    let all = all_programs();
    for boolean in [true, false] {
        for step in STEPS {
            for evolve in EVOLUTIONS {
                assert!(
                    all.iter()
                        .any(|(_, p)| p.boolean == boolean && p.step == step && p.evolve == evolve),
                    "no program with boolean={boolean}, {step}, {evolve}"
                );
            }
        }
    }
}

#[test]
fn projects_validate_against_the_schema() {
    for (name, p) in all_programs() {
        let doc = plcopen::project(
            &p,
            &plcopen::program_interface(&p),
            &plcopen::Body::Il(il::body(&p)),
            common::CREATED,
        );
        assert!(doc.contains("<IL>"), "{}", describe(&name, &p));
        if let Err(e) = common::xmllint(&doc) {
            panic!("{}: {e}\n{doc}", describe(&name, &p));
        }
    }
}

#[test]
fn plain_text_is_one_program() {
    for (name, p) in all_programs() {
        let text = il::program_text(&p);
        let what = describe(&name, &p);
        assert!(text.starts_with(&format!("PROGRAM {}\n", p.pou)), "{what}");
        assert!(text.trim_end().ends_with("END_PROGRAM"), "{what}");
        assert_eq!(text.matches("END_PROGRAM").count(), 1, "{what}");
        assert!(text.contains(&il::body(&p)), "{what}");
        let interface = plcopen::program_interface(&p);
        for v in interface
            .inputs
            .iter()
            .chain(&interface.outputs)
            .chain(&interface.locals)
        {
            assert!(
                text.contains(&format!("    {} : {};", v.name, v.ty.iec())),
                "{what}: {} not declared",
                v.name
            );
        }
        assert_eq!(
            text.matches("(*").count(),
            text.matches("*)").count(),
            "{what}"
        );
    }
}

#[test]
fn header_lists_renamed_names_and_conflicts() {
    let n = small_nets()
        .into_iter()
        .find(|(n, _)| *n == "conflict")
        .unwrap()
        .1;
    let p = Program::lower(&n, &Options::of(&n)).unwrap();
    assert!(!p.renamed.is_empty() && !p.conflicts.is_empty());
    let text = il::program_text(&p);
    assert!(text.contains("   IF -> IF_2\n"), "{text}");
    assert!(
        text.contains("   first over second (on shared)\n"),
        "{text}"
    );
    // The renamed signal is used under its new name.
    assert!(text.contains("LD    IF_2"), "{text}");
}

/// IL with comments removed, as (label, operator, operand) lines; `)` is kept as an
/// operator.
fn instructions(body: &str) -> Vec<(Option<String>, String, String)> {
    let mut text = String::new();
    let mut rest = body;
    while let Some(i) = rest.find("(*") {
        text.push_str(&rest[..i]);
        let end = rest[i..].find("*)").expect("comment is closed");
        rest = &rest[i + end + 2..];
    }
    text.push_str(rest);
    let mut out = Vec::new();
    for line in text.lines().map(str::trim).filter(|l| !l.is_empty()) {
        if let Some(label) = line.strip_suffix(':') {
            out.push((Some(label.to_string()), String::new(), String::new()));
            continue;
        }
        let (op, arg) = line.split_once(' ').unwrap_or((line, ""));
        out.push((None, op.to_string(), arg.trim().to_string()));
    }
    out
}

/// The IL operators the backend may write: the plainest ones, which Beremiz (matiec),
/// CODESYS and TwinCAT all accept. No `S`/`R` (matiec crashed on them), no `STN`.
const OPERATORS: &[&str] = &[
    "LD",
    "LDN",
    "ST",
    "AND",
    "ANDN",
    "OR",
    "ORN",
    "XOR",
    "XORN",
    "NOT",
    "ADD",
    "SUB",
    "GT",
    "GE",
    "EQ",
    "NE",
    "LE",
    "LT",
    "JMP",
    "JMPC",
    "JMPCN",
    "CAL",
    "AND(",
    "ANDN(",
    "OR(",
    "ORN(",
    "XOR(",
    "XORN(",
    "GT(",
    "GE(",
    "EQ(",
    "NE(",
    "LE(",
    "LT(",
    ")",
    "MAX",
    "MIN",
    "BOOL_TO_UDINT",
    "DINT_TO_UDINT",
    "BOOL_TO_DINT",
];

#[test]
fn labels_are_defined_once_and_jumps_land_on_them() {
    for (name, p) in all_programs() {
        let what = describe(&name, &p);
        let code = instructions(&il::body(&p));
        let mut defined = HashSet::new();
        for (label, _, _) in &code {
            if let Some(l) = label {
                assert!(defined.insert(l.to_ascii_uppercase()), "{what}: {l} twice");
            }
        }
        for (_, op, arg) in &code {
            if op.starts_with("JMP") {
                assert!(
                    defined.contains(&arg.to_ascii_uppercase()),
                    "{what}: no label {arg}"
                );
            }
        }
        let interface = plcopen::program_interface(&p);
        for v in interface
            .inputs
            .iter()
            .chain(&interface.outputs)
            .chain(&interface.locals)
        {
            assert!(
                !defined.contains(&v.name.to_ascii_uppercase()),
                "{what}: label {}",
                v.name
            );
        }
    }
}

#[test]
fn every_identifier_is_declared() {
    for (name, p) in all_programs() {
        let what = describe(&name, &p);
        let interface = plcopen::program_interface(&p);
        let mut declared: HashMap<String, String> = HashMap::new();
        for v in interface
            .inputs
            .iter()
            .chain(&interface.outputs)
            .chain(&interface.locals)
        {
            declared.insert(v.name.to_ascii_uppercase(), v.ty.iec().to_string());
        }
        let operand_ok = |tok: &str| -> bool {
            let upper = tok.to_ascii_uppercase();
            if upper == "TRUE" || upper == "FALSE" || upper.starts_with("T#") {
                return true;
            }
            if tok
                .trim_start_matches('-')
                .chars()
                .all(|c| c.is_ascii_digit())
            {
                return !tok.is_empty();
            }
            if let Some((fb, field)) = upper.split_once('.') {
                return declared.get(fb).is_some_and(|t| t == "TON")
                    && ["Q", "IN", "PT", "ET"].contains(&field);
            }
            declared.contains_key(&upper)
        };
        let mut open = 0i32;
        for (label, op, arg) in instructions(&il::body(&p)) {
            if label.is_some() {
                continue;
            }
            assert!(OPERATORS.contains(&op.as_str()), "{what}: operator {op}");
            if op.ends_with('(') {
                open += 1;
            } else if op == ")" {
                open -= 1;
            }
            if arg.is_empty() || op.starts_with("JMP") {
                continue;
            }
            let arg = arg.trim_end_matches(',');
            if op == "CAL" {
                assert_eq!(
                    declared.get(&arg.to_ascii_uppercase()).map(String::as_str),
                    Some("TON"),
                    "{what}: CAL {arg}"
                );
                continue;
            }
            assert!(operand_ok(arg), "{what}: {op} {arg} is not declared");
        }
        assert_eq!(open, 0, "{what}: unbalanced parentheses");
    }
}

/// The forms matiec (Beremiz) crashed on or refused must not come back: the `S`/`R`
/// operators (markings are stored with `LD`/`ST` behind a jump), formal call lists
/// (`CAL TON_x(IN := …, PT := …)`: the inputs are stored into the instance first), a label
/// with no instruction after it, and a jump that is not conditional on the current result.
#[test]
fn the_il_keeps_to_the_plainest_forms() {
    for (name, p) in all_programs() {
        let what = describe(&name, &p);
        let body = il::body(&p);
        let code = instructions(&body);
        assert!(
            !body.contains(":="),
            "{what}: a formal parameter list\n{body}"
        );
        for (i, (label, op, arg)) in code.iter().enumerate() {
            assert!(
                !matches!(op.as_str(), "S" | "R" | "S1" | "R1" | "STN" | "JMP" | "RET"),
                "{what}: operator {op} {arg}\n{body}"
            );
            if op == "CAL" {
                assert!(
                    arg.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'),
                    "{what}: CAL {arg} is not a plain call\n{body}"
                );
            }
            if let Some(l) = label {
                let next = code.get(i + 1);
                assert!(
                    next.is_some_and(|(label, op, _)| label.is_none() && op != "CAL"),
                    "{what}: label {l} is not followed by a plain instruction\n{body}"
                );
            }
        }
    }
}

fn program(text: &str, step: StepRule, markings: Markings) -> Program {
    let n = net(text);
    Program::lower(&n, &options(step, Evolution::OnePass, markings)).unwrap()
}

#[test]
fn conditions_render_each_atom() {
    let p = program(
        "
        s B1 in bool
        s L in int
        p a 1 cap=3
        p b 0 cap=3
        t t1 a*2@1s -> b if B1 AND L > 2
        ",
        StepRule::MaximalStep,
        Markings::Int,
    );
    let at_least = Cond::lit(Atom::AtLeast {
        place: 0,
        avail: true,
        tokens: 2,
    });
    assert_eq!(
        il::cond_text(&p, &at_least),
        "    LD    aAvail\n    GE    2\n"
    );
    let fewer = Cond::not(Atom::AtLeast {
        place: 0,
        avail: false,
        tokens: 2,
    });
    assert_eq!(il::cond_text(&p, &fewer), "    LD    aLocal\n    LT    2\n");
    let room = Cond::lit(Atom::AtMost {
        place: 1,
        produced: true,
        limit: 2,
    });
    assert_eq!(
        il::cond_text(&p, &room),
        "    LD    bLocal\n    ADD   bNew\n    LE    2\n"
    );
    let room_seq = Cond::lit(Atom::AtMost {
        place: 1,
        produced: false,
        limit: 2,
    });
    assert_eq!(
        il::cond_text(&p, &room_seq),
        "    LD    bLocal\n    LE    2\n"
    );
    assert_eq!(
        il::cond_text(&p, &Cond::lit(Atom::Timer(0))),
        "    LD    TON_arc1.Q\n"
    );
    assert_eq!(
        il::cond_text(&p, &Cond::not(Atom::Fired(0))),
        "    LDN   t1Fire\n"
    );
    assert_eq!(il::cond_text(&p, &Cond::Const(false)), "    LD    FALSE\n");
    assert_eq!(
        il::cond_text(&p, &Cond::lit(Atom::Guard(0))),
        "    LD    B1\n    AND(  L\n        GT    2\n    )\n"
    );
    assert_eq!(
        il::cond_text(&p, &Cond::not(Atom::Guard(0))),
        "    LD    B1\n    AND(  L\n        GT    2\n    )\n    NOT\n"
    );
    // The whole enabling: guard, delay, preset, postset.
    assert_eq!(
        il::conjunction_text(&p, &p.transitions[0].enabling.all().cloned().collect::<Vec<_>>()),
        "    LD    B1\n    AND(  L\n        GT    2\n    )\n    AND   TON_arc1.Q\n    AND(  aAvail\n        GE    2\n    )\n    AND(  bLocal\n        ADD   bNew\n        LE    2\n    )\n"
    );
    assert_eq!(il::conjunction_text(&p, &[]), "    LD    TRUE\n");
}

#[test]
fn disjunctions_and_bool_markings() {
    let p = program(
        "
        p a 1 cap=1
        p b 1 cap=1
        p c 0 cap=1
        p d 0 cap=1
        t t1 b -> c
        t t2 a !b -> d
        ",
        StepRule::MaximalStep,
        Markings::Bool,
    );
    let any = Cond::Any(vec![Cond::not(Atom::Marked(1)), Cond::lit(Atom::Fired(0))]);
    assert_eq!(
        il::cond_text(&p, &any),
        "    LDN   bLocal\n    OR    t1Fire\n"
    );
    let body = il::body(&p);
    // t2's inhibitor arc on b: empty, or emptied by t1 in this step.
    assert!(
        body.contains("    LDN   bLocal\n    OR    t1Fire\n")
            || body.contains("    AND(\n        LDN   bLocal\n        OR    t1Fire\n    )\n"),
        "{body}"
    );
    // Resets before sets.
    let reset = body
        .find("    LD    FALSE\n    ST    bLocal\n")
        .expect("b is reset");
    let set = body
        .find("    LD    TRUE\n    ST    cLocal\n")
        .expect("c is set");
    assert!(reset < set, "{body}");
}

#[test]
fn guards_with_signals_of_both_types() {
    let p = program(
        "
        s B in bool
        s Num in int
        p a 1
        t t1 a -> a if Num AND NOT B XOR (Num = B) OR 3 < 2 OR Num > 9999999999
        ",
        StepRule::Sequential,
        Markings::Int,
    );
    let text = il::cond_text(&p, &Cond::lit(Atom::Guard(0)));
    // An integer read as a boolean is compared with 0, a BOOL compared with an integer is
    // converted, and comparisons of constants (or out of DINT range) are folded.
    assert!(
        text.starts_with("    LD    Num\n    NE    0\n    ANDN  B\n"),
        "{text}"
    );
    assert!(
        text.contains("EQ(   B\n            BOOL_TO_DINT\n"),
        "{text}"
    );
    assert!(
        text.contains("    OR    FALSE\n    OR    FALSE\n"),
        "{text}"
    );
    assert!(!text.contains("9999999999"), "{text}");
}

#[test]
fn input_places_are_clamped() {
    let p = program(
        "
        s B in bool
        s C in int
        s D in int
        p i 0 <B
        p j 0 <C cap=5
        p k 0 <D
        p x 0
        t t1 ?i ?j ?k -> x
        ",
        StepRule::Sequential,
        Markings::Int,
    );
    let body = il::body(&p);
    assert!(
        body.contains("    LD    B\n    BOOL_TO_UDINT\n    ST    iLocal\n"),
        "{body}"
    );
    assert!(
        body.contains(
            "    LD    C\n    MAX   0\n    MIN   5\n    DINT_TO_UDINT\n    ST    jLocal\n"
        ),
        "{body}"
    );
    assert!(
        body.contains("    LD    D\n    MAX   0\n    DINT_TO_UDINT\n    ST    kLocal\n"),
        "{body}"
    );
}

// ---------------------------------------------------------------------------------------
// An interpreter for the IL this backend writes, to run it against the net's scanner.

#[derive(Clone, Debug, Default)]
struct Ton {
    input: bool,
    pt: Duration,
    q: bool,
    start: Option<Duration>,
}

#[derive(Debug)]
enum Step {
    Label,
    Op(String, String),
    Open(String, String),
    Close,
    Call(String),
}

struct Machine {
    code: Vec<Step>,
    labels: HashMap<String, usize>,
    vars: HashMap<String, i64>,
    tons: HashMap<String, Ton>,
}

impl Machine {
    fn new(p: &Program) -> Machine {
        let mut code = Vec::new();
        let mut labels = HashMap::new();
        let lines = instructions(&il::body(p));
        let mut i = 0;
        while i < lines.len() {
            let (label, op, arg) = &lines[i];
            i += 1;
            if let Some(l) = label {
                labels.insert(l.to_ascii_uppercase(), code.len());
                code.push(Step::Label);
            } else if op == "CAL" {
                code.push(Step::Call(arg.to_ascii_uppercase()));
            } else if let Some(o) = op.strip_suffix('(') {
                code.push(Step::Open(o.to_string(), arg.clone()));
            } else if op == ")" {
                code.push(Step::Close);
            } else {
                code.push(Step::Op(op.clone(), arg.clone()));
            }
        }
        let mut vars = HashMap::new();
        let mut tons = HashMap::new();
        let interface = plcopen::program_interface(p);
        for v in interface
            .inputs
            .iter()
            .chain(&interface.outputs)
            .chain(&interface.locals)
        {
            if v.ty.iec() == "TON" {
                tons.insert(v.name.to_ascii_uppercase(), Ton::default());
            } else {
                vars.insert(v.name.to_ascii_uppercase(), 0);
            }
        }
        Machine {
            code,
            labels,
            vars,
            tons,
        }
    }

    fn value(&self, operand: &str) -> i64 {
        let upper = operand.to_ascii_uppercase();
        match upper.as_str() {
            "TRUE" => return 1,
            "FALSE" => return 0,
            _ => {}
        }
        if let Ok(n) = operand.parse::<i64>() {
            return n;
        }
        // A duration is carried in the current result as nanoseconds.
        if upper.starts_with("T#") {
            let d = petriplc_net::time::parse_duration(operand).unwrap();
            return i64::try_from(d.as_nanos()).unwrap();
        }
        if let Some((fb, field)) = upper.split_once('.') {
            let t = &self.tons[fb];
            return match field {
                "Q" => i64::from(t.q),
                "IN" => i64::from(t.input),
                "PT" => i64::try_from(t.pt.as_nanos()).unwrap(),
                other => panic!("TON field {other}"),
            };
        }
        *self
            .vars
            .get(&upper)
            .unwrap_or_else(|| panic!("undeclared {operand}"))
    }

    fn store(&mut self, var: &str, v: i64) {
        let upper = var.to_ascii_uppercase();
        if let Some((fb, field)) = upper.split_once('.') {
            let t = self.tons.get_mut(fb).unwrap();
            match field {
                "IN" => t.input = v != 0,
                "PT" => t.pt = Duration::from_nanos(u64::try_from(v).unwrap()),
                other => panic!("cannot store into TON field {other}"),
            }
            return;
        }
        *self
            .vars
            .get_mut(&upper)
            .unwrap_or_else(|| panic!("undeclared {var}")) = v;
    }

    fn apply(op: &str, a: i64, b: i64) -> i64 {
        let (base, negate) = match op {
            "ANDN" | "ORN" | "XORN" => (&op[..op.len() - 1], true),
            _ => (op, false),
        };
        let (a_b, b_b) = (a != 0, (b != 0) != negate);
        match base {
            "AND" => i64::from(a_b && b_b),
            "OR" => i64::from(a_b || b_b),
            "XOR" => i64::from(a_b != b_b),
            "ADD" => a + b,
            "SUB" => {
                assert!(a >= b, "UDINT underflow {a} - {b}");
                a - b
            }
            "GT" => i64::from(a > b),
            "GE" => i64::from(a >= b),
            "EQ" => i64::from(a == b),
            "NE" => i64::from(a != b),
            "LE" => i64::from(a <= b),
            "LT" => i64::from(a < b),
            "MAX" => a.max(b),
            "MIN" => a.min(b),
            other => panic!("operator {other}"),
        }
    }

    fn run(&mut self, now: Duration) {
        let mut pc = 0;
        let mut cr = 0i64;
        let mut stack: Vec<(String, i64)> = Vec::new();
        let mut steps = 0u64;
        // Taken out so that instructions can change the variables they name.
        let code = std::mem::take(&mut self.code);
        while pc < code.len() {
            steps += 1;
            assert!(steps < 10_000_000, "the IL does not terminate");
            let mut next = pc + 1;
            match &code[pc] {
                Step::Label => {}
                Step::Open(op, arg) => {
                    stack.push((op.clone(), cr));
                    if !arg.is_empty() {
                        cr = self.value(arg);
                    }
                }
                Step::Close => {
                    let (op, saved) = stack.pop().expect("balanced");
                    cr = Self::apply(&op, saved, cr);
                }
                Step::Call(fb) => {
                    let t = self.tons.get_mut(fb).unwrap();
                    if t.input {
                        let start = *t.start.get_or_insert(now);
                        t.q = now - start >= t.pt;
                    } else {
                        t.start = None;
                        t.q = false;
                    }
                }
                Step::Op(op, arg) => match op.as_str() {
                    "LD" => cr = self.value(arg),
                    "LDN" => cr = i64::from(self.value(arg) == 0),
                    "ST" => self.store(arg, cr),
                    "NOT" => cr = i64::from(cr == 0),
                    "BOOL_TO_UDINT" | "BOOL_TO_DINT" => {}
                    "DINT_TO_UDINT" => assert!(cr >= 0),
                    "JMP" => next = self.labels[&arg.to_ascii_uppercase()],
                    "JMPC" | "JMPCN" => {
                        if (cr != 0) == (op == "JMPC") {
                            next = self.labels[&arg.to_ascii_uppercase()];
                        }
                    }
                    _ => cr = Self::apply(op, cr, self.value(arg)),
                },
            }
            pc = next;
        }
        self.code = code;
        assert!(stack.is_empty());
    }
}

/// A deterministic stream of numbers, so the input sequences are reproducible.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self, n: u64) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 33) % n
    }
}

/// Runs the program's IL and the net's scanner side by side for some scans with changing
/// inputs, comparing markings, outputs and instability after every scan.
fn agree(name: &str, n: &Net, p: &Program, scans: usize) {
    let what = describe(name, p);
    let mut m = Machine::new(p);
    let mut scanner = Scanner::new(
        n,
        ScanOptions {
            step: p.step,
            evolve: p.evolve,
            max_passes: p.max_passes,
        },
    );
    let mut rng = Lcg(7);
    let mut signals = vec![0i64; n.signals().len()];
    let (mut inputs, mut outputs) = (0, 0);
    let mut io = Vec::new();
    for s in n.signals() {
        match s.direction {
            SignalDirection::Input => {
                io.push((true, inputs));
                inputs += 1;
            }
            SignalDirection::Output => {
                io.push((false, outputs));
                outputs += 1;
            }
        }
    }
    for scan in 0..scans {
        let now = p.period * scan as u32;
        for (i, s) in n.signals().iter().enumerate() {
            if s.direction == SignalDirection::Input && rng.next(4) == 0 {
                signals[i] = match s.ty {
                    petriplc_net::SignalType::Bool => rng.next(2) as i64,
                    petriplc_net::SignalType::Int => rng.next(12) as i64 - 3,
                };
                m.store(&p.inputs[io[i].1].ident, signals[i]);
            }
        }
        let result = scanner.scan(now, &mut signals);
        m.run(now);
        let at = format!("{what}, scan {scan}");
        if p.evolve == Evolution::UntilStable {
            assert_eq!(
                m.value(&p.helpers.unstable) != 0,
                result.is_err(),
                "{at}: {result:?}"
            );
        } else {
            assert!(result.is_ok(), "{at}: {result:?}");
        }
        for (i, pl) in n.place_ids().enumerate() {
            assert_eq!(
                m.value(&p.places[i].ident),
                i64::from(scanner.marking()[pl]),
                "{at}: marking of {}",
                p.places[i].label
            );
        }
        if result.is_ok() {
            for (i, s) in n.signals().iter().enumerate() {
                if s.direction == SignalDirection::Output {
                    assert_eq!(
                        m.value(&p.outputs[io[i].1].ident),
                        signals[i],
                        "{at}: output {}",
                        s.name
                    );
                }
            }
        }
    }
}

#[test]
fn the_il_does_what_the_scanner_does() {
    for (name, n) in small_nets() {
        for p in programs(&n) {
            agree(name, &n, &p, 60);
        }
    }
    for (name, _, _) in common::EXAMPLE_NETS {
        let n = common::example(name);
        for p in programs(&n) {
            agree(name, &n, &p, 120);
        }
    }
}
