//! The differential harness: the code `petriplc compile` writes, in any language and form,
//! run by the engine in step with `petriplc sim` running the net, outputs and markings compared
//! scan by scan. Each test file picks its languages ([`compare`] takes them); random nets come
//! from the code generator's property-test generators ([`random`]).
#![allow(dead_code)]

#[path = "../../../../petri/codegen/tests/common/random.rs"]
pub mod random;

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use petriplc_codegen::{generate, Form, Language, Markings, Options, Program, Request};
use petriplc_iec::sema::Overflow;
use petriplc_iec::{build, Natives, Select, Sources};
use petriplc_iec_sema::value::Value;
use petriplc_iec_vm::{Backend, Engine, Machine, VarRef};
use petriplc_net::{Evolution, Net, PlaceId, ScanOptions, SignalId, StepRule};
use petriplc_pnml::{Naming, ReadOptions};
use petriplc_sim::{SimOptions, Simulation, Timeline};

pub const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../examples");

/// (name, net, SIPN naming, timeline, built-in plant), as the examples' READMEs run them.
pub type Example = (
    &'static str,
    &'static str,
    bool,
    Option<&'static str>,
    Option<&'static str>,
);

pub const NETS: &[Example] = &[
    (
        "mixer",
        "mixer/mixer.pnml",
        true,
        Some("mixer/timeline.csv"),
        None,
    ),
    ("tank", "mixer/tank.pnml", false, None, None),
    (
        "blink",
        "blink/blink.pnml",
        false,
        Some("blink/timeline.csv"),
        None,
    ),
    (
        "philosophers",
        "philosophers/philosophers.pnml",
        false,
        Some("philosophers/timeline.csv"),
        None,
    ),
    (
        "keyboard",
        "keyboard/keyboard.pnml",
        false,
        Some("keyboard/timeline.csv"),
        Some("keyboard"),
    ),
    (
        "busy-beaver",
        "busy-beaver/busy-beaver.pnml",
        false,
        None,
        Some("tape"),
    ),
];

/// One way `petriplc compile` can be asked to generate: step rule, evolution, markings.
#[derive(Clone, Copy, Debug)]
pub struct Mode {
    pub step: StepRule,
    pub evolve: Evolution,
    pub markings: Markings,
}

/// Every mode `compile` supports (`--step`, `--evolve`, `--markings`).
pub fn modes() -> Vec<Mode> {
    let mut v = Vec::new();
    for step in [StepRule::MaximalStep, StepRule::Sequential] {
        for evolve in [Evolution::OnePass, Evolution::UntilStable] {
            for markings in [Markings::Auto, Markings::Int] {
                v.push(Mode {
                    step,
                    evolve,
                    markings,
                });
            }
        }
    }
    v
}

pub fn read(path: &str, sipn: bool) -> Net {
    let options = ReadOptions {
        naming: if sipn { Naming::Sipn } else { Naming::Plain },
    };
    petriplc_pnml::read_file(Path::new(&format!("{EXAMPLES}/{path}")), &options)
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .net
}

pub fn example_timeline(path: Option<&str>) -> Option<Timeline> {
    path.map(|t| Timeline::read_file(Path::new(&format!("{EXAMPLES}/{t}"))).unwrap())
}

/// What was compared, per language and form.
#[derive(Default, Debug)]
pub struct Figures {
    pub nets: u64,
    /// (language and form) → (runs, scans compared)
    pub compared: BTreeMap<String, (u64, u64)>,
    /// (language and form) → runs where `compile` refused the net (LD and SFC need safe nets)
    pub refused: BTreeMap<String, u64>,
}

impl Figures {
    pub fn runs(&self) -> u64 {
        self.compared.values().map(|c| c.0).sum()
    }

    pub fn scans(&self) -> u64 {
        self.compared.values().map(|c| c.1).sum()
    }

    pub fn merge(&mut self, other: Figures) {
        self.nets += other.nets;
        for (k, (runs, scans)) in other.compared {
            let c = self.compared.entry(k).or_default();
            c.0 += runs;
            c.1 += scans;
        }
        for (k, n) in other.refused {
            *self.refused.entry(k).or_default() += n;
        }
    }

    pub fn report(&self, what: &str, modes: usize) -> String {
        let mut s = format!(
            "differential ({what}): {} nets, {modes} modes, {} runs, {} scans compared",
            self.nets,
            self.runs(),
            self.scans()
        );
        for (lang, (runs, scans)) in &self.compared {
            s.push_str(&format!("\n  {lang}: {runs} runs, {scans} scans"));
            if let Some(r) = self.refused.get(lang) {
                s.push_str(&format!(" ({r} runs refused by compile)"));
            }
        }
        s
    }
}

pub fn as_int(v: Option<Value>) -> i64 {
    match v {
        Some(Value::Int(i)) => i as i64,
        other => panic!("not an integer: {other:?}"),
    }
}

/// A generated program on the engine, with its variables found.
/// Signals and places are found once (by index), so comparing a scan costs no name look-ups.
struct Runner {
    what: String,
    machine: Machine,
    /// The same program on the bytecode VM alone, in step with `machine` (machine code where
    /// petriplc-iec-jit compiles it): same memory after every scan, same faults.
    vm: Machine,
    slots: u32,
    inputs: Vec<(Option<SignalId>, VarRef)>,
    outputs: Vec<(String, Option<SignalId>, VarRef)>,
    places: Vec<(String, PlaceId, VarRef)>,
    unstable: Option<VarRef>,
}

impl Runner {
    fn new(what: String, engine: Arc<Engine>, lowered: &Program, net: &Net) -> Runner {
        // Bare text runs its PROGRAM; a project runs its configuration's instance.
        let prefix = match engine.project.configuration {
            Some(_) => engine.instances()[0].name.clone(),
            None => lowered.pou.clone(),
        };
        let var = |ident: &str| {
            engine
                .lookup(&format!("{prefix}.{ident}"))
                .unwrap_or_else(|| panic!("{what}: no variable {ident}"))
        };
        let inputs = lowered
            .inputs
            .iter()
            .map(|io| (net.signal_by_name(&io.name), var(&io.ident)))
            .collect();
        let outputs = lowered
            .outputs
            .iter()
            .map(|io| {
                (
                    io.name.clone(),
                    net.signal_by_name(&io.name),
                    var(&io.ident),
                )
            })
            .collect();
        let places = lowered
            .places
            .iter()
            .map(|p| {
                let id = net
                    .place_ids()
                    .find(|&q| net.place_label(q) == p.label)
                    .unwrap_or_else(|| panic!("{what}: no place {}", p.label));
                (p.label.clone(), id, var(&p.ident))
            })
            .collect();
        let unstable = engine.lookup(&format!("{prefix}.{}", lowered.helpers.unstable));
        let mut vm = Machine::new(engine.clone());
        vm.set_backend(Backend::Vm);
        let slots = engine.code.init.len() as u32;
        Runner {
            what,
            machine: Machine::new(engine),
            vm,
            slots,
            inputs,
            outputs,
            places,
            unstable,
        }
    }
}

/// The name of a language and form in the figures.
pub fn label(language: Language, form: Form) -> String {
    let form = match form {
        Form::Plain => "text",
        Form::Project => "PLCopen XML",
    };
    format!("{} ({form})", language.name())
}

/// Runs `net` under `mode` in the simulator for 2 s of 10 ms scans on `timeline` (and the
/// built-in `plant`), and the program `compile` writes in each of `languages` on the engine in
/// step with it; panics at the first scan where an output or a marking differs. Languages
/// `compile` refuses for this net are counted as refused.
#[allow(clippy::too_many_arguments)]
pub fn compare(
    name: &str,
    net: &Net,
    timeline: Option<&Timeline>,
    plant: Option<&str>,
    mode: Mode,
    overflow: Overflow,
    languages: &[(Language, Form)],
    figures: &mut Figures,
) {
    let Mode {
        step,
        evolve,
        markings,
    } = mode;
    let mut options = Options::of(net);
    options.step = step;
    options.evolve = evolve;
    options.markings = markings;
    let lowered = Program::lower(net, &options).expect("lowers");
    let mut runners = Vec::new();
    for &(language, form) in languages {
        let key = label(language, form);
        let what = format!("{name} {step:?} {evolve:?} {markings:?} {key} overflow={overflow:?}");
        let generated = generate(
            net,
            &Request {
                language,
                form,
                options: options.clone(),
                created: "2026-01-01T00:00:00".into(),
            },
        );
        let text = match generated {
            Ok(g) => g.text,
            Err(_) if matches!(language, Language::Ld | Language::Sfc) => {
                *figures.refused.entry(key).or_default() += 1;
                continue;
            }
            Err(e) => panic!("{what}: not generated: {e}"),
        };
        let ext = match (language, form) {
            (_, Form::Project) => "xml",
            (Language::Il, _) => "il",
            _ => "st",
        };
        let mut sources = Sources::new();
        sources.overflow = overflow;
        sources.add_text(&format!("{name}.{ext}"), &text);
        let build = build(&sources, &Select::Auto, Natives::default()).unwrap_or_else(|e| {
            panic!("{what}: the engine refuses the generated code:\n{e}\n{text}")
        });
        runners.push((key, Runner::new(what, build.engine, &lowered, net)));
    }
    if runners.is_empty() {
        return;
    }

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
    'scans: loop {
        let t = sim.next_time();
        let r = sim.step().map(|row| row.is_some());
        if matches!(r, Ok(false)) {
            break;
        }
        scans += 1;
        for (_, run) in &mut runners {
            // The engine sees the inputs the scan saw.
            for (n, v) in &run.inputs {
                let value = n.map_or(0, |n| sim.signals()[n.index()]);
                run.machine.set(*v, &Value::Int(value as i128)).unwrap();
                run.vm.set(*v, &Value::Int(value as i128)).unwrap();
            }
            let iec = run.machine.scan(t.as_nanos() as i64, &mut || true);
            let iec_vm = run.vm.scan(t.as_nanos() as i64, &mut || true);
            let what = &run.what;
            assert_eq!(
                iec.as_ref().map_err(|f| f.to_string()),
                iec_vm.as_ref().map_err(|f| f.to_string()),
                "{what} at t={t:?}: machine code and VM end the scan differently"
            );
            if let Some(a) = (0..run.slots).find(|&a| run.machine.slot(a) != run.vm.slot(a)) {
                panic!(
                    "{what} at t={t:?}: machine code and VM differ at slot {a}: {} vs {}",
                    run.machine.slot(a),
                    run.vm.slot(a)
                );
            }
            match &r {
                Err(e) => {
                    // The simulator stops (unstable scan, token overflow): the engine reports it.
                    let flagged = run
                        .unstable
                        .is_some_and(|u| as_int(run.machine.get(u)) != 0);
                    assert!(
                        iec.is_err() || flagged,
                        "{what} at t={t:?}: sim failed ({e}) but the engine went on"
                    );
                }
                Ok(_) => {
                    if let Err(f) = iec {
                        panic!("{what} at t={t:?}: the engine failed ({f}) but sim went on");
                    }
                    for (n, id, v) in &run.outputs {
                        let want = id.map_or(0, |id| sim.signals()[id.index()]);
                        let got = as_int(run.machine.get(*v));
                        assert_eq!(got, want, "{what} at t={t:?}: output {n}");
                    }
                    for (label, id, v) in &run.places {
                        let want = sim.scanner().marking()[*id] as i64;
                        let got = as_int(run.machine.get(*v));
                        assert_eq!(got, want, "{what} at t={t:?}: marking of {label}");
                    }
                }
            }
        }
        if r.is_err() {
            break 'scans;
        }
    }
    for (key, _) in runners {
        let c = figures.compared.entry(key).or_default();
        c.0 += 1;
        c.1 += scans;
    }
}
