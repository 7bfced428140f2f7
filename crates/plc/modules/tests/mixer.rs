//! The mixer tank in closed loop as `petriplc run examples/mixer/plc.conf` runs it: the
//! controller net (`petrinet`, SIPN naming), the tank (`plant`, the README's tank net or the
//! Rust tank) and the start button (`timeline`, press-b1.csv), one scan each every 10 ms,
//! checked scan by scan against `petriplc sim` on the same net, plant and timeline.

mod harness;

use std::time::Duration;

use harness::{examples, ms, start, Plc};
use petriplc_net::{Net, ScanOptions};
use petriplc_pnml::{read_file, Naming, ReadOptions};
use petriplc_sim::{NetPlant, Plant, SimOptions, Simulation, Tank, Timeline};

const OUTPUTS: &[&str] = &["L1", "A1", "V1", "L2", "V2", "M1", "V3", "L3"];

fn config(plant: &str) -> String {
    let mut text = String::from(
        "[PLC]\n\
         module buttons timeline\n\
         module tank plant\n\
         module ctl petrinet\n\
         point B1 \"start button\" buttons\n\
         point N1 \"level <= 5 %\" tank\n\
         point N2 \"level >= 50 %\" tank\n\
         point N3 \"level >= 90 %\" tank\n",
    );
    for o in OUTPUTS {
        text.push_str(&format!("point {o} \"controller output\" ctl\n"));
    }
    text.push_str(&format!(
        "\n[buttons]\nfile = press-b1.csv\n\n[tank]\n{plant}\n\n[ctl]\nnet = mixer.pnml\nnames = sipn\n"
    ));
    text
}

fn net(file: &str, naming: Naming) -> Net {
    read_file(&examples("mixer").join(file), &ReadOptions { naming })
        .unwrap()
        .net
}

/// Runs the PLC and `Simulation` side by side for 60 s and returns the times at which L1
/// came back on (an N1 firing: a cycle completed) and A1 went on (a B1 firing).
fn run(plant_setting: &str, sim_plant: Box<dyn Plant + '_>, mixer: &Net) -> (Vec<f64>, Vec<f64>) {
    let dir = examples("mixer");
    let mut plc: Plc = start(&config(plant_setting), &dir).unwrap_or_else(|e| panic!("{e}"));
    let timeline = Timeline::read_file(dir.join("press-b1.csv")).unwrap();
    let until = Duration::from_secs(60);
    let mut sim = Simulation::new(
        mixer,
        SimOptions::new(mixer, ms(10), until),
        Some(timeline),
        Some(sim_plant),
    )
    .unwrap();
    let outputs: Vec<String> = mixer
        .outputs()
        .map(|s| mixer.signal(s).name.clone())
        .collect();
    // The trace's order (the timeline's columns, then what the plant drives, then the rest).
    let inputs: Vec<String> = sim.trace().inputs.clone();
    let (mut cycles, mut starts) = (Vec::new(), Vec::new());
    let mut last = Vec::new();
    for k in 0..=6000u64 {
        let now = ms(10 * k);
        plc.tick(now).unwrap_or_else(|e| panic!("{e}"));
        let row = sim.step().unwrap().expect("a scan within `until`").clone();
        assert_eq!(row.time, now);
        let got = plc_outputs(&plc, &outputs);
        assert_eq!(got, row.outputs, "outputs {outputs:?} at {now:?}");
        let got_in: Vec<i64> = inputs.iter().map(|i| plc.value(i)).collect();
        assert_eq!(got_in, row.inputs, "inputs {inputs:?} at {now:?}");
        // Before the first scan the points hold their init values, not the net's outputs.
        let rose = |name: &str| {
            let i = outputs.iter().position(|o| o == name).unwrap();
            k > 0 && last[i] == 0 && got[i] == 1
        };
        if rose("L1") {
            cycles.push(now.as_secs_f64());
        }
        if rose("A1") {
            starts.push(now.as_secs_f64());
        }
        last = got;
    }
    assert!(sim.step().unwrap().is_none());
    assert_eq!(plc.status("ctl"), "marking L1=1; fired B1:3 N2:3 N3:3 N1:3");
    (cycles, starts)
}

fn plc_outputs(plc: &Plc, outputs: &[String]) -> Vec<i64> {
    outputs.iter().map(|o| plc.value(o)).collect()
}

/// The README's closed loop: `petriplc sim examples/mixer/mixer.pnml --names sipn --plant
/// examples/mixer/tank.pnml --inputs examples/mixer/press-b1.csv` fires N1 at 8.96 s,
/// 17.71 s and 26.71 s; the press at 5 s comes mid-cycle and is ignored.
#[test]
fn mixer_with_the_tank_net_runs_three_cycles_like_sim() {
    let mixer = net("mixer.pnml", Naming::Sipn);
    let tank = net("tank.pnml", Naming::Plain);
    let plant = NetPlant::new(&tank, ScanOptions::of(&tank));
    let (cycles, starts) = run("net = tank.pnml", Box::new(plant), &mixer);
    assert_eq!(cycles, [8.96, 17.71, 26.71]);
    assert_eq!(starts, [1.0, 10.0, 19.0]);
}

/// The same loop with the continuous Rust tank: each level change comes one scan earlier.
#[test]
fn mixer_with_the_rust_tank_runs_three_cycles_like_sim() {
    let mixer = net("mixer.pnml", Naming::Sipn);
    let (cycles, starts) = run("plant = tank", Box::new(Tank::new()), &mixer);
    assert_eq!(cycles, [8.9, 17.65, 26.65]);
    assert_eq!(starts, [1.0, 10.0, 19.0]);
}
