//! The PLC-scan state space of a controller alone, its inputs free: states are markings, and
//! from each state every combination of the input values that matter (and every choice of
//! elapsed delays) gives one scan and one successor.
//!
//! States are numbered in breadth-first order from the initial marking (state 0), successors
//! tried in input-combination order, so the first state found with a property is one the
//! fewest scans reach, and results never depend on hash order.

use indexmap::IndexSet;
use petriplc_net::{Evolution, Marking, Net, ScanError};

use crate::domain::{Combos, Reduction};
use crate::plc::{Plc, Stepper};
use crate::witness::{ScanStep, Witness};
use crate::{ClosedLoopError, PlcOptions};

/// How a state was first reached: from state `from` with input combination `combo` and delay
/// choice `choice`.
#[derive(Clone, Copy, Debug)]
struct Edge {
    from: u32,
    combo: u32,
    choice: u32,
}

/// The explored PLC-scan state space of one controller.
#[derive(Debug)]
pub struct PlcSpace<'n> {
    pub(crate) plc: Plc<'n>,
    pub(crate) options: PlcOptions,
    pub(crate) combos: Combos,
    states: IndexSet<Box<[u32]>>,
    parent: Vec<Edge>,
    edges: u64,
    complete: bool,
    unstable_scans: u64,
    /// For one-pass nets without delays, where a scan is one pass and its successor is a
    /// function of (state, inputs): that function, for the stability check.
    pub(crate) table: Option<SuccTable>,
}

/// Successor of every (state, input combination), at `state * combos + combo`.
#[derive(Debug)]
pub(crate) struct SuccTable {
    /// The successor state, or [`SuccTable::NONE`] where it was not computed (search cut short).
    pub next: Vec<u32>,
    /// Whether the scan fired anything.
    pub fired: Vec<bool>,
}

impl SuccTable {
    pub const NONE: u32 = u32::MAX;
    /// The table is kept up to this many entries (4 bytes and a flag each).
    const MAX_ENTRIES: u64 = 1 << 26;
}

/// Explores the scan state space of `net` with its inputs free (see the module docs of
/// `domain.rs` for the input values tried and `plc.rs` for the time abstraction). Stops with
/// `complete() == false` at `options.max_states` or when `options.cancel` is set.
///
/// A scan that fails with `Unstable` (until-stable) has no successor; it is counted in
/// [`PlcSpace::unstable_scans`] and reported by [`sipn_checks`](crate::sipn_checks).
pub fn explore_controller<'n>(
    net: &'n Net,
    options: &PlcOptions,
) -> Result<PlcSpace<'n>, ClosedLoopError> {
    let plc = Plc::new(net, options.scan)?;
    let combos = Combos::new(net, Reduction::new(net).domains(net, &|_| None))?;
    let mut states: IndexSet<Box<[u32]>> = IndexSet::new();
    let mut parent = Vec::new();
    let mut m0 = net.initial_marking();
    plc.normalize(&mut m0);
    states.insert(m0.0.into_boxed_slice());
    parent.push(Edge {
        from: u32::MAX,
        combo: 0,
        choice: 0,
    });
    let (mut edges, mut complete, mut unstable_scans) = (0u64, true, 0u64);
    let functional = plc.timed.is_empty() && plc.options.evolve == Evolution::OnePass;
    let mut table = functional.then(|| SuccTable {
        next: Vec::new(),
        fired: Vec::new(),
    });
    {
        let mut stepper = Stepper::new(&plc);
        let mut signals = vec![0; net.signals().len()];
        let mut succ: Vec<usize> = Vec::new();
        let mut i = 0;
        'explore: while i < states.len() {
            if options.cancelled() {
                complete = false;
                break;
            }
            let m = Marking(states[i].to_vec());
            succ.clear();
            for c in 0..combos.count() {
                combos.write(c, &mut signals);
                let eligible = plc.eligible(&m, &signals)?;
                for choice in 0..1u32 << eligible.len() {
                    let out = match stepper.scan(&m, &signals, &eligible, choice) {
                        Ok(o) => o,
                        Err(ScanError::Unstable { .. }) => {
                            unstable_scans += 1;
                            continue;
                        }
                        Err(source) => {
                            return Err(ClosedLoopError::Scan {
                                net: net.id.clone(),
                                source,
                            })
                        }
                    };
                    let fired = !out.fired.is_empty();
                    let (j, new) = states.insert_full(out.marking.0.into_boxed_slice());
                    if new {
                        if states.len() as u64 > options.max_states {
                            states.pop();
                            complete = false;
                            break 'explore;
                        }
                        parent.push(Edge {
                            from: i as u32,
                            combo: c as u32,
                            choice,
                        });
                    }
                    succ.push(j);
                    if let Some(t) = &mut table {
                        t.next.push(j as u32);
                        t.fired.push(fired);
                    }
                }
            }
            succ.sort_unstable();
            succ.dedup();
            edges += succ.len() as u64;
            i += 1;
            if table
                .as_ref()
                .is_some_and(|t| t.next.len() as u64 > SuccTable::MAX_ENTRIES)
            {
                table = None;
            }
        }
    }
    if let Some(t) = &mut table {
        // Rows of states never expanded (search cut short) stay unknown.
        let size = states.len() * combos.count() as usize;
        t.next.resize(size, SuccTable::NONE);
        t.fired.resize(size, false);
    }
    Ok(PlcSpace {
        plc,
        options: options.clone(),
        combos,
        states,
        parent,
        edges,
        complete,
        unstable_scans,
        table,
    })
}

impl<'n> PlcSpace<'n> {
    pub fn net(&self) -> &'n Net {
        self.plc.net
    }
    /// Markings reached (input places counted as 0).
    pub fn states(&self) -> u64 {
        self.states.len() as u64
    }
    /// Distinct (state, successor) pairs, self-loops included, over the states expanded.
    pub fn edges(&self) -> u64 {
        self.edges
    }
    /// False when `max_states` or the cancel flag stopped the exploration.
    pub fn complete(&self) -> bool {
        self.complete
    }
    /// The input combinations tried from every state.
    pub fn input_combinations(&self) -> u64 {
        self.combos.count()
    }
    /// Scans that failed with `Unstable` (until-stable only).
    pub fn unstable_scans(&self) -> u64 {
        self.unstable_scans
    }
    /// The marking of state `i` (0 is the initial marking).
    pub fn marking(&self, i: usize) -> Marking {
        Marking(self.states[i].to_vec())
    }

    /// The shortest run (in scans) from the initial marking to state `i`; `about` goes into
    /// the timeline's leading comments.
    pub fn witness(&self, i: usize, about: &[String]) -> Result<Witness, ClosedLoopError> {
        let mut path = Vec::new();
        let mut j = i;
        while j != 0 {
            path.push(self.parent[j]);
            j = self.parent[j].from as usize;
        }
        path.reverse();
        let net = self.plc.net;
        let mut stepper = Stepper::new(&self.plc);
        let mut signals = vec![0; net.signals().len()];
        let mut steps = Vec::with_capacity(path.len());
        for e in path {
            let m = self.marking(e.from as usize);
            self.combos.write(u64::from(e.combo), &mut signals);
            let eligible = self.plc.eligible(&m, &signals)?;
            let out = stepper
                .scan(&m, &signals, &eligible, e.choice)
                .map_err(|source| ClosedLoopError::Scan {
                    net: net.id.clone(),
                    source,
                })?;
            steps.push(ScanStep {
                inputs: net.inputs().map(|s| signals[s.index()]).collect(),
                elapsed: out.elapsed,
                fired: out.fired,
                marking: out.marking,
            });
        }
        Ok(Witness::new(&self.plc, self.options.period, steps, about))
    }
}

#[cfg(test)]
mod tests {
    //! State and edge counts on small nets, limits, cancellation and witnesses.

    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;

    use super::*;
    use petriplc_testnet::net;

    /// `states/edges/complete` and the input rows of the witness to the last state.
    fn check(text: &str, opts: impl Fn(&mut PlcOptions), expect: &str) {
        let n = net(text);
        let mut o = PlcOptions::of(&n);
        opts(&mut o);
        let space = explore_controller(&n, &o).unwrap();
        let last = space.states() as usize - 1;
        let w = space.witness(last, &[]).unwrap();
        let rows: Vec<String> = w.steps.iter().map(|s| format!("{:?}", s.inputs)).collect();
        let got = format!(
            "{}/{}/{} last via {}",
            space.states(),
            space.edges(),
            space.complete(),
            rows.join("")
        );
        assert_eq!(got, expect);
    }

    #[test]
    fn a_chain_under_one_pass_and_until_stable() {
        let chain = "s A in bool\np p1 1\np p2 0\np p3 0\nt t1 p1 -> p2 if A\nt t2 p2 -> p3 if A";
        check(chain, |_| {}, "3/5/true last via [1][1]");
        check(
            &format!("evolve until-stable\n{chain}"),
            |_| {},
            "2/3/true last via [1]",
        );
    }

    #[test]
    fn limits_and_cancellation_end_the_exploration_incomplete() {
        let counter = "s A in bool\np n 0\nt more -> n if A";
        check(
            counter,
            |o| o.max_states = 4,
            "4/6/false last via [1][1][1]",
        );
        let stop = Arc::new(AtomicBool::new(true));
        check(
            counter,
            |o| o.cancel = Some(stop.clone()),
            "1/0/false last via ",
        );
    }

    #[test]
    fn integer_inputs_through_an_input_place() {
        // Level L (int) in an input place of capacity 10; `fill` needs L >= 3 (read arc of
        // weight 3), `full` needs L > 8 (guard).
        check(
            "s L in int\np l 0 <L cap=10\np a 1\np b 0\np c 0\nt fill a ?l*3 -> b\nt full b -> c if L > 8",
            |_| {},
            "3/5/true last via [3][9]",
        );
    }
}
