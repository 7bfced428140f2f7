//! The SFC backend: charts that validate against the PLCopen schema, their structure, the
//! geometry of every connection, and each net refused with the reason it gives.
mod common;

use petriplc_codegen::lower::Program;
use petriplc_codegen::{sfc, CodegenError, Options};
use petriplc_net::Net;
use petriplc_testnet::net;

fn generate(net: &Net) -> Result<String, CodegenError> {
    let program = Program::lower(net, &Options::of(net)).expect("lowers");
    sfc::project(net, &program, common::CREATED)
}

/// Generates, validates with xmllint and checks every connection's geometry.
fn valid(net: &Net) -> String {
    let doc = generate(net).unwrap_or_else(|e| panic!("refused: {e}"));
    if let Err(e) = common::xmllint(&doc) {
        panic!("{e}\n{doc}");
    }
    check_connections(&doc);
    doc
}

fn refusal(net: &Net) -> String {
    match generate(net) {
        Ok(doc) => panic!("accepted:\n{doc}"),
        Err(e) => e.to_string(),
    }
}

#[derive(Debug, Default)]
struct Conn {
    from: u64,
    formal: Option<String>,
    points: Vec<(i64, i64)>,
}

#[derive(Debug, Default)]
struct PointIn {
    rel: Option<(i64, i64)>,
    conns: Vec<Conn>,
}

#[derive(Debug, Default)]
struct PointOut {
    formal: Option<String>,
    action: bool,
    rel: Option<(i64, i64)>,
}

#[derive(Debug, Default)]
struct Element {
    tag: String,
    id: u64,
    head: String,
    pos: Option<(i64, i64)>,
    ins: Vec<PointIn>,
    outs: Vec<PointOut>,
}

fn attr(line: &str, name: &str) -> Option<String> {
    let key = format!(" {name}=\"");
    let start = line.find(&key)? + key.len();
    let len = line[start..].find('"')?;
    Some(line[start..start + len].to_string())
}

fn xy(line: &str) -> (i64, i64) {
    let n = |k| attr(line, k).and_then(|v| v.parse().ok()).expect("x and y");
    (n("x"), n("y"))
}

/// The elements of the SFC body, read line by line from the layout the backend writes.
fn elements(doc: &str) -> Vec<Element> {
    let body = &doc[doc.find("<SFC>").expect("an SFC body")..doc.find("</SFC>").unwrap()];
    let mut out: Vec<Element> = Vec::new();
    #[derive(PartialEq)]
    enum Inside {
        Element,
        PointIn,
        Connection,
        PointOut,
        Action,
        Other,
    }
    let mut at = Inside::Other;
    for line in body.lines() {
        let t = line.trim();
        if line.starts_with("            <") && !line.starts_with("             ") {
            if t.starts_with("</") {
                at = Inside::Other;
                continue;
            }
            let tag = t[1..].split([' ', '>', '/']).next().unwrap().to_string();
            out.push(Element {
                tag,
                id: attr(t, "localId").expect("localId").parse().unwrap(),
                head: t.to_string(),
                ..Default::default()
            });
            at = Inside::Element;
            continue;
        }
        let Some(e) = out.last_mut() else { continue };
        if t.starts_with("<connectionPointIn>") && at == Inside::Element {
            e.ins.push(PointIn::default());
            at = Inside::PointIn;
        } else if t.starts_with("</connectionPointIn>") {
            at = Inside::Element;
        } else if t.starts_with("<connection ") {
            e.ins.last_mut().unwrap().conns.push(Conn {
                from: attr(t, "refLocalId").unwrap().parse().unwrap(),
                formal: attr(t, "formalParameter"),
                points: Vec::new(),
            });
            at = Inside::Connection;
        } else if t.starts_with("</connection>") {
            at = Inside::PointIn;
        } else if t.starts_with("<connectionPointOut") && at == Inside::Element {
            e.outs.push(PointOut {
                formal: attr(t, "formalParameter"),
                action: t.starts_with("<connectionPointOutAction"),
                rel: None,
            });
            at = Inside::PointOut;
        } else if t.starts_with("</connectionPointOut") {
            at = Inside::Element;
        } else if t.starts_with("<action ") {
            at = Inside::Action;
        } else if t.starts_with("</action>") {
            at = Inside::Element;
        } else if t.starts_with("<position ") {
            match at {
                Inside::Element if e.pos.is_none() => e.pos = Some(xy(t)),
                Inside::Connection => e
                    .ins
                    .last_mut()
                    .unwrap()
                    .conns
                    .last_mut()
                    .unwrap()
                    .points
                    .push(xy(t)),
                _ => {}
            }
        } else if t.starts_with("<relPosition ") {
            match at {
                Inside::PointIn => e.ins.last_mut().unwrap().rel = Some(xy(t)),
                Inside::PointOut => e.outs.last_mut().unwrap().rel = Some(xy(t)),
                _ => {}
            }
        }
    }
    out
}

/// Every element has a position and a unique localId; every connectionPointIn has a
/// connection whose first point is the pin and whose last point is exactly the source
/// element's position plus its connectionPointOut's relPosition.
fn check_connections(doc: &str) {
    let els = elements(doc);
    assert!(!els.is_empty());
    let mut ids: Vec<u64> = els.iter().map(|e| e.id).collect();
    ids.sort();
    let n = ids.len();
    ids.dedup();
    assert_eq!(ids.len(), n, "localIds are unique");
    let add = |a: (i64, i64), b: (i64, i64)| (a.0 + b.0, a.1 + b.1);
    for e in &els {
        let pos = e
            .pos
            .unwrap_or_else(|| panic!("{} has no position", e.head));
        for pin in &e.ins {
            assert_eq!(pin.conns.len(), 1, "{}: one connection per pin", e.head);
            let c = &pin.conns[0];
            assert!(
                c.points.len() >= 2,
                "{}: a connection has its points",
                e.head
            );
            let rel = pin.rel.expect("connectionPointIn has a relPosition");
            assert_eq!(
                c.points[0],
                add(pos, rel),
                "{}: first point is the pin",
                e.head
            );
            let src = els
                .iter()
                .find(|s| s.id == c.from)
                .unwrap_or_else(|| panic!("{}: no element {}", e.head, c.from));
            let out = match &c.formal {
                Some(f) => src
                    .outs
                    .iter()
                    .find(|o| o.formal.as_deref() == Some(f.as_str()) && !o.action),
                None if e.tag == "actionBlock" => src.outs.iter().find(|o| o.action),
                None => {
                    let plain: Vec<_> = src.outs.iter().filter(|o| !o.action).collect();
                    assert_eq!(plain.len(), 1, "{}: {} has one output", e.head, src.head);
                    Some(plain[0])
                }
            };
            let out = out.unwrap_or_else(|| panic!("{}: {} lacks the output", e.head, src.head));
            let end = add(src.pos.unwrap(), out.rel.expect("relPosition"));
            assert_eq!(
                *c.points.last().unwrap(),
                end,
                "{}: last point is {}'s output",
                e.head,
                src.head
            );
        }
    }
}

fn find<'a>(els: &'a [Element], tag: &str, name: &str) -> &'a Element {
    els.iter()
        .find(|e| e.tag == tag && attr(&e.head, "name").as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no {tag} {name}"))
}

/// The elements whose single connection comes from element `id`.
fn fed_by(els: &[Element], id: u64) -> Vec<&Element> {
    els.iter()
        .filter(|e| {
            e.ins
                .iter()
                .any(|pin| pin.conns.iter().any(|c| c.from == id))
        })
        .collect()
}

#[test]
fn mixer_is_the_seed_chart() {
    let doc = valid(&common::example("mixer"));
    let els = elements(&doc);
    for step in [
        "L1Local", "A1Local", "V1Local", "L2Local", "V2Local", "M1Local", "V3Local", "L3Local",
    ] {
        find(&els, "step", step);
    }
    assert!(find(&els, "step", "L1Local")
        .head
        .contains("initialStep=\"true\""));
    assert_eq!(doc.matches("initialStep=\"true\"").count(), 1);
    // The initial step is entered only by the jump.
    assert!(find(&els, "step", "L1Local").ins.is_empty());
    let jumps: Vec<_> = els.iter().filter(|e| e.tag == "jumpStep").collect();
    assert_eq!(jumps.len(), 1);
    assert!(jumps[0].head.contains("targetName=\"L1Local\""));

    // B1 is followed by a simultaneous divergence to A1, V1 and L2.
    let l1 = find(&els, "step", "L1Local");
    let b1 = fed_by(&els, l1.id)
        .into_iter()
        .find(|e| e.tag == "transition")
        .unwrap();
    assert!(doc.contains("<![CDATA[B1]]>"));
    let div = fed_by(&els, b1.id);
    assert_eq!(div.len(), 1);
    assert_eq!(div[0].tag, "simultaneousDivergence");
    let mut branches: Vec<String> = fed_by(&els, div[0].id)
        .iter()
        .map(|e| attr(&e.head, "name").unwrap())
        .collect();
    branches.sort();
    assert_eq!(branches, ["A1Local", "L2Local", "V1Local"]);

    // N3 waits for V2, M1, A1 and L2: a simultaneous convergence of four branches.
    let convs: Vec<_> = els
        .iter()
        .filter(|e| e.tag == "simultaneousConvergence")
        .collect();
    assert_eq!(convs.len(), 2, "before N3 and before N1");
    let n3_conv = convs.iter().find(|c| c.ins.len() == 4).expect("N3's");
    let mut from: Vec<String> = n3_conv
        .ins
        .iter()
        .map(|pin| {
            let src = els.iter().find(|e| e.id == pin.conns[0].from).unwrap();
            attr(&src.head, "name").unwrap()
        })
        .collect();
    from.sort();
    assert_eq!(from, ["A1Local", "L2Local", "M1Local", "V2Local"]);
    let n3 = fed_by(&els, n3_conv.id);
    assert_eq!(n3[0].tag, "transition");
    assert_eq!(doc.matches("<simultaneousDivergence").count(), 3);
    assert!(!doc.contains("selectionDivergence"));

    // Each step drives its output with an N action.
    for out in ["L1", "A1", "V1", "L2", "V2", "M1", "V3", "L3"] {
        assert!(
            doc.contains(&format!("<reference name=\"{out}\"/>")),
            "action for {out}"
        );
    }
    assert_eq!(doc.matches("qualifier=\"N\"").count(), 8);
    assert!(doc.contains("<SFC>") && !doc.contains("<localVars>"));
}

#[test]
fn choice_becomes_selection_with_priorities() {
    let doc = valid(&net("
        s go in bool
        s stop in bool
        s A out bool
        s B out bool
        p a 1
        p b 0 >A
        p c 0 >B
        p d 0 >A
        t t1 a -> b if go
        t t2 a -> c if stop OR go
        t t3 b -> d
        t t4 c -> d
        t t5 d -> a
    "));
    let els = elements(&doc);
    let a = find(&els, "step", "aLocal");
    let div = fed_by(&els, a.id);
    assert_eq!(div[0].tag, "selectionDivergence");
    let branches = fed_by(&els, div[0].id);
    assert_eq!(branches.len(), 2);
    // Declaration order is priority order, left to right.
    assert!(branches[0].head.contains("priority=\"1\""));
    assert!(branches[1].head.contains("priority=\"2\""));
    assert!(branches[0].pos.unwrap().0 < branches[1].pos.unwrap().0);
    assert!(doc.contains("<![CDATA[go]]>"));
    assert!(doc.contains("<![CDATA[stop OR go]]>"));
    // b and c meet before d.
    let d = find(&els, "step", "dLocal");
    let conv = els.iter().find(|e| e.id == d.ins[0].conns[0].from).unwrap();
    assert_eq!(conv.tag, "selectionConvergence");
    assert_eq!(conv.ins.len(), 2);
    assert!(doc.contains("targetName=\"aLocal\""));
    // Two steps drive A: two N actions, which IEC ORs.
    assert_eq!(doc.matches("<reference name=\"A\"/>").count(), 2);
}

#[test]
fn read_inhibitor_and_delay_arcs_become_receptivities() {
    let doc = valid(&net("
        s start in bool
        s hold in bool
        s level in int
        s Lamp out bool
        p idle 1
        p run 0 >Lamp
        p aux 0
        p aux2 0
        p done 0
        p btn 0 <start
        p h 0 <hold
        p lvl 0 <level
        t go idle ?btn !h -> run aux if NOT hold OR start
        t chk aux ?run !done ?lvl*3 -> aux2
        t stop run@0.5 -> done
        t fin done aux2 -> idle
    "));
    assert!(
        doc.contains("<![CDATA[(NOT hold OR start) AND start AND NOT hold]]>"),
        "{doc}"
    );
    assert!(doc.contains("<![CDATA[runLocal.X AND level >= 3 AND NOT doneLocal.X]]>"));
    assert!(doc.contains("<![CDATA[runLocal.T >= T#500ms]]>"));
    assert!(doc.contains("<![CDATA[TRUE]]>"));
    assert!(doc.contains("<DINT/>"));
}

#[test]
fn a_capacity_no_invariant_implies_is_checked() {
    // q and e are safe only by their capacity: a transition filling them waits while they
    // are marked (E4), which the SFC must spell out.
    let doc = valid(&net("
        p a 1
        p b 0
        p q 0 cap=1
        p e 0 cap=1
        t t1 a -> b q
        t t2 b -> a
        t t3 q -> e
    "));
    assert!(doc.contains("<![CDATA[NOT qLocal.X]]>"), "{doc}");
    assert!(doc.contains("<![CDATA[NOT eLocal.X]]>"));
    assert!(doc.contains("<![CDATA[TRUE]]>"));
    assert!(doc.contains("targetName=\"aLocal\""));
}

#[test]
fn conflicts_between_parallel_branches_meet_in_convergences() {
    // b is wanted by t1 (with a) and t2 (with c): b's selection divergence feeds both
    // transitions' simultaneous convergences.
    let doc = valid(&net("
        p s 1
        p a 0
        p b 0
        p c 0
        p x 0
        p y 0
        t t0 s -> a b c
        t t1 a b -> x
        t t2 b c -> y
    "));
    let els = elements(&doc);
    let b = find(&els, "step", "bLocal");
    let div = fed_by(&els, b.id);
    assert_eq!(div[0].tag, "selectionDivergence");
    let convs = fed_by(&els, div[0].id);
    assert_eq!(convs.len(), 2);
    assert!(convs.iter().all(|c| c.tag == "simultaneousConvergence"));
    assert!(!doc.contains("jumpStep"));
}

#[test]
fn refusals_name_the_element_and_the_fix() {
    let two_initial = refusal(&net("
        p a 1
        p b 1
        t t1 a -> b
        t t2 b -> a
    "));
    assert!(
        two_initial.contains("places a, b are all marked initially"),
        "{two_initial}"
    );
    assert!(two_initial.contains("mark exactly one place"));

    let two_tokens = refusal(&net("
        p a 2
        p b 0
        t t1 a -> b
        t t2 b -> a
    "));
    assert!(
        two_tokens.contains("place a starts with 2 tokens"),
        "{two_tokens}"
    );
    assert!(two_tokens.contains("give it exactly one token"));

    let two_arcs_in = refusal(&net("
        p a 1
        p b 0
        p c 0
        t t1 a -> b
        t t2 a -> c
        t t3 b -> a
        t t4 c -> a
    "));
    assert!(
        two_arcs_in.contains("the initial place a has 2 arcs into it (from transitions t3, t4)"),
        "{two_arcs_in}"
    );
    assert!(two_arcs_in.contains("single transition back to a"));

    let sequential = refusal(&net("
        step sequential
        p a 1
        p b 0
        t t1 a -> b
        t t2 b -> a
    "));
    assert!(
        sequential.contains("SFC cannot express step rule sequential with evolution one-pass"),
        "{sequential}"
    );
    assert!(sequential.contains("use --step maximal-step --evolve one-pass, or --lang st, il or c"));

    let until_stable = refusal(&net("
        evolve until-stable
        p a 1
        p b 0
        t t1 a -> b
        t t2 b -> a
    "));
    assert!(
        until_stable.contains("evolution until-stable"),
        "{until_stable}"
    );

    let unreachable = refusal(&net("
        p a 1
        p b 0
        p c 0
        t t1 a -> b
        t t2 b -> a
    "));
    assert!(
        unreachable.contains("place c cannot be reached from the initial place a"),
        "{unreachable}"
    );
    assert!(unreachable.contains("connect it or remove it"));

    let int_output = refusal(&net("
        s Count out int
        p a 1 >Count
        p b 0
        t t1 a -> b
        t t2 b -> a
    "));
    assert!(
        int_output.contains("SFC cannot express integer output Count"),
        "{int_output}"
    );

    let stale_read = refusal(&net("
        p a 1
        p b 0
        p c 0
        p d 0
        p e 0
        t t0 a -> b c
        t t1 b -> d
        t t2 c ?b -> e
        t t3 d e -> a
    "));
    assert!(
        stale_read.contains("transition t2 tests place b")
            && stale_read.contains("declare t2 before t1"),
        "{stale_read}"
    );

    let debounce = refusal(&net("
        s x in bool
        p a 1
        p b 0
        p i 0 <x
        t t1 a ?i@1s -> b
        t t2 b -> a
    "));
    assert!(debounce.contains("from input place i"), "{debounce}");
}

#[test]
fn output_is_deterministic() {
    let n = common::example("mixer");
    assert_eq!(generate(&n).unwrap(), generate(&n).unwrap());
}
