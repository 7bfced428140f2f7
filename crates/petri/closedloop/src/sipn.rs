//! Frey's SIPN checks on the PLC-scan state space, each finding with a witness timeline:
//!
//! - **not safe under PLC semantics**: a reachable marking with more than one token in a place
//!   (input places excepted: they hold their signal's value);
//! - **unstable input combinations**: a reachable marking and a constant input vector under
//!   which passes never stop firing — what makes an `until-stable` scan fail with `Unstable`
//!   (X1). Checked for every net: for a `one-pass` net it means the outputs keep changing,
//!   scan after scan, while the inputs do not;
//! - **contradictory outputs** cannot happen in petriplc's model: a boolean output is the OR
//!   of its places and an integer output has exactly one place (S6, checked by `NetBuilder`),
//!   so no two places can ask one output for different values. What remains is the user's
//!   knowledge that two outputs must not be on together (`V1` and `V3` of the mixer): pass
//!   them as `exclusive` pairs and the check reports a reachable marking that sets both.

use std::collections::HashSet;

use petriplc_net::{Marking, PlaceId, SignalDirection, SignalId, TransitionId};

use crate::plc::{write_outputs, Settle, Stepper};
use crate::space::{PlcSpace, SuccTable};
use crate::witness::{names, values, Witness};
use crate::ClosedLoopError;

/// At most this many unstable input combinations are reported with witnesses (all are
/// counted in [`SipnReport::unstable_total`]).
pub const MAX_UNSTABLE_REPORTED: usize = 20;

/// What the SIPN checks found.
#[derive(Clone, Debug)]
pub struct SipnReport {
    pub states: u64,
    /// False when the state space was cut short: findings stand, absences are not proved.
    pub complete: bool,
    /// Places that can hold more than one token, in place order, each with the first such
    /// state found.
    pub unsafe_places: Vec<Unsafe>,
    /// Distinct cycles, each with the first state and inputs found to enter it (states in BFS
    /// order, inputs in combination order); the first [`MAX_UNSTABLE_REPORTED`].
    pub unstable: Vec<Unstable>,
    pub unstable_total: u64,
    /// Exclusive output pairs found on together, in the order given.
    pub conflicting_outputs: Vec<ConflictingOutputs>,
}

impl SipnReport {
    /// Safe and stable, and no exclusive outputs on together.
    pub fn ok(&self) -> bool {
        self.unsafe_places.is_empty()
            && self.unstable_total == 0
            && self.conflicting_outputs.is_empty()
    }
}

/// A place above one token.
#[derive(Clone, Debug)]
pub struct Unsafe {
    pub place: PlaceId,
    pub tokens: u32,
    /// The scans that reach it.
    pub witness: Witness,
}

/// A marking and constant inputs under which passes never settle.
#[derive(Clone, Debug)]
pub struct Unstable {
    /// The reachable marking the scan starts from (input places shown as 0).
    pub marking: Marking,
    /// Every input of the net with its value.
    pub inputs: Vec<(SignalId, i64)>,
    /// Delayed transitions assumed elapsed at the scan start.
    pub elapsed: Vec<TransitionId>,
    /// The transitions that keep firing (in priority order): the repeating part of the passes,
    /// or, when no marking repeats within `max_passes`, those of the second half.
    pub cycle: Vec<TransitionId>,
    /// True when a marking repeats (a true cycle); false when tokens keep growing.
    pub periodic: bool,
    /// The scans that reach `marking`; then holding `inputs` makes `until-stable` fail.
    pub witness: Witness,
}

/// Two outputs declared exclusive that a reachable marking sets together.
#[derive(Clone, Debug)]
pub struct ConflictingOutputs {
    pub outputs: (SignalId, SignalId),
    pub witness: Witness,
}

/// Runs the SIPN checks on an explored space; `exclusive` lists output pairs that must never
/// be on (non-zero) together.
pub fn sipn_checks(
    space: &PlcSpace<'_>,
    exclusive: &[(SignalId, SignalId)],
) -> Result<SipnReport, ClosedLoopError> {
    let net = space.net();
    let plc = &space.plc;
    for &(a, b) in exclusive {
        for s in [a, b] {
            let is_output = net
                .signals()
                .get(s.index())
                .is_some_and(|sig| sig.direction == SignalDirection::Output);
            if !is_output {
                return Err(ClosedLoopError::NotAnOutput {
                    net: net.id.clone(),
                    signal: net
                        .signals()
                        .get(s.index())
                        .map_or_else(|| format!("#{}", s.index()), |sig| sig.name.clone()),
                });
            }
        }
    }
    let n = space.states() as usize;

    // Safeness and exclusive outputs: the first state in BFS order is a shortest witness.
    let mut unsafe_places = Vec::new();
    let mut first_unsafe: Vec<Option<(usize, u32)>> = vec![None; net.places().len()];
    let mut first_conflict: Vec<Option<usize>> = vec![None; exclusive.len()];
    let mut outputs = vec![0; net.signals().len()];
    for i in 0..n {
        let m = space.marking(i);
        for p in net.place_ids() {
            if m[p] > 1 && first_unsafe[p.index()].is_none() && !plc.is_input_place(p) {
                first_unsafe[p.index()] = Some((i, m[p]));
            }
        }
        if !exclusive.is_empty() {
            write_outputs(net, &m, &mut outputs);
            for (k, &(a, b)) in exclusive.iter().enumerate() {
                if first_conflict[k].is_none() && outputs[a.index()] != 0 && outputs[b.index()] != 0
                {
                    first_conflict[k] = Some(i);
                }
            }
        }
    }
    for p in net.place_ids() {
        if let Some((i, tokens)) = first_unsafe[p.index()] {
            let about = [format!(
                "a run of `{}` under PLC-scan semantics after which place {} holds {tokens} tokens (not safe)",
                net.id,
                net.place_label(p)
            )];
            unsafe_places.push(Unsafe {
                place: p,
                tokens,
                witness: space.witness(i, &about)?,
            });
        }
    }
    let mut conflicting_outputs = Vec::new();
    for (k, &(a, b)) in exclusive.iter().enumerate() {
        if let Some(i) = first_conflict[k] {
            let about = [format!(
                "a run of `{}` after which outputs {} and {} are both on",
                net.id,
                net.signal(a).name,
                net.signal(b).name
            )];
            conflicting_outputs.push(ConflictingOutputs {
                outputs: (a, b),
                witness: space.witness(i, &about)?,
            });
        }
    }

    // Stability: passes under constant inputs from every state, every input combination and
    // every delay choice, as an until-stable scan would make them.
    let mut acc = Cycles {
        complete: space.complete(),
        ..Cycles::default()
    };
    // The successor table only helps when it is whole: a cut-short space leaves paths ending
    // in states never expanded, where only the passes themselves tell what happens.
    match &space.table {
        Some(table) if space.complete() => by_table(space, table, &mut acc)?,
        _ => by_passes(space, &mut acc)?,
    }
    let Cycles {
        found,
        total,
        complete,
        ..
    } = acc;
    let mut signals = vec![0; net.signals().len()];
    let mut unstable = Vec::with_capacity(found.len());
    for Finding {
        state: i,
        combo: c,
        choice,
        cycle,
        periodic,
    } in found
    {
        let m = space.marking(i);
        space.combos.write(c, &mut signals);
        let eligible = plc.eligible(&m, &signals)?;
        let inputs: Vec<(SignalId, i64)> = net.inputs().map(|s| (s, signals[s.index()])).collect();
        let elapsed: Vec<TransitionId> = eligible
            .iter()
            .enumerate()
            .filter(|(b, _)| choice >> b & 1 == 1)
            .map(|(_, &k)| plc.timed[k].t)
            .collect();
        let about = [
            format!(
                "a run of `{}` to a marking from which inputs {} held constant make the passes cycle ({})",
                net.id,
                values(net, &inputs),
                names(net, &cycle)
            ),
            "from there, a scan with --evolve until-stable fails: the net is unstable".into(),
        ];
        unstable.push(Unstable {
            marking: m,
            inputs,
            elapsed,
            cycle,
            periodic,
            witness: space.witness(i, &about)?,
        });
    }
    Ok(SipnReport {
        states: space.states(),
        complete,
        unsafe_places,
        unstable,
        unstable_total: total,
        conflicting_outputs,
    })
}

/// An unstable (state, inputs, delay choice) and what keeps firing.
struct Finding {
    state: usize,
    combo: u64,
    choice: u32,
    cycle: Vec<TransitionId>,
    periodic: bool,
}

/// Cycles found so far. A cycle is known by its least marking and its transitions: the same
/// cycle entered from many states, or under inputs it does not read, is counted once, with
/// the first state (BFS order) and inputs (combination order) found to enter it.
#[derive(Default)]
struct Cycles {
    seen: HashSet<(Marking, Vec<TransitionId>)>,
    found: Vec<Finding>,
    total: u64,
    complete: bool,
}

impl Cycles {
    fn add(&mut self, key: (Marking, Vec<TransitionId>), f: Finding) {
        if self.seen.insert(key) {
            self.total += 1;
            if self.found.len() < MAX_UNSTABLE_REPORTED {
                self.found.push(f);
            }
        }
    }
}

fn scan_error(net: &petriplc_net::Net, source: petriplc_net::ScanError) -> ClosedLoopError {
    ClosedLoopError::Scan {
        net: net.id.clone(),
        source,
    }
}

/// The general check: the passes themselves, from every state, inputs and delay choice.
fn by_passes(space: &PlcSpace<'_>, acc: &mut Cycles) -> Result<(), ClosedLoopError> {
    let (net, plc) = (space.net(), &space.plc);
    let mut stepper = Stepper::new(plc);
    let mut signals = vec![0; net.signals().len()];
    for i in 0..space.states() as usize {
        if space.options.cancelled() {
            acc.complete = false;
            return Ok(());
        }
        let m = space.marking(i);
        for c in 0..space.combos.count() {
            space.combos.write(c, &mut signals);
            let eligible = plc.eligible(&m, &signals)?;
            for choice in 0..1u32 << eligible.len() {
                let limit = plc.options.max_passes.max(1);
                let settle = stepper
                    .settle(&m, &signals, &eligible, choice, limit)
                    .map_err(|e| scan_error(net, e))?;
                let (key, cycle, periodic) = match settle {
                    Settle::Stable => continue,
                    Settle::Cycle { cycle, markings } => {
                        let least = markings.into_iter().min().unwrap_or_default();
                        ((least, cycle.clone()), cycle, true)
                    }
                    // Growth has no least marking; the transitions name it.
                    Settle::Endless { firing } => {
                        ((Marking::default(), firing.clone()), firing, false)
                    }
                };
                let f = Finding {
                    state: i,
                    combo: c,
                    choice,
                    cycle,
                    periodic,
                };
                acc.add(key, f);
            }
        }
    }
    Ok(())
}

/// One-pass nets without delays: a pass is a scan, so the passes under constant inputs follow
/// the explored successor function of each input combination. Every path of a function on a
/// finite set ends in a cycle: a state that fires nothing (stable) or a cycle that fires.
fn by_table(
    space: &PlcSpace<'_>,
    table: &SuccTable,
    acc: &mut Cycles,
) -> Result<(), ClosedLoopError> {
    const UNSET: u32 = u32::MAX;
    const BUSY: u32 = u32::MAX - 1;
    const STABLE: u32 = u32::MAX - 2;
    const UNKNOWN: u32 = u32::MAX - 3;
    let (net, plc) = (space.net(), &space.plc);
    let n = space.states() as usize;
    let nc = space.combos.count() as usize;
    // Per (state, combo): where its passes end — a cycle id (index into `cycles`) or a mark.
    let mut outcome = vec![UNSET; n * nc];
    let mut cycles: Vec<Vec<usize>> = Vec::new();
    let mut keys: Vec<Option<(Marking, Vec<TransitionId>)>> = Vec::new();
    let mut stepper = Stepper::new(plc);
    let mut signals = vec![0; net.signals().len()];
    let mut path = Vec::new();
    for i in 0..n {
        if space.options.cancelled() {
            acc.complete = false;
            return Ok(());
        }
        for c in 0..nc {
            if outcome[i * nc + c] == UNSET {
                path.clear();
                let mut j = i;
                let result = loop {
                    match outcome[j * nc + c] {
                        BUSY => {
                            let from = path.iter().position(|&x| x == j).unwrap_or(0);
                            cycles.push(path[from..].to_vec());
                            keys.push(None);
                            break (cycles.len() - 1) as u32;
                        }
                        UNSET => {}
                        done => break done,
                    }
                    outcome[j * nc + c] = BUSY;
                    path.push(j);
                    let next = table.next[j * nc + c];
                    if next == SuccTable::NONE {
                        break UNKNOWN;
                    }
                    if next as usize == j && !table.fired[j * nc + c] {
                        break STABLE;
                    }
                    j = next as usize;
                };
                for &x in &path {
                    outcome[x * nc + c] = result;
                }
            }
            let k = outcome[i * nc + c] as usize;
            // Only the first (state, combo) entering a cycle can be news.
            if k >= cycles.len() || keys[k].is_some() {
                continue;
            }
            {
                space.combos.write(c as u64, &mut signals);
                let mut fired = Vec::new();
                for &x in &cycles[k] {
                    let out = stepper
                        .scan(&space.marking(x), &signals, &[], 0)
                        .map_err(|e| scan_error(net, e))?;
                    fired.extend(out.fired);
                }
                fired.sort();
                fired.dedup();
                let least = cycles[k].iter().map(|&x| space.marking(x)).min();
                keys[k] = Some((least.unwrap_or_default(), fired));
            }
            let key = keys[k].clone().unwrap_or_default();
            let f = Finding {
                state: i,
                combo: c as u64,
                choice: 0,
                cycle: key.1.clone(),
                periodic: true,
            };
            acc.add(key, f);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    //! Each check on a small net that fails it, and its witness against the real scanner.

    use std::time::Duration;

    use petriplc_net::{Evolution, ScanError, ScanOptions, Scanner};

    use super::*;
    use crate::{explore_controller, PlcOptions};
    use petriplc_testnet::net;

    /// The report in one line per finding: `unsafe P=n after [inputs per scan]`,
    /// `unstable {inputs} from {marked places}: cycle`, `conflict A B after [..]`.
    fn check(text: &str, exclusive: &[(&str, &str)], expect: &[&str]) {
        let n = net(text);
        let space = explore_controller(&n, &PlcOptions::of(&n)).unwrap();
        let ex: Vec<(SignalId, SignalId)> = exclusive
            .iter()
            .map(|(a, b)| (n.signal_by_name(a).unwrap(), n.signal_by_name(b).unwrap()))
            .collect();
        let r = sipn_checks(&space, &ex).unwrap();
        let runs = |w: &Witness| {
            w.steps
                .iter()
                .map(|s| format!("{:?}", s.inputs))
                .collect::<Vec<_>>()
                .join("")
        };
        let mut got = Vec::new();
        for u in &r.unsafe_places {
            got.push(format!(
                "unsafe {}={} after {}",
                n.place_label(u.place),
                u.tokens,
                runs(&u.witness)
            ));
        }
        for u in &r.unstable {
            let marked: Vec<String> = n
                .place_ids()
                .filter(|&p| u.marking[p] > 0)
                .map(|p| n.place_label(p).to_string())
                .collect();
            got.push(format!(
                "unstable {} from {}: {}{}",
                values(&n, &u.inputs),
                marked.join(" "),
                names(&n, &u.cycle),
                if u.periodic { "" } else { " (growing)" }
            ));
        }
        for c in &r.conflicting_outputs {
            got.push(format!(
                "conflict {} {} after {}",
                n.signal(c.outputs.0).name,
                n.signal(c.outputs.1).name,
                runs(&c.witness)
            ));
        }
        assert_eq!(got, expect);
    }

    #[test]
    fn a_net_safe_under_interleaving_may_not_be_under_scans() {
        // `go` puts a second token in q when A is on; `take` empties q one token per scan.
        check(
            "s A in bool\np p 1\np q 0 cap=2\nt go ?p -> q if A\nt take q -> if NOT A",
            &[],
            &["unsafe q=2 after [1][1]"],
        );
    }

    /// The unsafe witness, as a timeline, drives the simulator to the same markings.
    #[test]
    fn the_unsafe_witness_replays_in_the_simulator() {
        let n = net("s A in bool\np p 1\np q 0 cap=2\nt go ?p -> q if A\nt take q -> if NOT A");
        let space = explore_controller(&n, &PlcOptions::of(&n)).unwrap();
        let w = &sipn_checks(&space, &[]).unwrap().unsafe_places[0].witness;
        assert!(w.replays);
        assert_eq!(
            w.timeline_csv,
            "# a run of `test` under PLC-scan semantics after which place q holds 2 tokens (not safe)\n\
             time,A\n0,1\n0.01,1\n"
        );
        let tl = petriplc_sim::Timeline::parse(&w.timeline_csv, "w.csv").unwrap();
        let period = std::time::Duration::from_millis(10);
        let opts = petriplc_sim::SimOptions::new(&n, period, period);
        let mut sim = petriplc_sim::Simulation::new(&n, opts, Some(tl), None).unwrap();
        for step in &w.steps {
            assert_eq!(sim.step().unwrap().unwrap().marking, step.marking.0);
        }
        assert_eq!(sim.tokens("q"), Some(2));
    }

    /// The shortcut through the successor table finds what the passes find.
    #[test]
    fn table_and_passes_agree() {
        let nets = [
            crate::tests::example("mixer/mixer.pnml", petriplc_pnml::Naming::Sipn),
            crate::tests::example("busy-beaver/busy-beaver.pnml", petriplc_pnml::Naming::Plain),
            crate::tests::example(
                "philosophers/philosophers.pnml",
                petriplc_pnml::Naming::Plain,
            ),
            net("s A in bool\ns B in bool\np a 1\np b 0\np c 0\n\
                 t start a -> b if B\nt bc b -> c if A\nt cb c -> b if A\nt loop ?a -> if A AND B"),
        ];
        for n in &nets {
            let space = explore_controller(n, &PlcOptions::of(n)).unwrap();
            let table = space.table.as_ref().expect("one-pass, no delays");
            let (mut a, mut b) = (Cycles::default(), Cycles::default());
            by_table(&space, table, &mut a).unwrap();
            by_passes(&space, &mut b).unwrap();
            let summary = |c: &Cycles| {
                let mut keys: Vec<_> = c.seen.iter().cloned().collect();
                keys.sort();
                let found: Vec<_> = c
                    .found
                    .iter()
                    .map(|f| (f.state, f.combo, f.cycle.clone()))
                    .collect();
                (keys, found)
            };
            assert_eq!(summary(&a), summary(&b), "{}", n.id);
            assert!(a.total > 0 || n.id == "philosophers", "{}", n.id);
        }
    }

    #[test]
    fn a_two_transition_cycle_under_constant_inputs_is_unstable() {
        check(
            "s A in bool\np a 1\np b 0\nt ab a -> b if A\nt ba b -> a if A",
            &[],
            &["unstable A=1 from a: ab, ba"],
        );
    }

    #[test]
    fn a_growing_net_is_unstable_without_repeating() {
        let n = net("s A in bool\np p 1\np q 0\nt grow ?p -> q if A");
        let mut opts = PlcOptions::of(&n);
        opts.max_states = 5;
        opts.scan.max_passes = 10;
        let space = explore_controller(&n, &opts).unwrap();
        let r = sipn_checks(&space, &[]).unwrap();
        assert!(!r.complete);
        assert_eq!(r.unstable[0].cycle.len(), 1);
        assert!(!r.unstable[0].periodic);
    }

    #[test]
    fn exclusive_outputs_found_on_together() {
        check(
            "s A in bool\np idle 1\np v1 0 >V1 cap=1\np v3 0 >V3 cap=1\n\
             t open1 ?idle -> v1 if A\nt open3 ?idle -> v3 if NOT A",
            &[("V1", "V3")],
            &["conflict V1 V3 after [0][1]"],
        );
        check(
            "s A in bool\np idle 1\np v1 0 >V1\np v3 0 >V3\nt open1 idle -> v1 if A\nt open3 idle -> v3 if NOT A",
            &[("V1", "V3")],
            &[],
        );
    }

    /// The reported marking and inputs make petriplc-net's until-stable scan fail.
    #[test]
    fn the_unstable_witness_makes_until_stable_fail() {
        let n = net("s A in bool\ns B in bool\np a 1\np b 0\np c 0\n\
                     t start a -> b if B\nt bc b -> c if A\nt cb c -> b if A");
        let space = explore_controller(&n, &PlcOptions::of(&n)).unwrap();
        let r = sipn_checks(&space, &[]).unwrap();
        assert_eq!(r.unstable_total, 1);
        let u = &r.unstable[0];
        let mut sc = Scanner::new(
            &n,
            ScanOptions {
                evolve: Evolution::UntilStable,
                ..ScanOptions::of(&n)
            },
        );
        // Replay the witness one-pass, then scan until-stable with the reported inputs.
        let mut signals = vec![0; n.signals().len()];
        let mut one = Scanner::new(&n, ScanOptions::of(&n));
        for (k, st) in u.witness.steps.iter().enumerate() {
            for (s, v) in n.inputs().zip(&st.inputs) {
                signals[s.index()] = *v;
            }
            one.scan(Duration::from_millis(10 * k as u64), &mut signals)
                .unwrap();
        }
        assert_eq!(one.marking(), &u.marking);
        sc.set_marking(&u.marking);
        for (s, v) in &u.inputs {
            signals[s.index()] = *v;
        }
        let err = sc.scan(Duration::ZERO, &mut signals).unwrap_err();
        let ScanError::Unstable { transitions, .. } = err else {
            panic!("{err}")
        };
        assert_eq!(transitions, ["bc", "cb"]);
        assert_eq!(names(&n, &u.cycle), "bc, cb");
    }
}
