//! `petriplc analyze`: invariants, boundedness, the reachability graph and its properties,
//! conflicts, SIPN checks under PLC semantics and closed-loop checks against a plant.

mod graph;
mod report;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::{anyhow, Context};
use indicatif::{ProgressBar, ProgressStyle};
use petriplc_closedloop::{self as closedloop, NeverResult, PlcOptions};
use petriplc_net::{Marking, Net, PlaceId, SignalId, TransitionId};
use petriplc_pnml::ReadOptions;
use petriplc_reach::{self as reach, ExploreOptions, Limit, PropertyOptions, StateId, StateSpace};
use petriplc_structure::{self as structure, Limits};

use self::report::{
    ClosedLoopFacts, ConflictFacts, EffectiveConflict, InvariantFacts, Never, NeverFacts, Report,
    SipnFacts, SpaceFacts, StructuralConflict, Unstable,
};
use crate::args::AnalyzeArgs;
use crate::failure::{BadInputExt, Failure, RunExt};
use crate::output::write_file;

pub fn run(args: AnalyzeArgs) -> Result<(), Failure> {
    crate::heap::reuse_freed_memory();
    let net = super::read_net(&args.net, args.names)?;
    let plant = plant(&args, &net)?;
    let cancel = cancel_on_ctrl_c();

    let mut report = Report {
        net: net.id.clone(),
        complete: true,
        ..Report::default()
    };
    let structurally_bounded = invariants(&net, &mut report);
    boundedness(&net, &args, structurally_bounded, &cancel, &mut report);
    let space = state_space(&net, &args, &cancel, &mut report)?;
    report.conflicts = conflicts(&net, space.as_ref());
    draw(&net, &args, space.as_ref())?;
    drop(space);
    let plc = PlcOptions {
        cancel: Some(cancel.clone()),
        ..PlcOptions::of(&net)
    };
    let plc = PlcOptions {
        max_states: args.max_states.unwrap_or(plc.max_states),
        ..plc
    };
    if net.inputs().next().is_some() && plant.is_none() {
        sipn(&net, &plc, &mut report)?;
    }
    let violated = match &plant {
        Some(plant) => closed_loop(&net, plant, &args, &plc, &mut report)?,
        None => Vec::new(),
    };
    finish(&report, &args, &violated, &cancel)
}

/// The plant net of `--plant`, if any; a hint when its outputs look like the controller's
/// SIPN names.
fn plant(args: &AnalyzeArgs, net: &Net) -> Result<Option<Net>, Failure> {
    let plant = match &args.plant {
        Some(path) => Some(
            petriplc_pnml::read_file(path, &ReadOptions::default())
                .bad_input()?
                .net,
        ),
        None => None,
    };
    if let Some(plant) = &plant {
        let outputs: Vec<String> = plant
            .outputs()
            .map(|s| plant.signal(s).name.clone())
            .collect();
        if let Some(hint) = super::sipn_hint(&args.net, args.names, net, &outputs, "the plant") {
            eprintln!("warning: {hint}");
        }
    }
    Ok(plant)
}

/// A flag Ctrl-C sets, so that every stage stops early and the report says it is partial.
fn cancel_on_ctrl_c() -> Arc<AtomicBool> {
    let cancel = Arc::new(AtomicBool::new(false));
    {
        let cancel = cancel.clone();
        // A second Ctrl-C while the first is being handled kills the process as usual.
        let _ = ctrlc::set_handler(move || {
            if cancel.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        });
    }
    cancel
}

/// Invariants: cheap, and they may prove boundedness before any exploration. Returns
/// whether they do.
fn invariants(net: &Net, report: &mut Report) -> bool {
    let label = |p: PlaceId| net.place_label(p).to_string();
    let tlabel = |t: TransitionId| net.transition_label(t).to_string();
    let p_inv = structure::p_invariants(net, Limits::default());
    let t_inv = structure::t_invariants(net, Limits::default());
    let structurally_bounded = structure::structurally_bounded(net, &p_inv);
    let covered = structure::covered_places(net, &p_inv);
    report.invariants = InvariantFacts {
        p: p_inv
            .vectors
            .iter()
            .map(|v| {
                v.iter()
                    .map(|&(i, w)| (label(PlaceId::from(i)), w))
                    .collect()
            })
            .collect(),
        t: t_inv
            .vectors
            .iter()
            .map(|v| {
                v.iter()
                    .map(|&(i, w)| (tlabel(TransitionId::from(i)), w))
                    .collect()
            })
            .collect(),
        p_complete: p_inv.complete,
        t_complete: t_inv.complete,
        conservation_laws: structure::conservation_laws(net, &p_inv),
        structurally_bounded,
        uncovered_places: net
            .place_ids()
            .filter(|&p| !covered[p.index()] && net.place(p).input.is_none())
            .map(label)
            .collect(),
    };
    for (what, inv) in [("P-invariants", &p_inv), ("T-invariants", &t_inv)] {
        if !inv.complete {
            report.complete = false;
            report.incomplete.push(format!(
                "{what}: {}",
                inv.reason.as_deref().unwrap_or("limit reached")
            ));
        }
    }
    structurally_bounded
}

/// Boundedness: structural, else Karp–Miller.
fn boundedness(
    net: &Net,
    args: &AnalyzeArgs,
    structurally_bounded: bool,
    cancel: &Arc<AtomicBool>,
    report: &mut Report,
) {
    let label = |p: PlaceId| net.place_label(p).to_string();
    let max_states = args.max_states;
    report.bounded = if structurally_bounded {
        Some(true)
    } else {
        let cov = reach::coverability(
            net,
            max_states.unwrap_or(DEFAULT_COVERABILITY_NODES),
            Some(cancel),
        );
        if !cov.unbounded_places.is_empty() {
            report.unbounded_places = cov.unbounded_places.iter().map(|&p| label(p)).collect();
            report.place_bounds = net
                .place_ids()
                .map(|p| (label(p), cov.place_bounds[p.index()]))
                .collect();
            Some(false)
        } else if cov.complete {
            Some(cov.bounded)
        } else {
            report.complete = false;
            report.incomplete.push(format!(
                "coverability stopped after {} nodes: boundedness undecided",
                cov.nodes
            ));
            None
        }
    };
}

/// The reachability graph, for a net not known to be unbounded, and its properties;
/// the graph itself is kept when it is to be drawn.
fn state_space(
    net: &Net,
    args: &AnalyzeArgs,
    cancel: &Arc<AtomicBool>,
    report: &mut Report,
) -> Result<Option<StateSpace>, Failure> {
    let label = |p: PlaceId| net.place_label(p).to_string();
    let tlabel = |t: TransitionId| net.transition_label(t).to_string();
    let max_states = args.max_states;
    let max_memory = args.max_memory.or_else(default_max_memory);
    let drawing = args.dot.is_some() || args.svg.is_some();
    let mut space = None;
    if report.bounded != Some(false) {
        let progress = Progress::new();
        let opts = ExploreOptions {
            max_states: max_states
                .or((report.bounded.is_none()).then_some(DEFAULT_UNDECIDED_STATES)),
            max_memory,
            threads: 0,
            keep_graph: false,
            cancel: Some(cancel.clone()),
            progress: Some(progress.callback()),
        };
        let explored = reach::explore(net, &opts);
        progress.finish();
        let explored = match explored {
            // A count past the 32-bit token counter: no graph, but the rest still stands
            // (and boundedness is what coverability said, not a consequence of this).
            Err(e @ reach::ReachError::TokenOverflow { .. }) => {
                report.complete = false;
                report
                    .incomplete
                    .push(format!("reachability graph not built: {e}"));
                None
            }
            explored => Some(explored.run_failure()?),
        };
        if let Some(mut explored) = explored {
            progress.phase(&explored, "liveness, reversibility, home markings");
            let props = reach::properties_with(
                net,
                &explored,
                &PropertyOptions {
                    threads: 0,
                    max_memory,
                    cancel: Some(cancel.clone()),
                },
            );
            progress.finish();
            let complete = explored.complete();
            if !complete {
                report.complete = false;
                let (n, e) = (explored.states(), explored.edges());
                report.incomplete.push(match explored.limit() {
                    Some(Limit::Memory(m)) => format!(
                        "stopped at --max-memory {} ({n} states, {e} edges explored; raise it, e.g. --max-memory {})",
                        size(m),
                        size(m.saturating_mul(4))
                    ),
                    Some(Limit::States(m)) => format!(
                        "stopped at --max-states {m} ({n} states, {e} edges explored)"
                    ),
                    Some(Limit::Cancelled) | None => {
                        format!("interrupted after {n} states, {e} edges")
                    }
                });
            }
            if let Some(why) = &props.unknown {
                report.complete = false;
                report
                    .incomplete
                    .push(format!("liveness, reversibility and home markings: {why}"));
            }
            if report.place_bounds.is_empty() {
                report.place_bounds = net
                    .place_ids()
                    .map(|p| (label(p), Some(props.place_bounds[p.index()])))
                    .collect();
            }
            // What a partial exploration found holds; what it did not find is undecided.
            let found = |yes: bool, holds: bool| (yes || complete).then_some(holds);
            report.space = Some(SpaceFacts {
                states: props.states,
                edges: props.edges,
                max_tokens_place: props.max_tokens_place,
                max_tokens_marking: props.max_tokens_marking,
                safe: found(!props.safe, props.safe),
                deadlock: found(props.deadlock, props.deadlock),
                deadlock_trace: props
                    .deadlock_trace
                    .map(|ts| ts.into_iter().map(tlabel).collect()),
                quasi_live: found(props.quasi_live, props.quasi_live),
                dead_transitions: complete
                    .then(|| props.dead_transitions.into_iter().map(tlabel).collect()),
                live: props.live,
                reversible: props.reversible,
                home_marking: props.home_marking,
            });
            if drawing && explored.states() <= args.graph_limit {
                explored.keep_graph(0);
            }
            space = Some(explored);
        }
    }
    Ok(space)
}

/// Conflicts: structural ones, and effective ones when the state space is known.
fn conflicts(net: &Net, space: Option<&StateSpace>) -> ConflictFacts {
    let label = |p: PlaceId| net.place_label(p).to_string();
    let tlabel = |t: TransitionId| net.transition_label(t).to_string();
    ConflictFacts {
        structural: structure::structural_conflicts(net)
            .into_iter()
            .map(|c| StructuralConflict {
                a: tlabel(c.a),
                b: tlabel(c.b),
                places: c.places.into_iter().map(label).collect(),
            })
            .collect(),
        effective: space.map(|s| {
            // On all cores, with the first witness in state order (as a sequential sweep).
            let check = structure::ConflictCheck::new(net);
            let first = s.first_states(0, check.len(), |m, open, hit| {
                check.effective_in(m, open, hit)
            });
            check
                .conflicts(
                    first
                        .into_iter()
                        .map(|x| x.map(|id| s.marking(id)))
                        .collect(),
                )
                .into_iter()
                .map(|c| EffectiveConflict {
                    a: tlabel(c.a),
                    b: tlabel(c.b),
                    places: c.places.into_iter().map(label).collect(),
                    winner: tlabel(c.winner),
                    marking: marked(net, &c.witness_marking),
                    inputs: signal_values(net, &c.witness_inputs),
                })
                .collect()
        }),
    }
}

/// The graph drawing, if asked.
fn draw(net: &Net, args: &AnalyzeArgs, space: Option<&StateSpace>) -> Result<(), Failure> {
    if args.dot.is_some() || args.svg.is_some() {
        let s = space
            .ok_or_else(|| {
                anyhow!("the net is unbounded: there is no finite reachability graph to draw")
            })
            .bad_input()?;
        if s.states() > args.graph_limit {
            return Err(anyhow!(
                "the reachability graph has {} states, more than --graph-limit {}; raise the limit (e.g. --graph-limit {}) if you really want to draw it",
                s.states(),
                args.graph_limit,
                s.states()
            ))
            .bad_input();
        }
        let marking = |i: u64| s.marking(StateId(i as u32));
        let successors = |i: u64| {
            s.successors(StateId(i as u32))
                .map(|(t, d)| (t, u64::from(d.0)))
                .collect()
        };
        let dot = graph::to_dot(
            net,
            &graph::GraphView {
                states: s.states(),
                marking: &marking,
                successors: &successors,
            },
        );
        if let Some(path) = &args.dot {
            let what = format!(
                "the reachability graph in Graphviz DOT, {} states",
                s.states()
            );
            write_file(path, dot.as_bytes(), &what)?;
        }
        if let Some(path) = &args.svg {
            let svg = graph::to_svg(&dot).run_failure()?;
            let what = format!("the reachability graph as SVG, {} states", s.states());
            write_file(path, svg.as_bytes(), &what)?;
        }
    }
    Ok(())
}

/// SIPN checks under PLC semantics, for nets that read inputs (without a plant).
fn sipn(net: &Net, plc: &PlcOptions, report: &mut Report) -> Result<(), Failure> {
    let label = |p: PlaceId| net.place_label(p).to_string();
    let tlabel = |t: TransitionId| net.transition_label(t).to_string();
    let space = closedloop::explore_controller(net, plc).bad_input()?;
    let sipn = closedloop::sipn_checks(&space, &[]).run_failure()?;
    if !sipn.complete {
        report.complete = false;
        report.incomplete.push(format!(
            "PLC state space stopped after {} states",
            sipn.states
        ));
    }
    report.sipn = Some(SipnFacts {
        states: sipn.states,
        complete: sipn.complete,
        unsafe_places: sipn
            .unsafe_places
            .iter()
            .map(|u| (label(u.place), u.witness.timeline_csv.clone()))
            .collect(),
        unstable: sipn
            .unstable
            .iter()
            .map(|u| Unstable {
                marking: marked(net, &u.marking),
                inputs: signal_values(net, &u.inputs),
                cycle: u.cycle.iter().map(|&t| tlabel(t)).collect(),
            })
            .collect(),
    });
    Ok(())
}

/// Closed loop with a plant: the `--never` places, each proved never marked, undecided,
/// or reached (with the run). Returns why each reached one fails the command, and whether
/// there is a run to see.
fn closed_loop(
    net: &Net,
    plant: &Net,
    args: &AnalyzeArgs,
    plc: &PlcOptions,
    report: &mut Report,
) -> Result<Vec<(String, bool)>, Failure> {
    let mut violated = Vec::new();
    let opts = PlcOptions {
        timed: args.period.is_some(),
        period: args.period.unwrap_or(plc.period),
        ..plc.clone()
    };
    let cl = closedloop::closed_loop(net, plant, &opts).bad_input()?;
    if !args.never.is_empty() {
        let places: Vec<&str> = args.never.iter().map(String::as_str).collect();
        let started = std::time::Instant::now();
        let found = closedloop::never_all(&cl, &places).bad_input()?;
        let seconds = started.elapsed().as_secs_f64();
        if !found.complete
            && found
                .verdicts
                .iter()
                .any(|(_, v)| !matches!(v, NeverResult::Reached { .. }))
        {
            report.complete = false;
            report.incomplete.push(format!(
                "closed-loop search stopped after {} states",
                found.states
            ));
        }
        let mut verdicts = Vec::new();
        for ((label, verdict), asked) in found.verdicts.into_iter().zip(&args.never) {
            let (states, verdict) = match verdict {
                NeverResult::Proved { states, .. } => (states, Never::Proved),
                NeverResult::Incomplete { states } => (states, Never::Unknown),
                NeverResult::Reached {
                    states,
                    moves,
                    timeline_csv,
                    replays,
                } => {
                    let mut scans = 0;
                    let steps = moves
                        .iter()
                        .map(|m| {
                            let line = m.describe(net, plant, scans);
                            if matches!(m, closedloop::Move::Scan(_)) {
                                scans += 1;
                            }
                            line
                        })
                        .collect();
                    // (why, whether there is a run to see)
                    violated.push(if moves.is_empty() {
                        (format!("`{asked}` is marked from the start"), false)
                    } else {
                        (format!("`{asked}` can be marked"), true)
                    });
                    (
                        states,
                        Never::Reached {
                            plant_moves: moves.len() - scans,
                            scans,
                            steps,
                            timeline: timeline_csv,
                            replays,
                        },
                    )
                }
            };
            verdicts.push(NeverFacts {
                place: asked.clone(),
                label,
                states,
                verdict,
            });
        }
        report.closed_loop = Some(ClosedLoopFacts {
            plant: plant.id.clone(),
            period: args.period,
            states: found.states,
            edges: found.edges,
            complete: found.complete,
            time_locks: found.time_locks,
            seconds,
            places: verdicts,
        });
    }
    Ok(violated)
}

/// The report on standard output; the exit status tells of a reached `--never` place or an
/// interruption.
fn finish(
    report: &Report,
    args: &AnalyzeArgs,
    violated: &[(String, bool)],
    cancel: &AtomicBool,
) -> Result<(), Failure> {
    let text = if args.json {
        let json = serde_json::to_string_pretty(&report.to_json())
            .context("cannot write JSON")
            .run_failure()?;
        json + "\n"
    } else {
        report.to_text()
    };
    crate::output::to_stdout(|out| out.write_all(text.as_bytes()))?;
    let runs = violated.iter().filter(|(_, run)| *run).count();
    let whys: Vec<&str> = violated.iter().map(|(why, _)| why.as_str()).collect();
    match runs {
        _ if whys.is_empty() && cancel.load(Ordering::SeqCst) => Err(Failure::Interrupted(
            anyhow!("interrupted by Ctrl-C: the report above is partial"),
        )),
        _ if whys.is_empty() => Ok(()),
        0 => Err(Failure::Run(anyhow!("{}", whys.join("; ")))),
        1 => Err(Failure::Run(anyhow!(
            "{}: see the run above",
            whys.join("; ")
        ))),
        _ => Err(Failure::Run(anyhow!(
            "{}: see the runs above",
            whys.join("; ")
        ))),
    }
}

/// Karp–Miller nodes tried before boundedness is declared undecided.
const DEFAULT_COVERABILITY_NODES: u64 = 1_000_000;
/// States explored when boundedness is undecided, so exploration cannot run forever.
const DEFAULT_UNDECIDED_STATES: u64 = 10_000_000;

fn marked(net: &Net, m: &Marking) -> Vec<(String, u64)> {
    net.place_ids()
        .filter(|&p| m[p] > 0)
        .map(|p| (net.place_label(p).to_string(), u64::from(m[p])))
        .collect()
}

fn signal_values(net: &Net, values: &[(SignalId, i64)]) -> Vec<(String, i64)> {
    values
        .iter()
        .map(|&(s, v)| (net.signal(s).name.clone(), v))
        .collect()
}

/// Half the machine's physical memory (`MemTotal` in /proc/meminfo): the default
/// `--max-memory`, so that a net too big to finish gets a partial report instead of the
/// kernel's out-of-memory killer.
fn default_max_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kb: u64 = info
        .lines()
        .find_map(|l| l.strip_prefix("MemTotal:"))?
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kb * 1024 / 2)
}

/// This process's resident memory in bytes (Linux), for the progress bar.
fn resident_bytes() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096)
}

/// A size as `--max-memory` reads it: 512K, 64M, 1.5G.
fn size(b: u64) -> String {
    let (v, unit) = match b {
        b if b >= 1 << 30 => (b as f64 / (1u64 << 30) as f64, "G"),
        b if b >= 1 << 20 => (b as f64 / (1u64 << 20) as f64, "M"),
        b if b >= 1 << 10 => (b as f64 / (1u64 << 10) as f64, "K"),
        b => (b as f64, ""),
    };
    let text = format!("{v:.1}");
    format!("{}{unit}", text.trim_end_matches(".0"))
}

fn megabytes(b: u64) -> String {
    format!("{} MB", b.div_ceil(1 << 20))
}

/// A progress bar on standard error, shown only once an exploration has run for a second
/// and only on a terminal (indicatif draws nothing otherwise): states, edges, states per
/// second and memory.
struct Progress {
    bar: Arc<Mutex<Option<ProgressBar>>>,
}

impl Progress {
    fn new() -> Self {
        Progress {
            bar: Arc::new(Mutex::new(None)),
        }
    }

    fn bar(slot: &mut Option<ProgressBar>) -> &ProgressBar {
        slot.get_or_insert_with(|| {
            let b = ProgressBar::new_spinner();
            b.set_style(
                ProgressStyle::with_template("{spinner} {elapsed} {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            b
        })
    }

    fn callback(&self) -> Arc<dyn Fn(reach::Progress) + Send + Sync> {
        let bar = self.bar.clone();
        Arc::new(move |p: reach::Progress| {
            if p.elapsed < Duration::from_secs(1) {
                return;
            }
            let mut guard = bar.lock().unwrap_or_else(|e| e.into_inner());
            let bar = Self::bar(&mut guard);
            let rate = p.states as f64 / p.elapsed.as_secs_f64();
            bar.set_message(format!(
                "{} states, {} edges, {:.0} states/s, {} (Ctrl-C stops)",
                p.states,
                p.edges,
                rate,
                megabytes(resident_bytes().unwrap_or(p.bytes))
            ));
            bar.tick();
        })
    }

    /// A spinner for a phase after a long exploration (none after a short one).
    fn phase(&self, space: &reach::StateSpace, what: &str) {
        if space.elapsed() < Duration::from_secs(1) {
            return;
        }
        let mut guard = self.bar.lock().unwrap_or_else(|e| e.into_inner());
        let bar = Self::bar(&mut guard);
        bar.set_message(format!(
            "{} states explored; {what}, {}",
            space.states(),
            megabytes(resident_bytes().unwrap_or(0))
        ));
        bar.enable_steady_tick(Duration::from_millis(200));
    }

    fn finish(&self) {
        if let Some(bar) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            bar.finish_and_clear();
        }
    }
}
