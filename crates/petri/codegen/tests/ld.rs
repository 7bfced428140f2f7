//! Ladder Diagram backend: the projects validate against the TC6 schema, every wire ends
//! exactly on its source pin, and what LD cannot express is refused with a clear error.
mod common;

use std::collections::BTreeMap;

use petriplc_codegen::lower::{Markings, Options, Program};
use petriplc_codegen::{ld, CodegenError};
use petriplc_net::{Evolution, Net};
use petriplc_testnet::net;

fn ld_of(net: &Net, options: &Options) -> Result<String, CodegenError> {
    let program = Program::lower(net, options).expect("the net lowers");
    ld::project(&program, common::CREATED)
}

fn one_pass(net: &Net) -> Options {
    Options {
        evolve: Evolution::OnePass,
        ..Options::of(net)
    }
}

/// Generates, validates with xmllint and checks the geometry; returns the document.
fn valid(net: &Net, options: &Options) -> String {
    let doc = ld_of(net, options).unwrap_or_else(|e| panic!("LD refused: {e}"));
    if let Err(e) = common::xmllint(&doc) {
        panic!("{e}\n{doc}");
    }
    if let Err(e) = check_geometry(&doc).and_then(|()| check_overlap(&doc)) {
        panic!("{e}\n{doc}");
    }
    doc
}

const CONFLICT: &str = "
    p a 1
    p b 0 >B
    p c 0 >C
    s B out bool
    s C out bool
    t t1 a -> b
    t t2 a -> c
    t t3 b -> a
    t t4 c -> a
";

const READ_INHIBIT: &str = "
    s go in bool
    s stop in bool
    s busy out bool
    p g 0 <go
    p s 0 <stop
    p idle 1
    p run 0 >busy
    t start idle ?g !s -> run if go OR stop
    t halt run ?s -> idle
";

const GUARDS: &str = "
    s x in bool
    s y in bool
    s z in bool
    s o out bool
    p a 1 >o
    p b 0 >o
    t t1 a -> b if (x XOR y) AND NOT (z OR x)
    t t2 b -> a if NOT (x XOR NOT y) OR TRUE AND z
    t t3 a -> a if FALSE
";

#[test]
fn mixer_validates() {
    let net = common::example("mixer");
    let doc = valid(&net, &one_pass(&net));
    // Seed 002's blocks: fire flags, reset and set coils, the initial marking.
    assert!(doc.contains("<LD>"));
    assert!(doc.contains("storage=\"set\""));
    assert!(doc.contains("storage=\"reset\""));
    assert!(doc.contains("<leftPowerRail"));
    assert!(doc.contains("<rightPowerRail"));
}

#[test]
fn blink_validates_with_timers() {
    let net = common::example("blink");
    let doc = valid(&net, &Options::of(&net));
    assert!(doc.contains("typeName=\"TON\""));
    assert!(doc.contains("<expression>T#500ms</expression>"));
    assert!(doc.contains("formalParameter=\"Q\""));
    assert!(doc.contains("<variable name=\"TON_"));
}

#[test]
fn small_nets_validate() {
    for text in [
        CONFLICT,
        READ_INHIBIT,
        GUARDS,
        &format!("step sequential\n{CONFLICT}"),
        &format!("step sequential\n{READ_INHIBIT}"),
        "p a 1\np b 0\nt t1 a@0.5 -> b\nt t2 b@1 -> a",
        "p a 0",
    ] {
        let n = net(text);
        valid(&n, &Options::of(&n));
    }
}

#[test]
fn other_examples_validate_or_are_refused_as_integer() {
    for (name, _, _) in common::EXAMPLE_NETS {
        let n = common::example(name);
        match ld_of(&n, &one_pass(&n)) {
            Ok(doc) => {
                common::xmllint(&doc).unwrap_or_else(|e| panic!("{name}: {e}"));
                check_geometry(&doc)
                    .and_then(|()| check_overlap(&doc))
                    .unwrap_or_else(|e| panic!("{name}: {e}"));
            }
            Err(CodegenError::NeedsSafeNet { .. } | CodegenError::Unsupported { .. }) => {}
            Err(e) => panic!("{name}: {e}"),
        }
    }
}

#[test]
fn output_is_deterministic() {
    let n = net(GUARDS);
    let a = ld_of(&n, &Options::of(&n)).unwrap();
    let b = ld_of(&n, &Options::of(&n)).unwrap();
    assert_eq!(a, b);
}

#[test]
fn rungs_follow_the_scan_order() {
    let doc = valid(&net(CONFLICT), &Options::of(&net(CONFLICT)));
    let at = |needle: &str| {
        doc.find(needle)
            .unwrap_or_else(|| panic!("no {needle} in\n{doc}"))
    };
    // Init first, then the fire flags, then all resets, then all sets, then the outputs.
    let init = at("<variable>Init</variable>");
    let fire = at("<variable>t4Fire</variable>");
    let reset = at("storage=\"reset\"");
    let set_after_resets = doc[reset..].find("storage=\"set\"").unwrap() + reset;
    let last_reset = doc.rfind("storage=\"reset\"").unwrap();
    let output = doc.rfind("<variable>B</variable>").unwrap();
    assert!(init < fire && fire < reset);
    assert!(last_reset < set_after_resets);
    assert!(set_after_resets < output);
}

#[test]
fn sequential_fires_each_transition_at_once() {
    let n = net(&format!("step sequential\n{CONFLICT}"));
    let doc = valid(&n, &Options::of(&n));
    // t1's reset and set rungs come before t2's fire flag is computed.
    let t1_fire = doc.find("<variable>t1Fire</variable>").unwrap();
    let t2_fire = doc.find("<variable>t2Fire</variable>").unwrap();
    let between = &doc[t1_fire..t2_fire];
    assert!(between.contains("storage=\"reset\""));
    assert!(between.contains("storage=\"set\""));
}

#[test]
fn transition_comments_name_a_guard_only_when_there_is_one() {
    // Every backend leaves out a guard that is TRUE; LD alone used to write "if TRUE".
    let n = net("s Go in bool\np a 1 cap=1\np b 0 cap=1\nt t1 a -> b\nt t2 b -> a if Go");
    let doc = valid(&n, &Options::of(&n));
    assert!(doc.contains("Transition t1: a -&gt; b<"), "{doc}");
    assert!(doc.contains("Transition t2: b -&gt; a if Go<"), "{doc}");
    assert!(!doc.contains("if TRUE"), "{doc}");
}

#[test]
fn guards_become_contacts() {
    let doc = valid(&net(GUARDS), &Options::of(&net(GUARDS)));
    // NOT pushed inward: negated contacts on inputs.
    assert!(doc.contains("negated=\"true\""));
    // FALSE guard: Init and NOT Init in series.
    let n = doc.matches("<variable>Init</variable>").count();
    assert!(n >= 3, "Init appears {n} times");
}

#[test]
fn integer_markings_are_refused() {
    let n = net("p a 2\np b 0\nt t1 a -> b");
    let err = ld_of(&n, &Options::of(&n)).unwrap_err();
    match &err {
        CodegenError::NeedsSafeNet {
            lang,
            place,
            reason,
        } => {
            assert_eq!(*lang, "LD");
            assert_eq!(place, "a");
            assert!(reason.contains("--markings"), "{reason}");
        }
        other => panic!("{other:?}"),
    }
    let safe = net("p a 1\np b 0\nt t1 a -> b");
    let int = Options {
        markings: Markings::Int,
        ..Options::of(&safe)
    };
    assert!(matches!(
        ld_of(&safe, &int),
        Err(CodegenError::NeedsSafeNet { .. })
    ));
}

#[test]
fn comparisons_and_integer_signals_are_refused() {
    let n = net("s lvl in int\np a 1\np b 0\nt t1 a -> b if lvl >= 3");
    match ld_of(&n, &Options::of(&n)).unwrap_err() {
        CodegenError::Unsupported { lang, what, hint } => {
            assert_eq!(lang, "LD");
            assert!(what.contains("comparison"), "{what}");
            assert!(hint.contains("--lang st"), "{hint}");
        }
        other => panic!("{other:?}"),
    }
    let n = net("s lvl in int\np a 1\np b 0\nt t1 a -> b if lvl");
    assert!(matches!(
        ld_of(&n, &Options::of(&n)),
        Err(CodegenError::Unsupported { .. })
    ));
    let n = net("s n out int\np a 1 >n");
    assert!(matches!(
        ld_of(&n, &Options::of(&n)),
        Err(CodegenError::Unsupported { .. })
    ));
}

/// A chain of XORs expands each operand twice: refused past a bound on the work, however
/// few branches it would give (`B0 XOR TRUE XOR TRUE …` is one contact), rather than 2^40
/// steps.
#[test]
fn xor_chains_are_refused_in_bounded_work() {
    let guard = std::iter::once("B0")
        .chain(std::iter::repeat_n("TRUE", 39))
        .collect::<Vec<_>>()
        .join(" XOR ");
    let n = net(&format!(
        "s B0 in bool\np a 1\np b 0\nt t1 a -> b if {guard}"
    ));
    match ld_of(&n, &Options::of(&n)).unwrap_err() {
        CodegenError::Unsupported { what, hint, .. } => {
            assert!(what.contains("more than 100000 steps"), "{what}");
            assert!(hint.contains("fewer XORs"), "{hint}");
        }
        other => panic!("{other:?}"),
    }
    // A few XORs are still contacts.
    let n = net("s B0 in bool\ns B1 in bool\np a 1\np b 0\nt t1 a -> b if B0 XOR B1 XOR TRUE");
    valid(&n, &Options::of(&n));
}

#[test]
fn until_stable_is_refused() {
    let n = net("evolve until-stable\np a 1\np b 0\nt t1 a -> b");
    match ld_of(&n, &Options::of(&n)).unwrap_err() {
        CodegenError::Unsupported { what, hint, .. } => {
            assert!(what.contains("until-stable"), "{what}");
            assert!(hint.contains("one-pass"), "{hint}");
        }
        other => panic!("{other:?}"),
    }
}

// ---- A small XML scan for the geometry checks (no XML crate among the dependencies). ----

struct Tag<'a> {
    name: &'a str,
    attrs: Vec<(&'a str, &'a str)>,
    close: bool,
    empty: bool,
    /// The text up to the next tag.
    text: &'a str,
}

impl Tag<'_> {
    fn attr(&self, name: &str) -> Option<&str> {
        self.attrs.iter().find(|a| a.0 == name).map(|a| a.1)
    }
    fn point(&self) -> (f64, f64) {
        let num = |n: &str| self.attr(n).unwrap().parse::<f64>().unwrap();
        (num("x"), num("y"))
    }
}

fn tags(s: &str) -> Vec<Tag<'_>> {
    let mut out = Vec::new();
    let mut rest = s;
    while let Some(start) = rest.find('<') {
        let end = rest[start..].find('>').unwrap() + start;
        let inner = &rest[start + 1..end];
        rest = &rest[end + 1..];
        let text = &rest[..rest.find('<').unwrap_or(rest.len())];
        if inner.starts_with('?') || inner.starts_with('!') {
            continue;
        }
        let close = inner.starts_with('/');
        let empty = inner.ends_with('/');
        let inner = inner.trim_start_matches('/').trim_end_matches('/');
        let (name, mut attrs_text) = inner.split_once(' ').unwrap_or((inner, ""));
        let mut attrs = Vec::new();
        while let Some(eq) = attrs_text.find("=\"") {
            let key = attrs_text[..eq].trim();
            let after = &attrs_text[eq + 2..];
            let q = after.find('"').unwrap();
            attrs.push((key, &after[..q]));
            attrs_text = &after[q + 1..];
        }
        out.push(Tag {
            name,
            attrs,
            close,
            empty,
            text,
        });
    }
    out
}

/// A connection: the element it enters and its input pin, its source and the source's pin,
/// and its points.
struct Wire {
    owner: u64,
    rel: (f64, f64),
    source: u64,
    formal: String,
    points: Vec<(f64, f64)>,
}

/// Every element of the LD body has a position and a unique localId, and every connection
/// runs from its input pin (first point) to its source's pin (last point), exactly.
fn check_geometry(doc: &str) -> Result<(), String> {
    let body = &doc[doc.find("<LD>").ok_or("no <LD>")?..doc.find("</LD>").ok_or("no </LD>")?];
    let tags = tags(body);
    // localId -> position; (localId, formalParameter or "") -> pin relPosition.
    let mut positions: BTreeMap<u64, (f64, f64)> = BTreeMap::new();
    let mut out_pins: BTreeMap<(u64, String), (f64, f64)> = BTreeMap::new();
    let mut wires: Vec<Wire> = Vec::new();

    let mut depth = 0;
    let mut element: Option<u64> = None;
    let mut formal = String::new();
    let mut in_point: Option<(f64, f64)> = None;
    let mut expect: Option<&str> = None; // "in" or "out" relPosition next
    let mut wire: Option<Wire> = None;
    for t in &tags[1..] {
        if t.close {
            depth -= 1;
            match t.name {
                "connection" => wires.push(Wire {
                    rel: in_point.ok_or("no relPosition")?,
                    ..wire.take().unwrap()
                }),
                "variable" => formal.clear(),
                _ => {}
            }
            if depth == 0 {
                element = None;
            }
            continue;
        }
        if depth == 0 {
            let id: u64 = t
                .attr("localId")
                .ok_or(format!("<{}> without localId", t.name))?
                .parse()
                .unwrap();
            if positions.contains_key(&id) || element == Some(id) {
                return Err(format!("localId {id} used twice"));
            }
            element = Some(id);
        }
        let id = element.unwrap();
        match t.name {
            "position" if depth == 1 && positions.insert(id, t.point()).is_some() => {
                return Err(format!("element {id} has two positions"));
            }
            "position" if depth == 1 => {}
            "position" => wire
                .as_mut()
                .ok_or("position outside a connection")?
                .points
                .push(t.point()),
            "variable" => {
                if let Some(f) = t.attr("formalParameter") {
                    formal = f.to_string();
                }
            }
            "connectionPointIn" => expect = Some("in"),
            "connectionPointOut" => expect = Some("out"),
            "relPosition" => match expect.take() {
                Some("in") => in_point = Some(t.point()),
                Some(_) => {
                    out_pins.insert((id, formal.clone()), t.point());
                }
                None => return Err(format!("stray relPosition in {id}")),
            },
            "connection" => {
                wire = Some(Wire {
                    owner: id,
                    rel: (0.0, 0.0),
                    source: t
                        .attr("refLocalId")
                        .ok_or("connection without refLocalId")?
                        .parse()
                        .unwrap(),
                    formal: t.attr("formalParameter").unwrap_or("").to_string(),
                    points: Vec::new(),
                })
            }
            _ => {}
        }
        if !t.empty {
            depth += 1;
        }
        if depth == 0 {
            // A self-closing top-level element has no position.
            return Err(format!("element {id} (<{}>) has no position", t.name));
        }
    }
    let mut ids: Vec<u64> = Vec::new();
    for t in &tags {
        if let Some(id) = t.attr("localId") {
            ids.push(id.parse().unwrap());
        }
    }
    for id in &ids {
        if !positions.contains_key(id) {
            return Err(format!("element {id} has no position"));
        }
    }
    if wires.is_empty() {
        return Err("no connections".into());
    }
    for Wire {
        owner: el,
        rel,
        source: r,
        formal: f,
        points: pts,
    } in &wires
    {
        let pos = positions[el];
        let src = positions
            .get(r)
            .ok_or(format!("element {el} connects to missing {r}"))?;
        let pin = out_pins.get(&(*r, f.clone())).ok_or(format!(
            "element {el} connects to {r}.{f:?}, which has no such pin"
        ))?;
        let (first, last) = (
            pts.first().ok_or("a wire without points")?,
            pts.last().unwrap(),
        );
        if *first != (pos.0 + rel.0, pos.1 + rel.1) {
            return Err(format!("wire {r}→{el} starts at {first:?}, not at the pin"));
        }
        if *last != (src.0 + pin.0, src.1 + pin.1) {
            return Err(format!(
                "wire {r}→{el} ends at {last:?}, not at {r}'s pin {:?}",
                (src.0 + pin.0, src.1 + pin.1)
            ));
        }
        // Wires are drawn with horizontal and vertical segments only.
        for w in pts.windows(2) {
            if w[0].0 != w[1].0 && w[0].1 != w[1].1 {
                return Err(format!("wire {r}→{el} has a diagonal segment"));
            }
        }
    }
    Ok(())
}

#[test]
fn geometry_check_catches_a_misplaced_wire() {
    let n = net(CONFLICT);
    let doc = ld_of(&n, &Options::of(&n)).unwrap();
    check_geometry(&doc).unwrap();
    // Moving the first wire's last point off its source pin must be caught.
    let at = doc.find("</connection>").unwrap();
    let last = doc[..at].rfind("<position x=\"").unwrap() + "<position x=\"".len();
    let broken = format!("{}9{}", &doc[..last], &doc[last..]);
    assert!(check_geometry(&broken).is_err());
}

/// No two elements' boxes intersect (rungs are stacked, branches on their own rows).
fn check_overlap(doc: &str) -> Result<(), String> {
    let body = &doc[doc.find("<LD>").unwrap()..doc.find("</LD>").unwrap()];
    let tags = tags(body);
    let mut boxes = Vec::new();
    for (i, t) in tags.iter().enumerate() {
        if let (Some(_), Some(w), Some(h)) = (t.attr("localId"), t.attr("width"), t.attr("height"))
        {
            let p = tags[i + 1].point();
            let (w, h): (f64, f64) = (w.parse().unwrap(), h.parse().unwrap());
            boxes.push((
                t.name,
                t.attr("localId").unwrap(),
                p.0,
                p.1,
                p.0 + w,
                p.1 + h,
            ));
        }
    }
    for (i, a) in boxes.iter().enumerate() {
        for b in &boxes[i + 1..] {
            if a.2 < b.4 && b.2 < a.4 && a.3 < b.5 && b.3 < a.5 {
                return Err(format!("{a:?} overlaps {b:?}"));
            }
        }
    }
    Ok(())
}

// ---- Running the diagram: an LD interpreter checked against the net's own scans. ----

/// One element of the body as the interpreter needs it.
#[derive(Debug, Default)]
struct Element {
    kind: String,
    id: u64,
    var: String,
    negated: bool,
    storage: String,
    instance: String,
    /// Per input pin (formal parameter, "" for a contact, coil or rail): its sources.
    inputs: Vec<(String, Vec<(u64, String)>)>,
}

fn elements(doc: &str) -> Vec<Element> {
    let body = &doc[doc.find("<LD>").unwrap()..doc.find("</LD>").unwrap()];
    let mut out: Vec<Element> = Vec::new();
    let mut depth = 0;
    let mut formal = String::new();
    for t in &tags(body)[1..] {
        if t.close {
            depth -= 1;
            continue;
        }
        if depth == 0 {
            out.push(Element {
                kind: t.name.to_string(),
                id: t.attr("localId").unwrap().parse().unwrap(),
                negated: t.attr("negated") == Some("true"),
                storage: t.attr("storage").unwrap_or("none").to_string(),
                instance: t.attr("instanceName").unwrap_or("").to_string(),
                ..Default::default()
            });
            formal.clear();
        }
        let el = out.last_mut().unwrap();
        match t.name {
            "variable" => match t.attr("formalParameter") {
                Some(f) => formal = f.to_string(),
                None => el.var = t.text.to_string(),
            },
            "expression" => el.var = t.text.to_string(),
            "connectionPointIn" => el.inputs.push((formal.clone(), Vec::new())),
            "connection" => el.inputs.last_mut().unwrap().1.push((
                t.attr("refLocalId").unwrap().parse().unwrap(),
                t.attr("formalParameter").unwrap_or("").to_string(),
            )),
            _ => {}
        }
        if !t.empty {
            depth += 1;
        }
    }
    out
}

/// Variables and timer states of a running LD program.
#[derive(Default)]
struct Machine {
    vars: BTreeMap<String, bool>,
    /// TON instance -> when its IN went TRUE.
    started: BTreeMap<String, std::time::Duration>,
}

impl Machine {
    /// One scan: every element in document order (sources come before their consumers).
    fn scan(&mut self, els: &[Element], now: std::time::Duration) {
        let mut power: BTreeMap<(u64, String), bool> = BTreeMap::new();
        let mut presets: BTreeMap<u64, std::time::Duration> = BTreeMap::new();
        for el in els {
            let input = |formal: &str, power: &BTreeMap<(u64, String), bool>| {
                let (_, srcs) = el.inputs.iter().find(|i| i.0 == formal).unwrap();
                srcs.iter().any(|s| power[s])
            };
            match el.kind.as_str() {
                "leftPowerRail" => {
                    power.insert((el.id, String::new()), true);
                }
                "contact" => {
                    let v = self.vars.get(&el.var).copied().unwrap_or(false);
                    let on = input("", &power) && (v != el.negated);
                    power.insert((el.id, String::new()), on);
                }
                "coil" => {
                    let on = input("", &power);
                    match el.storage.as_str() {
                        "set" if on => {
                            self.vars.insert(el.var.clone(), true);
                        }
                        "reset" if on => {
                            self.vars.insert(el.var.clone(), false);
                        }
                        "none" => {
                            self.vars.insert(el.var.clone(), on);
                        }
                        _ => {}
                    }
                    power.insert((el.id, String::new()), on);
                }
                "inVariable" => {
                    let d = petriplc_net::time::parse_duration(&el.var).unwrap();
                    presets.insert(el.id, d);
                }
                "block" => {
                    let on = input("IN", &power);
                    let (_, srcs) = el.inputs.iter().find(|i| i.0 == "PT").unwrap();
                    let pt = presets[&srcs[0].0];
                    let q = if on {
                        let start = *self.started.entry(el.instance.clone()).or_insert(now);
                        now - start >= pt
                    } else {
                        self.started.remove(&el.instance);
                        false
                    };
                    power.insert((el.id, "Q".into()), q);
                }
                _ => {}
            }
        }
    }
}

/// Runs the LD of `net` and the net's own scanner side by side on pseudo-random inputs and
/// compares markings and outputs after every scan.
fn runs_like_the_net(net: &Net, scans: usize) {
    use petriplc_net::{ScanOptions, Scanner, SignalDirection};
    let options = Options::of(net);
    let program = Program::lower(net, &options).unwrap();
    let doc = ld::project(&program, common::CREATED).unwrap();
    let els = elements(&doc);
    let ident = |name: &str| {
        program
            .inputs
            .iter()
            .chain(&program.outputs)
            .find(|io| io.name == name)
            .unwrap()
            .ident
            .clone()
    };
    let mut machine = Machine::default();
    let mut scanner = Scanner::new(net, ScanOptions::of(net));
    let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
    for k in 0..scans {
        let now = std::time::Duration::from_millis(100 * k as u64);
        let mut signals = vec![0i64; net.signals().len()];
        for (i, s) in net.signals().iter().enumerate() {
            if s.direction == SignalDirection::Input {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                signals[i] = ((seed >> 33) % 2) as i64;
                machine.vars.insert(ident(&s.name), signals[i] != 0);
            }
        }
        machine.scan(&els, now);
        scanner.scan(now, &mut signals).unwrap();
        for (i, pl) in program.places.iter().enumerate() {
            assert_eq!(
                machine.vars.get(&pl.ident).copied().unwrap_or(false),
                scanner.marking().0[i] == 1,
                "scan {k}: marking of {} differs",
                pl.label
            );
        }
        for (i, s) in net.signals().iter().enumerate() {
            if s.direction == SignalDirection::Output {
                assert_eq!(
                    machine.vars.get(&ident(&s.name)).copied().unwrap_or(false),
                    signals[i] != 0,
                    "scan {k}: output {} differs",
                    s.name
                );
            }
        }
    }
}

#[test]
fn the_diagram_runs_like_the_net() {
    for text in [
        CONFLICT,
        READ_INHIBIT,
        GUARDS,
        &format!("step sequential\n{CONFLICT}"),
        &format!("step sequential\n{READ_INHIBIT}"),
        &format!("step sequential\n{GUARDS}"),
        "p a 1\np b 0\np c 0 cap=1\nt t1 a -> c\nt t2 b -> c\nt t0 c -> b",
        "s o out bool\np a 1 >o\np b 0\nt t1 a@0.3 -> b\nt t2 b@0.5 -> a",
    ] {
        runs_like_the_net(&net(text), 60);
    }
    for name in ["mixer", "blink", "philosophers", "busy-beaver", "tank"] {
        let n = common::example(name);
        if n.evolve == Evolution::OnePass {
            runs_like_the_net(&n, 200);
        }
    }
}

#[test]
fn degenerate_nets_validate_and_run_like_the_net() {
    for (name, n) in common::degenerate_nets() {
        match ld_of(&n, &one_pass(&n)) {
            Ok(_) => {
                valid(&n, &one_pass(&n));
                runs_like_the_net(&n, 40);
            }
            Err(CodegenError::NeedsSafeNet { .. }) => {}
            Err(e) => panic!("{name}: {e}"),
        }
    }
}
