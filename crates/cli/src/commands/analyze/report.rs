//! What `petriplc analyze` found, in names rather than ids, rendered as text for people or
//! as the stable JSON documented in docs/analysis.md.

use std::fmt::Write as _;

use serde_json::{json, Map, Value};

/// Everything one analysis found. `None` means "not computed" (e.g. the net is unbounded, or
/// the graph was not kept), never "false".
#[derive(Debug, Default)]
pub struct Report {
    pub net: String,
    /// False when a limit or Ctrl-C cut an exploration short; `incomplete` says which.
    pub complete: bool,
    pub incomplete: Vec<String>,
    pub bounded: Option<bool>,
    pub unbounded_places: Vec<String>,
    pub space: Option<SpaceFacts>,
    /// Per place in declaration order: its bound, `None` for ω (unbounded).
    pub place_bounds: Vec<(String, Option<u64>)>,
    pub invariants: InvariantFacts,
    pub conflicts: ConflictFacts,
    pub sipn: Option<SipnFacts>,
    pub closed_loop: Option<ClosedLoopFacts>,
}

/// Facts from the reachability graph.
#[derive(Debug, Default)]
pub struct SpaceFacts {
    pub states: u64,
    pub edges: u64,
    pub max_tokens_place: u64,
    pub max_tokens_marking: u64,
    /// `None` (here and below) when a partial exploration does not decide it: what it found
    /// holds (a deadlock found is real), the absence of something found proves nothing.
    pub safe: Option<bool>,
    pub deadlock: Option<bool>,
    pub deadlock_trace: Option<Vec<String>>,
    pub quasi_live: Option<bool>,
    pub dead_transitions: Option<Vec<String>>,
    pub live: Option<bool>,
    pub reversible: Option<bool>,
    pub home_marking: Option<bool>,
}

/// One invariant: (element name, weight), weights > 0.
pub type Vector = Vec<(String, u64)>;

#[derive(Debug, Default)]
pub struct InvariantFacts {
    pub p: Vec<Vector>,
    pub t: Vec<Vector>,
    pub p_complete: bool,
    pub t_complete: bool,
    pub conservation_laws: Vec<String>,
    pub structurally_bounded: bool,
    pub uncovered_places: Vec<String>,
}

#[derive(Debug, Default)]
pub struct ConflictFacts {
    pub structural: Vec<StructuralConflict>,
    /// `None` when no state space was built to find them in.
    pub effective: Option<Vec<EffectiveConflict>>,
}

#[derive(Debug)]
pub struct StructuralConflict {
    pub a: String,
    pub b: String,
    pub places: Vec<String>,
}

#[derive(Debug)]
pub struct EffectiveConflict {
    pub a: String,
    pub b: String,
    pub places: Vec<String>,
    /// The transition the priority rule lets fire (the lower index).
    pub winner: String,
    pub marking: Vec<(String, u64)>,
    pub inputs: Vec<(String, i64)>,
}

/// Seed 002/Frey's checks under PLC semantics.
#[derive(Debug, Default)]
pub struct SipnFacts {
    pub states: u64,
    pub complete: bool,
    /// Places that can hold more than one token, with an input timeline reaching it.
    pub unsafe_places: Vec<(String, String)>,
    /// (marking, inputs, transitions cycling) for which until-stable would never settle.
    pub unstable: Vec<Unstable>,
}

#[derive(Debug)]
pub struct Unstable {
    pub marking: Vec<(String, u64)>,
    pub inputs: Vec<(String, i64)>,
    pub cycle: Vec<String>,
}

/// The closed loop with `--plant` and `--never`: its state space and a verdict per place.
#[derive(Debug)]
pub struct ClosedLoopFacts {
    pub plant: String,
    /// `Some` for a timed analysis (`--period`).
    pub period: Option<std::time::Duration>,
    pub states: u64,
    pub edges: u64,
    pub complete: bool,
    pub time_locks: u64,
    /// Wall-clock time of the search.
    pub seconds: f64,
    pub places: Vec<NeverFacts>,
}

/// The answer to one `--never PLACE`.
#[derive(Debug)]
pub struct NeverFacts {
    /// As given on the command line.
    pub place: String,
    /// Qualified: `plant:NAME` or `controller:NAME`.
    pub label: String,
    /// States found when the verdict was known (for `reached`: when the place was first
    /// marked; otherwise all of them).
    pub states: u64,
    pub verdict: Never,
}

#[derive(Debug)]
pub enum Never {
    /// No reachable state marks the place (within the documented abstraction).
    Proved,
    /// A run reaching it, as steps and as a timeline `petriplc sim` replays; no steps when
    /// the place is marked from the start.
    Reached {
        steps: Vec<String>,
        timeline: String,
        /// Controller scans and plant moves in `steps`.
        scans: usize,
        plant_moves: usize,
        /// Whether the controller side replays with real timers.
        replays: bool,
    },
    /// A limit stopped the search first.
    Unknown,
}

fn map<T: Into<Value> + Clone>(pairs: &[(String, T)]) -> Value {
    let mut m = Map::new();
    for (k, v) in pairs {
        m.insert(k.clone(), v.clone().into());
    }
    Value::Object(m)
}

fn opt<T: Into<Value>>(v: Option<T>) -> Value {
    v.map_or(Value::Null, Into::into)
}

impl Report {
    /// The stable JSON form (docs/analysis.md); keys keep this order.
    pub fn to_json(&self) -> Value {
        let s = self.space.as_ref();
        let bounds: Vec<(String, Value)> = self
            .place_bounds
            .iter()
            .map(|(p, b)| (p.clone(), b.map_or_else(|| json!("inf"), |b| json!(b))))
            .collect();
        let mut out = Map::new();
        let mut put = |k: &str, v: Value| {
            out.insert(k.to_string(), v);
        };
        put("net", json!(self.net));
        put("complete", json!(self.complete));
        if !self.incomplete.is_empty() {
            put("incomplete", json!(self.incomplete));
        }
        put("bounded", opt(self.bounded));
        put("unbounded_places", json!(self.unbounded_places));
        put("states", opt(s.map(|s| s.states)));
        put("edges", opt(s.map(|s| s.edges)));
        put("max_tokens_place", opt(s.map(|s| s.max_tokens_place)));
        put("max_tokens_marking", opt(s.map(|s| s.max_tokens_marking)));
        put("place_bounds", map(&bounds));
        put("safe", opt(s.and_then(|s| s.safe)));
        put("deadlock", opt(s.and_then(|s| s.deadlock)));
        put(
            "deadlock_trace",
            opt(s.and_then(|s| s.deadlock_trace.clone())),
        );
        put("quasi_live", opt(s.and_then(|s| s.quasi_live)));
        put(
            "dead_transitions",
            opt(s.and_then(|s| s.dead_transitions.clone())),
        );
        put("live", opt(s.and_then(|s| s.live)));
        put("reversible", opt(s.and_then(|s| s.reversible)));
        put("home_marking", opt(s.and_then(|s| s.home_marking)));
        let vectors = |vs: &[Vector]| Value::Array(vs.iter().map(|v| map(v)).collect());
        put("p_invariants", vectors(&self.invariants.p));
        put("t_invariants", vectors(&self.invariants.t));
        put(
            "invariants_complete",
            json!(self.invariants.p_complete && self.invariants.t_complete),
        );
        put(
            "conservation_laws",
            json!(self.invariants.conservation_laws),
        );
        put(
            "structurally_bounded",
            json!(self.invariants.structurally_bounded),
        );
        let structural: Vec<Value> = self
            .conflicts
            .structural
            .iter()
            .map(|c| json!({"transitions": [c.a, c.b], "places": c.places}))
            .collect();
        let effective = self.conflicts.effective.as_ref().map(|es| {
            es.iter()
                .map(|c| {
                    json!({
                        "transitions": [c.a, c.b],
                        "places": c.places,
                        "winner": c.winner,
                        "marking": map(&c.marking),
                        "inputs": map(&c.inputs),
                    })
                })
                .collect::<Vec<_>>()
        });
        put(
            "conflicts",
            json!({"structural": structural, "effective": effective}),
        );
        if let Some(sipn) = &self.sipn {
            let unstable: Vec<Value> = sipn
                .unstable
                .iter()
                .map(|u| json!({"marking": map(&u.marking), "inputs": map(&u.inputs), "cycle": u.cycle}))
                .collect();
            let unsafe_places: Vec<Value> = sipn
                .unsafe_places
                .iter()
                .map(|(p, tl)| json!({"place": p, "timeline": tl}))
                .collect();
            put(
                "sipn",
                json!({
                    "states": sipn.states,
                    "complete": sipn.complete,
                    "safe": sipn.unsafe_places.is_empty(),
                    "unsafe_places": unsafe_places,
                    "stable": sipn.unstable.is_empty(),
                    "unstable": unstable,
                    "contradictory_outputs": false,
                }),
            );
        }
        if let Some(cl) = &self.closed_loop {
            let places: Vec<Value> = cl
                .places
                .iter()
                .map(|n| {
                    let (verdict, steps, timeline) = match &n.verdict {
                        Never::Proved => ("never", Value::Null, Value::Null),
                        Never::Reached {
                            steps, timeline, ..
                        } => ("reached", json!(steps), json!(timeline)),
                        Never::Unknown => ("unknown", Value::Null, Value::Null),
                    };
                    json!({"place": n.place, "label": n.label, "verdict": verdict, "states": n.states, "steps": steps, "timeline": timeline})
                })
                .collect();
            // The first place alone, as before several could be asked.
            if let Some(first) = places.first() {
                put("never", first.clone());
            }
            put(
                "closed_loop",
                json!({
                    "plant": cl.plant,
                    "timed": cl.period.is_some(),
                    "period": cl.period.map(|p| p.as_secs_f64()),
                    "states": cl.states,
                    "edges": cl.edges,
                    "complete": cl.complete,
                    "time_locks": cl.time_locks,
                    "seconds": cl.seconds,
                    "places": places,
                }),
            );
        }
        Value::Object(out)
    }

    /// The report for people: properties first, then invariants, then conflicts.
    pub fn to_text(&self) -> String {
        let mut o = String::new();
        let yes_no = |b: bool| if b { "yes" } else { "no" };
        let maybe = |b: Option<bool>| b.map_or("not computed", yes_no);
        let _ = writeln!(o, "net {}", self.net);
        if !self.complete {
            let _ = writeln!(o, "INCOMPLETE: {}", self.incomplete.join("; "));
        }
        let _ = writeln!(o, "\nproperties (interleaving semantics)");
        match (self.bounded, &self.space) {
            (Some(false), _) => {
                let _ = writeln!(
                    o,
                    "  bounded:            no — unbounded places: {}",
                    self.unbounded_places.join(", ")
                );
            }
            (_, Some(s)) => {
                let _ = writeln!(o, "  states:             {}", s.states);
                let _ = writeln!(o, "  edges:              {}", s.edges);
                let _ = writeln!(o, "  bounded:            {}", maybe(self.bounded));
                let _ = writeln!(o, "  max tokens/place:   {}", s.max_tokens_place);
                let _ = writeln!(o, "  max tokens/marking: {}", s.max_tokens_marking);
                let _ = writeln!(o, "  safe (1-bounded):   {}", maybe(s.safe));
                let _ = match &s.deadlock_trace {
                    Some(t) if s.deadlock == Some(true) => writeln!(
                        o,
                        "  deadlock:           yes, after {}",
                        if t.is_empty() {
                            "no firing (M0 is dead)".to_string()
                        } else {
                            t.join(" ")
                        }
                    ),
                    _ => writeln!(o, "  deadlock:           {}", maybe(s.deadlock)),
                };
                let _ = writeln!(o, "  quasi-live:         {}", maybe(s.quasi_live));
                if let Some(dead) = s.dead_transitions.as_ref().filter(|d| !d.is_empty()) {
                    let _ = writeln!(o, "    never fire:       {}", dead.join(", "));
                }
                let _ = writeln!(o, "  live (L4):          {}", maybe(s.live));
                let _ = writeln!(o, "  reversible:         {}", maybe(s.reversible));
                let _ = writeln!(o, "  home marking:       {}", maybe(s.home_marking));
            }
            _ => {
                let _ = writeln!(o, "  bounded:            {}", maybe(self.bounded));
            }
        }
        if !self.place_bounds.is_empty() {
            let bounds: Vec<String> = self
                .place_bounds
                .iter()
                .map(|(p, b)| {
                    format!(
                        "{p}={}",
                        b.map_or_else(|| "ω".to_string(), |b| b.to_string())
                    )
                })
                .collect();
            let _ = writeln!(o, "  place bounds:       {}", bounds.join(" "));
        }

        let inv = &self.invariants;
        let _ = writeln!(
            o,
            "\nP-invariants: {}{}",
            inv.p.len(),
            if inv.p_complete {
                ""
            } else {
                " (incomplete: limit reached)"
            }
        );
        for law in &inv.conservation_laws {
            let _ = writeln!(o, "  {law}");
        }
        let _ = writeln!(
            o,
            "  structurally bounded: {}{}",
            yes_no(inv.structurally_bounded),
            if inv.uncovered_places.is_empty() {
                String::new()
            } else {
                format!(" (not covered: {})", inv.uncovered_places.join(", "))
            }
        );
        let _ = writeln!(
            o,
            "T-invariants: {}{}",
            inv.t.len(),
            if inv.t_complete {
                ""
            } else {
                " (incomplete: limit reached)"
            }
        );
        for v in &inv.t {
            let terms: Vec<String> = v
                .iter()
                .map(|(n, w)| {
                    if *w == 1 {
                        n.clone()
                    } else {
                        format!("{w}·{n}")
                    }
                })
                .collect();
            let _ = writeln!(o, "  {}", terms.join(" + "));
        }

        let c = &self.conflicts;
        let _ = writeln!(o, "\nconflicts");
        let _ = writeln!(o, "  structural: {}", c.structural.len());
        for s in &c.structural {
            let _ = writeln!(o, "    {} / {} share {}", s.a, s.b, s.places.join(", "));
        }
        match &c.effective {
            None => {
                let _ = writeln!(o, "  effective: not computed (no state space)");
            }
            Some(es) => {
                let _ = writeln!(o, "  effective: {}", es.len());
                for e in es {
                    let inputs: Vec<String> =
                        e.inputs.iter().map(|(n, v)| format!("{n}={v}")).collect();
                    let _ = writeln!(
                        o,
                        "    {} / {} on {}: both can fire{}; priority picks {}",
                        e.a,
                        e.b,
                        e.places.join(", "),
                        if inputs.is_empty() {
                            String::new()
                        } else {
                            format!(" with {}", inputs.join(" "))
                        },
                        e.winner
                    );
                }
            }
        }

        if let Some(s) = &self.sipn {
            let _ = writeln!(
                o,
                "\nPLC semantics (SIPN checks, {}{})",
                plural(s.states, "state"),
                if s.complete { "" } else { ", incomplete" }
            );
            let _ = writeln!(
                o,
                "  safe under PLC scans:   {}",
                yes_no(s.unsafe_places.is_empty())
            );
            for (p, _) in &s.unsafe_places {
                let _ = writeln!(o, "    {p} can hold more than one token");
            }
            let _ = writeln!(
                o,
                "  stable for all inputs:  {}",
                yes_no(s.unstable.is_empty())
            );
            for u in &s.unstable {
                let inputs: Vec<String> =
                    u.inputs.iter().map(|(n, v)| format!("{n}={v}")).collect();
                let _ = writeln!(
                    o,
                    "    with {} the firings {} repeat forever",
                    inputs.join(" "),
                    u.cycle.join(" ")
                );
            }
            let _ = writeln!(
                o,
                "  contradictory outputs:  impossible (an output is the OR of its places)"
            );
        }
        if let Some(cl) = &self.closed_loop {
            let timing = match cl.period {
                Some(p) => format!(
                    "timed at a {} scan period: controller timers exact, plant delays and deadlines kept",
                    petriplc_net::time::format_iec(p).trim_start_matches("T#")
                ),
                None => "every timing: any scan period, plant delays ignored".to_string(),
            };
            let _ = writeln!(o, "\nclosed loop with plant {} ({timing})", cl.plant);
            let _ = writeln!(
                o,
                "  {}, {}{}, {:.2} s",
                plural(cl.states, "state"),
                plural(cl.edges, "edge"),
                if cl.complete {
                    ""
                } else {
                    " (search stopped early)"
                },
                cl.seconds
            );
            if cl.time_locks > 0 {
                let _ = writeln!(
                    o,
                    "  {} where a plant deadline is due and no move can meet it (time locks): check the plant's delays and deadlines",
                    plural(cl.time_locks, "state")
                );
            }
            for n in &cl.places {
                never_text(&mut o, n, cl.period.is_some());
            }
            if cl.places.iter().any(|n| matches!(n.verdict, Never::Proved)) {
                let _ = writeln!(
                    o,
                    "  {}",
                    if cl.period.is_some() {
                        "(proved: never marked at this scan period, for every plant timing its delays\n  \
                         and deadlines allow and every value of the free inputs)"
                    } else {
                        "(proved: never marked for every scan period, every timing of the plant and\n  \
                         every value of the free inputs)"
                    }
                );
            }
        }
        o
    }
}

/// The `--never` verdict for people, saying which abstraction it is about
/// (docs/analysis-plc.md, section 5): `timed` keeps the plant's delays and deadlines at one
/// scan period; otherwise the plant's moves ignore its delays. (What `proved` covers is said
/// once, under the verdicts.)
fn never_text(o: &mut String, n: &NeverFacts, timed: bool) {
    let label = &n.label;
    let count = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    let _ = match &n.verdict {
        Never::Proved => writeln!(o, "  never {label}: proved, never marked"),
        Never::Unknown => writeln!(
            o,
            "  never {label}: unknown, the search stopped after {} (raise --max-states);\n  \
             nothing is proved",
            plural(n.states, "state")
        ),
        Never::Reached { steps, .. } if steps.is_empty() => writeln!(
            o,
            "  never {label}: VIOLATED, marked from the start, in the initial marking, before\n  \
             any scan or plant move: there is nothing to replay"
        ),
        Never::Reached {
            steps,
            timeline,
            scans,
            plant_moves,
            replays,
        } => {
            let _ = writeln!(
                o,
                "  never {label}: VIOLATED, marked after {} and {}:\n    {}",
                count(*scans, "controller scan"),
                count(*plant_moves, "plant move"),
                steps.join("\n    ")
            );
            if *plant_moves > 0 && !timed {
                let _ = writeln!(
                    o,
                    "  The plant's moves here ignore its delays: if this run needs the plant to be\n  \
                     faster than its delays allow, the real loop never takes it (--period keeps them)."
                );
            }
            if !replays {
                let _ = writeln!(
                    o,
                    "  The controller's own delays do not allow this run at the scan period either:\n  \
                     a replay in `petriplc sim` takes longer."
                );
            }
            writeln!(
                o,
                "  Replay the controller's side with this timeline (petriplc sim --inputs):\n{timeline}"
            )
        }
    };
}

/// `1 state`, `25 states`.
fn plural(n: u64, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}
