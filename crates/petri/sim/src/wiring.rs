//! The one wiring of a closed loop by name, for any controller (a net, an IEC program):
//! which timeline column and which plant output drive which controller input, what each plant
//! input reads, which inputs nothing drives, and the order the trace lists the driven inputs.

use crate::error::SimError;
use crate::plant::Plant;
use crate::timeline::Timeline;

/// A controller signal the wiring may connect.
#[derive(Clone, Debug)]
pub struct Port<S> {
    /// Its name as the controller spells it (what messages and the trace show).
    pub name: String,
    /// The controller's handle for it.
    pub signal: S,
    /// A BOOL signal: a timeline may give it 0 or 1 only.
    pub boolean: bool,
    /// What it holds when nothing drives it, as a warning shows it (`FALSE`, `0`, `5`).
    pub initial: String,
    /// The controller may set it itself (an IEC configuration's global variable): no warning
    /// when nothing else drives it.
    pub optional: bool,
}

/// The controller side of a closed loop, as the wiring sees it.
pub trait Controller {
    /// How the controller names one of its signals (a net's `SignalId`, a program's
    /// variable).
    type Signal: Copy + PartialEq;
    /// The signals a timeline column or a plant output may drive, in declaration order.
    fn inputs(&self) -> Vec<Port<Self::Signal>>;
    /// The signals a plant input may read, in declaration order. A signal may be both an
    /// input and an output (an IEC global variable).
    fn outputs(&self) -> Vec<Port<Self::Signal>>;
    /// Whether two names are the same signal's: exact for nets; IEC 61131-3 identifiers
    /// ignore case.
    fn same_name(&self, a: &str, b: &str) -> bool {
        a == b
    }
}

/// Where a plant input's value comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source<S> {
    /// A controller output, as the previous scan left it.
    Controller(S),
    /// A timeline column.
    Timeline(usize),
    /// Nothing: the input stays 0 unless forced (a warning says so).
    Unwired,
}

/// The checked wiring of a controller with its timeline and plant.
#[derive(Clone, Debug)]
pub struct Wiring<S> {
    /// Timeline column → the controller input it drives, in column order.
    pub timeline_inputs: Vec<(usize, Port<S>)>,
    /// Per plant input (in [`Plant::inputs`] order): where its value comes from.
    pub plant_sources: Vec<Source<S>>,
    /// Plant output index → the controller input it drives.
    pub drives: Vec<(usize, Port<S>)>,
    /// Plant outputs that drive nothing, kept for the plot.
    pub observed: Vec<usize>,
    /// Remarks that do not stop the run: inputs nothing drives.
    pub warnings: Vec<String>,
}

impl<S: Copy + PartialEq> Wiring<S> {
    /// The driven inputs in the order the trace lists them first: the timeline's columns,
    /// then what the plant drives, each once. The other inputs follow, as the controller
    /// declares them.
    pub fn first_inputs(&self) -> Vec<&Port<S>> {
        let mut first: Vec<&Port<S>> = Vec::new();
        for p in self
            .timeline_inputs
            .iter()
            .chain(&self.drives)
            .map(|(_, p)| p)
        {
            if !first.iter().any(|f| f.signal == p.signal) {
                first.push(p);
            }
        }
        first
    }

    /// Whether a timeline column or the plant drives `signal`.
    pub fn is_driven(&self, signal: S) -> bool {
        self.timeline_inputs
            .iter()
            .chain(&self.drives)
            .any(|(_, p)| p.signal == signal)
    }
}

/// Wires `timeline` and `plant` to `controller` by name and checks the wiring: every column
/// drives a controller input or a plant input, nothing is driven twice, a BOOL input gets 0
/// or 1 only.
pub fn wire<C: Controller>(
    controller: &C,
    timeline: Option<&Timeline>,
    plant: Option<&dyn Plant>,
) -> Result<Wiring<C::Signal>, SimError> {
    let inputs = controller.inputs();
    let outputs = controller.outputs();
    let same = |a: &str, b: &str| controller.same_name(a, b);
    let find =
        |ports: &[Port<C::Signal>], name: &str| ports.iter().find(|p| same(&p.name, name)).cloned();
    let input_of = |name: &str| find(&inputs, name);
    let output_of = |name: &str| find(&outputs, name);
    let plant_name = plant.map(|p| p.name().to_string());
    let plant_inputs = plant.map_or_else(Vec::new, |p| p.inputs());
    let plant_outputs = plant.map_or_else(Vec::new, |p| p.outputs());
    let plant_label = || format!("plant `{}`", plant_name.as_deref().unwrap_or(""));

    let mut timeline_inputs = Vec::new();
    if let Some(tl) = timeline {
        for (col, name) in tl.columns().iter().enumerate() {
            if let Some(port) = input_of(name) {
                if port.boolean {
                    if let Some(&(time, value)) =
                        tl.changes(col).iter().find(|c| c.1 != 0 && c.1 != 1)
                    {
                        return Err(SimError::NotBoolean {
                            column: name.clone(),
                            time,
                            value,
                        });
                    }
                }
                timeline_inputs.push((col, port));
            } else if plant_inputs.iter().any(|p| same(p, name)) {
                // Wired below, with the plant's other inputs.
            } else if output_of(name).is_some() {
                return Err(SimError::ColumnIsOutput {
                    timeline: tl.source().to_string(),
                    column: name.clone(),
                });
            } else {
                let known = inputs
                    .iter()
                    .map(|p| p.name.clone())
                    .chain(
                        plant_inputs
                            .iter()
                            .filter(|n| output_of(n).is_none())
                            .cloned(),
                    )
                    .collect();
                return Err(SimError::UnknownColumn {
                    timeline: tl.source().to_string(),
                    column: name.clone(),
                    plant: plant_name.clone(),
                    known,
                });
            }
        }
    }
    let column =
        |name: &str| timeline.and_then(|tl| tl.columns().iter().position(|c| same(c, name)));

    let mut warnings = Vec::new();
    let mut plant_sources = Vec::with_capacity(plant_inputs.len());
    let mut unwired = Vec::new();
    for name in &plant_inputs {
        plant_sources.push(match (output_of(name), column(name)) {
            (Some(p), None) => Source::Controller(p.signal),
            (None, Some(c)) => Source::Timeline(c),
            (Some(_), Some(_)) => {
                return Err(SimError::DrivenTwice {
                    signal: name.clone(),
                    first: "the controller".into(),
                    second: "the timeline".into(),
                })
            }
            (None, None) => {
                unwired.push(name.as_str());
                Source::Unwired
            }
        });
    }
    let mut drives = Vec::new();
    let mut observed = Vec::new();
    for (i, name) in plant_outputs.iter().enumerate() {
        // A name that is both (an IEC global) is an input here: the plant drives it.
        match (input_of(name), output_of(name)) {
            (Some(port), _) => {
                if column(name).is_some() {
                    return Err(SimError::DrivenTwice {
                        signal: name.clone(),
                        first: "the timeline".into(),
                        second: plant_label(),
                    });
                }
                drives.push((i, port));
            }
            (None, Some(_)) => {
                return Err(SimError::DrivenTwice {
                    signal: name.clone(),
                    first: "the controller".into(),
                    second: plant_label(),
                })
            }
            (None, None) => observed.push(i),
        }
    }
    let mut wiring = Wiring {
        timeline_inputs,
        plant_sources,
        drives,
        observed,
        warnings: Vec::new(),
    };
    for p in &inputs {
        if !p.optional && !wiring.is_driven(p.signal) {
            warnings.push(format!(
                "input {} is driven by neither the timeline nor the plant; it stays {}",
                p.name, p.initial
            ));
        }
    }
    if !unwired.is_empty() {
        warnings.push(format!(
            "{} reads {}, which neither the controller nor the timeline drives; they stay 0 (add timeline columns to drive them)",
            plant_label(),
            unwired.join(", ")
        ));
    }
    wiring.warnings = warnings;
    Ok(wiring)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plants::Tank;
    use petriplc_testnet::net;

    /// A controller that names its signals without regard to case, as an IEC program does:
    /// (name, is an input, is boolean).
    struct Program(&'static [(&'static str, bool, bool)]);

    impl Controller for Program {
        type Signal = usize;
        fn inputs(&self) -> Vec<Port<usize>> {
            self.ports(true)
        }
        fn outputs(&self) -> Vec<Port<usize>> {
            self.ports(false)
        }
        fn same_name(&self, a: &str, b: &str) -> bool {
            a.eq_ignore_ascii_case(b)
        }
    }

    impl Program {
        fn ports(&self, inputs: bool) -> Vec<Port<usize>> {
            (self.0.iter().enumerate())
                .filter(|(_, s)| s.1 == inputs)
                .map(|(i, s)| Port {
                    name: s.0.to_string(),
                    signal: i,
                    boolean: s.2,
                    initial: if s.2 { "FALSE" } else { "0" }.to_string(),
                    optional: false,
                })
                .collect()
        }
    }

    /// The wiring's warnings, one a line, or its error.
    fn check<C: Controller>(c: &C, timeline: Option<&str>, plant: bool, expect: &str) {
        let tl = timeline.map(|t| Timeline::parse(t, "tl.csv").unwrap());
        let tank = Tank::new();
        let plant = plant.then_some(&tank as &dyn Plant);
        let got = match wire(c, tl.as_ref(), plant) {
            Ok(w) => w.warnings.join("\n"),
            Err(e) => format!("error: {e}"),
        };
        assert_eq!(got, expect);
    }

    #[test]
    fn a_plant_output_the_controller_also_writes_is_driven_twice_for_any_controller() {
        let expect =
            "error: `N3` is driven by both the controller and plant `tank`; drop it from one of them";
        check(&net("p fill 1 >V1\np lamp 0 >N3"), None, true, expect);
        // Before one wiring, a program's copy wired the plant's N3 to nothing and let both
        // write it.
        check(
            &Program(&[("V1", false, true), ("n3", false, true)]),
            None,
            true,
            expect,
        );
    }

    #[test]
    fn a_timeline_gives_a_boolean_input_0_or_1_for_any_controller() {
        let expect = "error: timeline column `b1` sets boolean input `b1` to 2 at t=1s; write 0/1 or TRUE/FALSE, or declare the input as int";
        check(
            &net("p a 1\nt go a -> a if b1"),
            Some("time,b1\n0,1\n1,2\n"),
            false,
            expect,
        );
        check(
            &Program(&[("B1", true, true)]),
            Some("time,b1\n0,1\n1,2\n"),
            false,
            expect,
        );
        // An integer input takes any whole value.
        check(
            &Program(&[("B1", true, false)]),
            Some("time,b1\n0,1\n1,2\n"),
            false,
            "",
        );
    }

    #[test]
    fn warnings_are_worded_the_same_for_a_net_and_a_program() {
        let warnings = "input B2 is driven by neither the timeline nor the plant; it stays FALSE\n\
             plant `tank` reads V2, V3, which neither the controller nor the timeline drives; they stay 0 (add timeline columns to drive them)";
        check(
            &net("p fill 1 >V1\nt go fill -> fill if B1 & B2"),
            Some("time,B1\n0,1\n"),
            true,
            warnings,
        );
        check(
            &Program(&[("b1", true, true), ("B2", true, true), ("v1", false, true)]),
            Some("time,B1\n0,1\n"),
            true,
            warnings,
        );
    }

    #[test]
    fn names_match_as_the_controller_says() {
        // A net's names are exact: `b1` is not `B1`.
        check(
            &net("p a 1\nt go a -> a if B1"),
            Some("time,b1\n0,1\n"),
            false,
            "error: timeline tl.csv: column `b1` is not an input of the controller; known inputs: B1; check the spelling",
        );
        check(
            &Program(&[("B1", true, true)]),
            Some("time,b1\n0,1\n"),
            false,
            "",
        );
    }
}
