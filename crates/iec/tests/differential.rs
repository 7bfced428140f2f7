//! The ST that `petriplc compile --lang st` writes runs on the engine exactly as
//! `petriplc sim` runs the net: for every example net, every step rule, evolution and marking
//! representation, 2 s of 10 ms scans on the example's timeline, outputs and markings
//! compared scan by scan.

use std::path::Path;
use std::time::Duration;

use petriplc_codegen::{generate, Form, Language, Markings, Options, Program, Request};
use petriplc_iec::{build_text, Select};
use petriplc_iec_sema::value::Value;
use petriplc_iec_vm::{Backend, Machine};
use petriplc_net::{Evolution, Net, ScanOptions, StepRule};
use petriplc_pnml::{Naming, ReadOptions};
use petriplc_sim::{SimOptions, Simulation, Timeline};

const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples");

/// (name, net, SIPN naming, timeline, built-in plant), as the examples' READMEs run them.
type Example = (
    &'static str,
    &'static str,
    bool,
    Option<&'static str>,
    Option<&'static str>,
);

const NETS: &[Example] = &[
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

const RULES: [(StepRule, Evolution); 4] = [
    (StepRule::MaximalStep, Evolution::OnePass),
    (StepRule::MaximalStep, Evolution::UntilStable),
    (StepRule::Sequential, Evolution::OnePass),
    (StepRule::Sequential, Evolution::UntilStable),
];

fn read(path: &str, sipn: bool) -> Net {
    let options = ReadOptions {
        naming: if sipn { Naming::Sipn } else { Naming::Plain },
    };
    petriplc_pnml::read_file(Path::new(&format!("{EXAMPLES}/{path}")), &options)
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .net
}

fn as_int(v: Option<Value>) -> i64 {
    match v {
        Some(Value::Int(i)) => i as i64,
        other => panic!("not an integer: {other:?}"),
    }
}

/// Runs one net under one rule; returns the number of scans compared.
fn compare(
    name: &str,
    net: &Net,
    timeline: Option<&Timeline>,
    plant: Option<&str>,
    step: StepRule,
    evolve: Evolution,
    markings: Markings,
) -> u64 {
    let mut options = Options::of(net);
    options.step = step;
    options.evolve = evolve;
    options.markings = markings;
    let lowered = Program::lower(net, &options).expect("lowers");
    let st = generate(
        net,
        &Request {
            language: Language::St,
            form: Form::Plain,
            options: options.clone(),
            created: "2026-01-01T00:00:00".into(),
        },
    )
    .expect("ST is generated")
    .text;
    let what = format!("{name} {step:?} {evolve:?} {markings:?}");
    let build = build_text(&format!("{name}.st"), &st, &Select::Auto)
        .unwrap_or_else(|e| panic!("{what}: the engine refuses the generated ST:\n{e}\n{st}"));
    let engine = build.engine.clone();
    assert!(engine.is_compiled(), "{what}: no machine code for the ST");
    let mut m = Machine::new(engine.clone());
    // The bytecode VM runs the same program in step with the machine code: same memory
    // after every scan, same faults.
    let mut mv = Machine::new(engine.clone());
    mv.set_backend(Backend::Vm);
    let slots = engine.code.init.len() as u32;
    // The PLCopen XML project `petriplc compile --lang st` writes (the POU, and a
    // configuration whose task runs it every 10 ms) runs in step with the bare ST.
    let xml = generate(
        net,
        &Request {
            language: Language::St,
            form: Form::Project,
            options: options.clone(),
            created: "2026-01-01T00:00:00".into(),
        },
    )
    .expect("the project is generated")
    .text;
    let xml_build = build_text(&format!("{name}.xml"), &xml, &Select::Auto)
        .unwrap_or_else(|e| panic!("{what}: the engine refuses the generated PLCopen XML:\n{e}"));
    let xml_engine = xml_build.engine.clone();
    assert!(
        xml_engine.project.configuration.is_some(),
        "{what}: the project has its configuration"
    );
    let mut mx = Machine::new(xml_engine.clone());
    let inst = xml_engine.instances()[0].name.clone();
    let xml_var = |ident: &str| {
        xml_engine
            .lookup(&format!("{inst}.{ident}"))
            .unwrap_or_else(|| panic!("{what}: no variable {ident} in the XML project"))
    };
    let pou = &lowered.pou;
    let var = |ident: &str| {
        engine
            .lookup(&format!("{pou}.{ident}"))
            .unwrap_or_else(|| panic!("{what}: no variable {ident}"))
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
    let places: Vec<_> = lowered
        .places
        .iter()
        .map(|p| (p.label.clone(), var(&p.ident)))
        .collect();
    let unstable = engine.lookup(&format!("{pou}.{}", lowered.helpers.unstable));
    let xml_inputs: Vec<_> = lowered.inputs.iter().map(|io| xml_var(&io.ident)).collect();
    let xml_watch: Vec<_> = lowered
        .outputs
        .iter()
        .map(|io| io.ident.clone())
        .chain(lowered.places.iter().map(|p| p.ident.clone()))
        .map(|i| (var(&i), xml_var(&i)))
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
        // The engine sees the inputs the scan saw.
        if r == Ok(false) {
            break;
        }
        for ((n, v), xv) in inputs.iter().zip(&xml_inputs) {
            let value = sim.signal(n).unwrap_or(0);
            m.set(*v, &Value::Int(value as i128)).unwrap();
            mv.set(*v, &Value::Int(value as i128)).unwrap();
            mx.set(*xv, &Value::Int(value as i128)).unwrap();
        }
        let iec = m.scan(t.as_nanos() as i64, &mut || true);
        let iec_xml = mx.scan(t.as_nanos() as i64, &mut || true);
        let iec_vm = mv.scan(t.as_nanos() as i64, &mut || true);
        assert_eq!(
            iec.as_ref().map_err(|f| f.to_string()),
            iec_vm.as_ref().map_err(|f| f.to_string()),
            "{what} at t={t:?}: machine code and VM end the scan differently"
        );
        if let Some(a) = (0..slots).find(|&a| m.slot(a) != mv.slot(a)) {
            panic!(
                "{what} at t={t:?}: machine code and VM differ at slot {a}: {} vs {}",
                m.slot(a),
                mv.slot(a)
            );
        }
        assert_eq!(
            iec.is_ok(),
            iec_xml.is_ok(),
            "{what} at t={t:?}: the XML project and the ST differ"
        );
        for (a, b) in &xml_watch {
            assert_eq!(
                m.get(*a),
                mx.get(*b),
                "{what} at t={t:?}: the XML project and the ST differ"
            );
        }
        scans += 1;
        match r {
            Err(e) => {
                // The simulator stops (unstable scan, token overflow): the engine reports it.
                let flagged = unstable.is_some_and(|u| as_int(m.get(u)) != 0);
                assert!(
                    iec.is_err() || flagged,
                    "{what} at t={t:?}: sim failed ({e}) but the engine went on"
                );
                return scans;
            }
            Ok(_) => {
                if let Err(f) = iec {
                    panic!("{what} at t={t:?}: the engine failed ({f}) but sim went on");
                }
                for (n, v) in &outputs {
                    let want = sim.signal(n).unwrap_or(0);
                    let got = as_int(m.get(*v));
                    assert_eq!(got, want, "{what} at t={t:?}: output {n}");
                }
                for (label, v) in &places {
                    let want = sim.tokens(label).unwrap_or(0) as i64;
                    let got = as_int(m.get(*v));
                    assert_eq!(got, want, "{what} at t={t:?}: marking of {label}");
                }
            }
        }
    }
    scans
}

#[test]
fn generated_st_runs_as_the_net_simulates() {
    let mut total = 0;
    let mut runs = 0;
    for &(name, path, sipn, timeline, plant) in NETS {
        let net = read(path, sipn);
        let timeline =
            timeline.map(|t| Timeline::read_file(Path::new(&format!("{EXAMPLES}/{t}"))).unwrap());
        for (step, evolve) in RULES {
            for markings in [Markings::Auto, Markings::Int] {
                total += compare(name, &net, timeline.as_ref(), plant, step, evolve, markings);
                runs += 1;
            }
        }
    }
    eprintln!("differential: {runs} runs, {total} scans compared");
    assert!(total > 0);
}
