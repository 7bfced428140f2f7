//! The search of the closed loop for `never PLACE…`: breadth-first over its states, each
//! place asked proved never marked or given the shortest run that marks it, replayed as
//! moves and a timeline.

use indexmap::IndexSet;

use super::{ClosedLoop, Edge, Kind, NeverReport, NeverResult, Target};
use crate::plc::Stepper;
use crate::witness::{self, values, Move, Row, ScanStep};
use crate::ClosedLoopError;

impl ClosedLoop<'_> {
    /// The run from the initial state along `path`, as moves.
    pub(super) fn replay(
        &self,
        stepper: &mut Stepper<'_>,
        path: &[Kind],
    ) -> Result<Vec<Move>, ClosedLoopError> {
        let mut s = self.initial();
        let mut moves = Vec::with_capacity(path.len());
        for &kind in path {
            let (n, mv) = self.apply(stepper, &s, kind)?;
            moves.push(mv);
            s = n;
        }
        Ok(moves)
    }

    /// The verdict for a place first marked in state `end`: the shortest run and its timeline.
    pub(super) fn reached(
        &self,
        stepper: &mut Stepper<'_>,
        parent: &[Option<Edge>],
        end: usize,
        target: Target,
        states: u64,
    ) -> Result<NeverResult, ClosedLoopError> {
        let (c, p) = (self.controller.net, self.plant);
        let mut path = Vec::new();
        let mut j = end;
        while let Some(e) = parent[j] {
            path.push(e.kind);
            j = e.from as usize;
        }
        path.reverse();
        let moves = self.replay(stepper, &path)?;
        let scans: Vec<&ScanStep> = moves
            .iter()
            .filter_map(|m| match m {
                Move::Scan(st) => Some(st),
                Move::Plant { .. } => None,
            })
            .collect();
        let label = self.label(target);
        let period = petriplc_net::time::format_iec(self.options.period);
        let period = period.trim_start_matches("T#");
        let mut about = vec![format!(
            "closed loop `{}` + plant `{}`: {label} is marked after {} and {}",
            c.id,
            p.id,
            plural(scans.len(), "controller scan"),
            plural(moves.len() - scans.len(), "plant move")
        )];
        if self.options.timed {
            about.push(format!(
                "timed at a {period} scan period: controller timers exact, plant delays and deadlines kept"
            ));
        }
        about.push("one row per controller scan (its inputs: the plant's outputs and free inputs); plant moves are comments".into());
        about.push(format!(
            "replay the controller side: petriplc sim CONTROLLER.pnml --inputs THIS.csv --period {period}"
        ));
        let mut rows: Vec<Row<'_>> = Vec::with_capacity(moves.len() + 1);
        for m in &moves {
            rows.push(match m {
                Move::Scan(st) => Row::Scan(st),
                Move::Plant {
                    transition,
                    free_inputs,
                    ..
                } => Row::Comment(if free_inputs.is_empty() {
                    format!("plant fires {}", p.transition_label(*transition))
                } else {
                    format!(
                        "plant fires {} (with {})",
                        p.transition_label(*transition),
                        values(p, free_inputs)
                    )
                }),
            });
        }
        rows.push(Row::Comment(format!("now {label} is marked")));
        let timeline_csv = witness::timeline(c, self.options.period, &rows, &about);
        let replays =
            witness::replays(&self.controller, self.options.period, scans.iter().copied());
        Ok(NeverResult::Reached {
            states,
            moves,
            timeline_csv,
            replays,
        })
    }
}

/// Searches the closed loop breadth-first for a state where `place` is marked: proves it never
/// is, or returns a shortest run that marks it, with its timeline. `place` is a place label or
/// id, qualified `controller:NAME` / `plant:NAME` when both nets have it.
pub fn never(cl: &ClosedLoop<'_>, place: &str) -> Result<NeverResult, ClosedLoopError> {
    let mut report = never_all(cl, &[place])?;
    Ok(report.verdicts.remove(0).1)
}

/// [`never`] for several places in one search: the state space is explored once, each place
/// gets the shortest run that marks it (breadth-first), and the search stops early only when
/// every place has been reached. A place named twice is checked once but reported twice.
pub fn never_all(cl: &ClosedLoop<'_>, places: &[&str]) -> Result<NeverReport, ClosedLoopError> {
    let targets = places
        .iter()
        .map(|p| cl.resolve(p))
        .collect::<Result<Vec<_>, _>>()?;
    let init = cl.initial();
    let mut states: IndexSet<Box<[u32]>> = IndexSet::new();
    let mut parent: Vec<Option<Edge>> = vec![None];
    states.insert(cl.key(&init));
    let mut stepper = Stepper::new(&cl.controller);
    let (mut unstable, mut time_locks, mut edges) = (0u64, 0u64, 0u64);
    // Per target, the first state that marks it.
    let mut hits: Vec<Option<usize>> = targets
        .iter()
        .map(|&t| cl.marks(&states[0], t).then_some(0))
        .collect();
    let mut next = Vec::new();
    let mut succ: Vec<u32> = Vec::new();
    let mut i = 0;
    let mut stopped = false;
    'search: while hits.iter().any(Option::is_none) && i < states.len() {
        if cl.options.cancelled() {
            stopped = true;
            break;
        }
        let s = cl.split(&states[i]);
        next.clear();
        cl.expand(&mut stepper, &s, &mut next, &mut unstable)?;
        if next.is_empty() && cl.options.timed && !cl.scan_allowed(&s) {
            time_locks += 1;
        }
        succ.clear();
        for (n, kind) in next.drain(..) {
            let (j, new) = states.insert_full(cl.key(&n));
            succ.push(j as u32);
            if !new {
                continue;
            }
            if states.len() as u64 > cl.options.max_states {
                states.pop();
                stopped = true;
                break 'search;
            }
            parent.push(Some(Edge {
                from: i as u32,
                kind,
            }));
            let mut all = true;
            for (h, &t) in hits.iter_mut().zip(&targets) {
                if h.is_none() && cl.marks(&states[j], t) {
                    *h = Some(j);
                }
                all &= h.is_some();
            }
            if all {
                i += 1;
                break 'search;
            }
        }
        succ.sort_unstable();
        succ.dedup();
        edges += succ.len() as u64;
        i += 1;
    }
    let found = states.len() as u64;
    let complete = !stopped && i >= states.len();
    let mut verdicts = Vec::with_capacity(targets.len());
    for (&target, hit) in targets.iter().zip(&hits) {
        let verdict = match hit {
            Some(end) => cl.reached(&mut stepper, &parent, *end, target, (*end + 1) as u64)?,
            None if complete => NeverResult::Proved {
                states: found,
                unstable_scans: unstable,
            },
            None => NeverResult::Incomplete { states: found },
        };
        verdicts.push((cl.label(target), verdict));
    }
    Ok(NeverReport {
        states: found,
        edges,
        complete,
        unstable_scans: unstable,
        time_locks,
        verdicts,
    })
}

/// `1 plant move`, `3 plant moves`.
fn plural(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}
