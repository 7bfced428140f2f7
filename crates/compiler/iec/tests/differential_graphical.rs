//! The LD and SFC that `petriplc compile --lang ld|sfc` writes run on the engine exactly as
//! `petriplc sim` runs the net: for every example net and 500 random safe nets (the codegen
//! property tests' generator, restricted to safe nets), in every step rule and evolution
//! `compile` supports for the language, 2 s of 10 ms scans on the net's timeline, outputs and
//! markings compared scan by scan. A net the generator refuses for a language (not safe, an
//! integer output, not an SFC shape, a mode the language cannot express) is counted and
//! skipped; the figures are printed and quoted in docs/codegen.md.

mod common;

use std::time::Duration;

use common::{as_int, example_timeline, random, read, NETS};
use petriplc_codegen::{generate, Form, Language, Markings, Options, Program, Request};
use petriplc_iec::{build_text, Select};
use petriplc_iec_sema::value::Value;
use petriplc_iec_vm::Machine;
use petriplc_net::guard::parse;
use petriplc_net::{
    ArcKind, ArcSpec, Evolution, Net, NetBuilder, PlaceSpec, ScanOptions, SignalDirection,
    SignalType, StepRule, TransitionSpec,
};
use petriplc_sim::{SimOptions, Simulation, Timeline};
use proptest::strategy::{Strategy, ValueTree};
use proptest::test_runner::TestRunner;

const RULES: [(StepRule, Evolution); 4] = [
    (StepRule::MaximalStep, Evolution::OnePass),
    (StepRule::MaximalStep, Evolution::UntilStable),
    (StepRule::Sequential, Evolution::OnePass),
    (StepRule::Sequential, Evolution::UntilStable),
];

const LANGUAGES: [Language; 2] = [Language::Ld, Language::Sfc];

/// The generator's safe net over its boolean signals only: LD and SFC are relay logic over
/// BOOL signals, so the integer input `N` (and its input place of capacity 4), the integer
/// output and the guards comparing `N` are left out; places, arcs (kinds, delays),
/// transitions and the timeline are the generator's.
fn safe_net(d: &random::Desc) -> Net {
    let mut b = NetBuilder::new("random", "random");
    for name in ["I0", "I1"] {
        b.signal(name, SignalDirection::Input, SignalType::Bool);
    }
    b.signal("Q", SignalDirection::Output, SignalType::Bool);
    let n = d.places.len();
    for (i, &(initial, _)) in d.places.iter().enumerate() {
        b.place(PlaceSpec {
            id: format!("p{i}"),
            name: format!("p{i}"),
            initial,
            capacity: Some(1),
            output: matches!(i, 0 | 2).then(|| "Q".into()),
            ..Default::default()
        });
    }
    for (k, s) in ["I0", "I1"].iter().enumerate() {
        b.place(PlaceSpec {
            id: format!("in{k}"),
            name: format!("in{k}"),
            input: Some(s.to_string()),
            ..Default::default()
        });
    }
    const GUARDS: [&str; 5] = ["", "I0", "NOT I1", "I0 AND I1", "I0 XOR I1"];
    for (t, (arcs, g)) in d.transitions.iter().enumerate() {
        b.transition(TransitionSpec {
            id: format!("t{t}"),
            name: format!("t{t}"),
            guard: parse(GUARDS[*g as usize % GUARDS.len()]).unwrap(),
        });
        let mut seen = Vec::new();
        for (i, &(p, kind, _, delay)) in arcs.iter().enumerate() {
            let p = p % (n + 2);
            let input = p >= n;
            let place = if input {
                format!("in{}", p - n)
            } else {
                format!("p{p}")
            };
            let kind = match (kind, input) {
                (0 | 2, true) => 2,
                (_, true) => 3,
                (k, false) => k,
            };
            let outgoing = kind == 1;
            if seen.contains(&(p, outgoing)) {
                continue;
            }
            seen.push((p, outgoing));
            let (source, target, kind) = match kind {
                0 => (place, format!("t{t}"), ArcKind::Normal),
                1 => (format!("t{t}"), place, ArcKind::Normal),
                2 => (place, format!("t{t}"), ArcKind::Read),
                _ => (place, format!("t{t}"), ArcKind::Inhibitor),
            };
            let delay = (delay > 0 && !outgoing && kind != ArcKind::Inhibitor)
                .then(|| Duration::from_millis(10 * delay));
            b.arc(ArcSpec {
                id: format!("a{t}_{i}"),
                source,
                target,
                kind,
                weight: 1,
                delay,
            });
        }
    }
    b.build().expect("random nets are valid by construction")
}

/// A net of the shape an SFC has, built from the generator's description: a cycle from the
/// initial place through segments, one per generated transition, each a single transition,
/// a selection of two (divergence and convergence) or two simultaneous branches (a fork and
/// a join), with the generated guards; one arc back to the initial place (seed 002's rule).
/// No delays: SFC step time runs from activation, a timed arc's TON from the next scan, a
/// difference `compile --lang sfc` documents.
fn sfc_net(d: &random::Desc) -> Net {
    const GUARDS: [&str; 5] = ["", "I0", "NOT I1", "I0 AND I1", "I0 XOR I1"];
    let mut b = NetBuilder::new("random", "random");
    for name in ["I0", "I1"] {
        b.signal(name, SignalDirection::Input, SignalType::Bool);
    }
    b.signal("Q", SignalDirection::Output, SignalType::Bool);
    b.signal("R", SignalDirection::Output, SignalType::Bool);
    let mut places = 0usize;
    let mut place = |b: &mut NetBuilder, initial: u32| {
        let i = places;
        places += 1;
        b.place(PlaceSpec {
            id: format!("p{i}"),
            name: format!("p{i}"),
            initial,
            capacity: Some(1),
            output: match d.places.get(i % d.places.len()).map(|p| p.0) {
                Some(0) if i % 2 == 0 => Some("Q".into()),
                Some(0) => Some("R".into()),
                _ => None,
            },
            ..Default::default()
        });
        format!("p{i}")
    };
    let mut ts = 0usize;
    let mut transition = |b: &mut NetBuilder, g: u8, pre: &[&str], post: &[&str]| {
        let t = format!("t{ts}");
        ts += 1;
        b.transition(TransitionSpec {
            id: t.clone(),
            name: t.clone(),
            guard: parse(GUARDS[g as usize % GUARDS.len()]).unwrap(),
        });
        for (k, p) in pre.iter().enumerate() {
            b.arc(ArcSpec {
                id: format!("{t}_i{k}"),
                source: p.to_string(),
                target: t.clone(),
                kind: ArcKind::Normal,
                weight: 1,
                delay: None,
            });
        }
        for (k, p) in post.iter().enumerate() {
            b.arc(ArcSpec {
                id: format!("{t}_o{k}"),
                source: t.clone(),
                target: p.to_string(),
                kind: ArcKind::Normal,
                weight: 1,
                delay: None,
            });
        }
    };
    let first = place(&mut b, 1);
    let mut cur = first.clone();
    for (k, (arcs, g)) in d.transitions.iter().enumerate() {
        let g2 = arcs.first().map_or(0, |a| a.1);
        let next = place(&mut b, 0);
        match (arcs.len() + k) % 3 {
            0 => transition(&mut b, *g, &[&cur], &[&next]),
            1 => {
                let a = place(&mut b, 0);
                let c = place(&mut b, 0);
                transition(&mut b, *g, &[&cur], &[&a]);
                transition(&mut b, g2 + 1, &[&cur], &[&c]);
                transition(&mut b, g2, &[&a], &[&next]);
                transition(&mut b, *g + 1, &[&c], &[&next]);
            }
            _ => {
                let a = place(&mut b, 0);
                let c = place(&mut b, 0);
                transition(&mut b, *g, &[&cur], &[&a, &c]);
                transition(&mut b, g2, &[&a, &c], &[&next]);
            }
        }
        cur = next;
    }
    let last = d.timeline.len() as u8;
    transition(&mut b, last, &[&cur], &[&first]);
    b.build()
        .expect("SFC-shaped nets are valid by construction")
}

/// The generator's timeline without the column of `N`.
fn timeline(d: &random::Desc) -> Timeline {
    let mut s = String::from("time,I0,I1\n");
    for &(t, a, b, _) in &d.timeline {
        s.push_str(&format!("{}ms,{},{}\n", t * 10, u8::from(a), u8::from(b)));
    }
    Timeline::parse(&s, "timeline.csv").unwrap()
}

/// What one language did with one net in one mode.
enum Outcome {
    /// `compile` refuses the net (or the mode) for this language.
    Refused,
    /// Scans compared.
    Compared(u64),
}

/// Runs the project `compile --lang lang` writes for one net and one rule against the
/// simulator, scan by scan.
fn compare(
    what: &str,
    net: &Net,
    timeline: Option<&Timeline>,
    plant: Option<&str>,
    lang: Language,
    step: StepRule,
    evolve: Evolution,
) -> Outcome {
    let mut options = Options::of(net);
    options.step = step;
    options.evolve = evolve;
    options.markings = Markings::Auto;
    let request = Request {
        language: lang,
        form: Form::Project,
        options: options.clone(),
        created: "2026-01-01T00:00:00".into(),
    };
    let Ok(generated) = generate(net, &request) else {
        return Outcome::Refused;
    };
    let xml = generated.text;
    let lowered = Program::lower(net, &options).expect("what compile wrote lowers");
    let what = format!("{what} {lang:?} {step:?} {evolve:?}");
    let build = build_text("net.xml", &xml, &Select::Auto).unwrap_or_else(|e| {
        panic!("{what}: the engine refuses the generated project:\n{e}\n{xml}")
    });
    let engine = build.engine.clone();
    let mut m = Machine::new(engine.clone());
    let inst = engine.instances()[0].name.clone();
    let var = |path: &str| {
        engine
            .lookup(&format!("{inst}.{path}"))
            .unwrap_or_else(|| panic!("{what}: no variable {path}"))
    };
    let inputs: Vec<_> = lowered
        .inputs
        .iter()
        .map(|io| (io.name.clone(), var(&io.ident)))
        .collect();
    let outputs: Vec<_> = lowered
        .outputs
        .iter()
        .map(|io| (io.name.clone(), var(&io.ident)))
        .collect();
    // SFC: a place that mirrors an input is no step (its marking is the input); every other
    // place is the step of its name, whose flag is `.X`.
    let places: Vec<_> = lowered
        .places
        .iter()
        .filter(|p| lang != Language::Sfc || p.input.is_none())
        .map(|p| {
            let path = if lang == Language::Sfc {
                format!("{}.X", p.ident)
            } else {
                p.ident.clone()
            };
            let id = net
                .place_ids()
                .find(|&q| net.place_label(q) == p.label)
                .expect("the place is in the net");
            (p.label.clone(), id, var(&path))
        })
        .collect();
    let signal = |n: &str| net.signal_by_name(n).map(|s| s.index());
    let inputs: Vec<_> = inputs.into_iter().map(|(n, v)| (signal(&n), v)).collect();
    let outputs: Vec<_> = outputs
        .into_iter()
        .map(|(n, v)| (n.clone(), signal(&n), v))
        .collect();
    let opts = SimOptions {
        period: Duration::from_millis(10),
        until: Duration::from_secs(2),
        scan: ScanOptions {
            step,
            evolve,
            max_passes: options.max_passes,
        },
    };
    let plant = plant.map(|p| petriplc_sim::builtin(p).expect("a built-in plant"));
    let mut sim = Simulation::new(net, opts, timeline.cloned(), plant).expect("simulation starts");
    let mut scans = 0;
    loop {
        let t = sim.next_time();
        let r = sim.step().map(|row| row.is_some());
        if matches!(r, Ok(false)) {
            break;
        }
        for (n, v) in &inputs {
            let value = n.map_or(0, |i| sim.signals()[i]);
            m.set(*v, &Value::Int(value as i128)).unwrap();
        }
        let iec = m.scan(t.as_nanos() as i64, &mut || true);
        scans += 1;
        match r {
            Err(e) => {
                // A safe net cannot overflow or be unstable in one pass: the simulator stops
                // only where the engine does.
                assert!(
                    iec.is_err(),
                    "{what} at t={t:?}: sim failed ({e}) but the engine went on"
                );
                return Outcome::Compared(scans);
            }
            Ok(_) => {
                if let Err(f) = iec {
                    panic!("{what} at t={t:?}: the engine failed ({f}) but sim went on");
                }
                for (n, i, v) in &outputs {
                    let want = i.map_or(0, |i| sim.signals()[i]);
                    let got = as_int(m.get(*v));
                    assert_eq!(got, want, "{what} at t={t:?}: output {n}\n{xml}");
                }
                for (label, id, v) in &places {
                    let want = sim.scanner().marking()[*id] as i64;
                    let got = as_int(m.get(*v));
                    assert_eq!(got, want, "{what} at t={t:?}: marking of {label}\n{xml}");
                }
            }
        }
    }
    Outcome::Compared(scans)
}

/// Figures of one language: (runs compared, runs refused, scans compared).
#[derive(Default)]
struct Figures {
    nets: usize,
    runs: usize,
    refused: usize,
    scans: u64,
}

impl Figures {
    fn add(&mut self, o: Outcome) -> bool {
        match o {
            Outcome::Refused => {
                self.refused += 1;
                false
            }
            Outcome::Compared(n) => {
                self.runs += 1;
                self.scans += n;
                true
            }
        }
    }
}

#[test]
fn generated_ld_and_sfc_run_as_the_net_simulates() {
    let mut figures: Vec<Figures> = LANGUAGES.iter().map(|_| Figures::default()).collect();
    let mut modes: Vec<Vec<(StepRule, Evolution)>> = vec![Vec::new(); LANGUAGES.len()];
    // The example nets.
    for &(name, path, sipn, timeline, plant) in NETS {
        let net = read(path, sipn);
        let timeline = example_timeline(timeline);
        for (k, &lang) in LANGUAGES.iter().enumerate() {
            let mut any = false;
            for (step, evolve) in RULES {
                let o = compare(name, &net, timeline.as_ref(), plant, lang, step, evolve);
                if figures[k].add(o) {
                    any = true;
                    if !modes[k].contains(&(step, evolve)) {
                        modes[k].push((step, evolve));
                    }
                }
            }
            figures[k].nets += usize::from(any);
        }
    }
    let examples: Vec<(usize, usize, u64)> =
        figures.iter().map(|f| (f.nets, f.runs, f.scans)).collect();
    // 500 random safe nets, the same every run (a fixed seed).
    let mut runner = TestRunner::deterministic();
    let strategy = random::arb_desc().prop_filter("safe nets", |d| d.safe);
    let mut safe = 0;
    while safe < 500 {
        let d = strategy.new_tree(&mut runner).expect("a net").current();
        safe += 1;
        let timeline = timeline(&d);
        for (k, &lang) in LANGUAGES.iter().enumerate() {
            let net = if lang == Language::Sfc {
                sfc_net(&d)
            } else {
                safe_net(&d)
            };
            let mut any = false;
            for (step, evolve) in RULES {
                let what = format!("random net {safe} {d:?}");
                let o = compare(&what, &net, Some(&timeline), None, lang, step, evolve);
                if figures[k].add(o) {
                    any = true;
                    if !modes[k].contains(&(step, evolve)) {
                        modes[k].push((step, evolve));
                    }
                }
            }
            figures[k].nets += usize::from(any);
        }
    }
    for (k, lang) in LANGUAGES.iter().enumerate() {
        let f = &figures[k];
        let (en, er, es) = examples[k];
        eprintln!(
            "differential {lang:?}: {} nets ({en} examples, {} of {safe} random safe nets), modes {:?}, {} runs ({er} on examples), {} scans compared ({es} on examples); {} net-mode pairs refused by compile",
            f.nets,
            f.nets - en,
            modes[k],
            f.runs,
            f.scans,
            f.refused
        );
        assert!(f.runs > 0 && f.scans > 0, "{lang:?}: nothing compared");
    }
}
