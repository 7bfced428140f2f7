//! examples/oven/plc.conf scan by scan in-process (without its logger, vitrine and HMI):
//! the recipe net goes through heat-up, hold and cool-down, the PID brings the vessel to its
//! setpoint and holds it there, and the alarms say so.

mod harness;

use std::time::Duration;

use harness::{examples, start};
use petriplc_config::PointValue;

fn f(plc: &harness::Plc, point: &str) -> f64 {
    match plc.get(point) {
        PointValue::Float(v) => f64::from(v),
        PointValue::Unsigned(v) => f64::from(v),
        PointValue::Signed(v) => f64::from(v),
    }
}

#[test]
fn the_oven_heats_holds_and_cools_down() {
    let dir = examples("oven");
    let text = std::fs::read_to_string(dir.join("plc.conf")).unwrap();
    // The displays and the logger are other tests' business: drop their modules and their
    // sections (the last of the file).
    let text: String = text[..text.find("[log]").unwrap()]
        .lines()
        .filter(|l| {
            !["module log ", "module vitrine ", "module hmi "]
                .iter()
                .any(|m| l.starts_with(m))
        })
        .map(|l| format!("{l}\n"))
        .collect();
    let mut plc = start(&text, &dir).unwrap_or_else(|e| panic!("{e}"));
    let mut phases = Vec::new();
    let mut at_temp = None;
    let mut hold_temps = Vec::new();
    for k in 0..250u64 {
        plc.tick(Duration::from_millis(100 * k)).unwrap();
        let phase = ["Ready", "HeatUp", "Hold", "Cool"]
            .into_iter()
            .find(|p| f(&plc, p) != 0.0)
            .unwrap_or("none");
        if phases.last() != Some(&phase) {
            phases.push(phase);
        }
        if at_temp.is_none() && f(&plc, "AtTemp") != 0.0 {
            at_temp = Some(k);
        }
        if phase == "Hold" {
            hold_temps.push(f(&plc, "temp"));
        }
        assert_eq!(f(&plc, "OverTemp"), 0.0, "over temperature at scan {k}");
        let heater = f(&plc, "heater");
        assert!((0.0..=100.0).contains(&heater), "heater {heater}");
    }
    assert_eq!(phases, ["Ready", "HeatUp", "Hold", "Cool", "Ready"]);
    // At temperature about 7 s after the start at 1 s, held within 2 °C for 5 s, and the
    // vessel cold again by the end.
    let at = at_temp.unwrap();
    assert!((60..120).contains(&at), "at temperature at scan {at}");
    assert!(hold_temps.len() >= 49, "{}", hold_temps.len());
    assert!(
        hold_temps.iter().all(|t| (t - 180.0).abs() <= 2.0),
        "{hold_temps:?}"
    );
    assert!(f(&plc, "temp") < 50.0 && f(&plc, "Cold") == 1.0);
    let status = plc.status("ctl");
    assert!(
        status.contains("filter butterworth lowpass: order 3")
            && status.contains("section 2: b = "),
        "{status}"
    );
}
