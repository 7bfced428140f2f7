//! The synchronisation Petri net of seed 000's synch library: the net a configuration
//! describes (the advanced `place`/`transition`/`arc` form and the simple `synch` /
//! `synch_start` form expanded into the same net), its firing rule on a marking, and
//! ([`SharedSynch`]) the marking in POSIX shared memory on which the modules of every
//! process fire transitions.
//!
//! # Semantics
//!
//! * `place P [N]`: a place with `N` initial tokens (0 when absent).
//! * `arc P -W-> T` (place → transition), `W ≥ 1`: `T` needs at least `W` tokens in `P` and
//!   takes `W` of them when it fires.
//! * `arc P -0-> T`: `T` needs `P` **empty**, and takes nothing from it.
//! * `arc T -W-> P` (transition → place), `W ≥ 1`: firing `T` adds `W` tokens to `P`.
//!   Weight 0 is only allowed from a place to a transition.
//! * A transition is also disabled when firing it would push a place past `u32::MAX`
//!   tokens: the net blocks rather than silently losing tokens.
//! * `NULL` is the null transition: synchronising on it returns at once. A module's
//!   `scan_beg` / `scan_end` default to `NULL`.
//! * The seed's modified semantics: a transition fires only when a module waits on it
//!   ([`SharedSynch::synch`]), once per wait, atomically across processes.
//!
//! # The simple form
//!
//! Every module named in a `synch` rule gets two transitions, `<module>:beg` (its
//! `scan_beg`) and `<module>:end` (its `scan_end`); user transition names cannot contain
//! `:`, so these never clash. Each rule `synch A -N-> B` becomes a place `A->B` (user
//! place names cannot contain `->`) with the arcs
//!
//! ```text
//! A:end -N-> A->B        each scan of A lets B make N scans
//! A->B  ->   B:beg       each scan of B takes one token
//! ```
//!
//! so, as seed 000's example config says, `synch Chaser --2--> vitrine` makes the vitrine
//! run two scans whenever the Chaser ends one. A module with several incoming rules waits
//! for a token from *each* of them (an AND join: `synch a -> c` and `synch b -> c` run `c`
//! once after both `a` and `b` have ended a scan). `synch_start B` puts one token — what
//! `B:beg` takes — in every place feeding `B:beg`, so B's first scan may start at once; a
//! module in `synch_start` with no incoming rule needs nothing (its `beg` has no inputs),
//! and one named in no rule at all keeps `NULL` for both.
//! A module named in a `synch` rule must not also set `scan_beg` or `scan_end`.

#![allow(unsafe_code)]

mod reach;
mod shared;

pub use shared::{Abandoned, Fired, SharedSynch, Stopped};

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;

use petriplc_config::{ModuleDecl, Origin, PlcConfig};

/// The reserved name of the null transition.
pub const NULL_TRANSITION: &str = "NULL";

/// A transition a module synchronises on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TransitionRef {
    /// The null transition: returns at once.
    Null,
    /// An index into [`SynchNet::transitions`].
    Index(usize),
}

/// A synchronised module's transitions and its scan slot in the shared marking (which says
/// whether it is inside a scan), from [`SynchNet::scan_ref`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ScanRef {
    pub slot: usize,
    pub beg: TransitionRef,
    pub end: TransitionRef,
}

/// A place and its initial tokens.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Place {
    pub name: String,
    pub tokens: u32,
    pub origin: Origin,
}

/// A transition with its input and output arcs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Transition {
    pub name: String,
    pub origin: Origin,
    /// `(place, weight)`: weight 0 means "only while the place is empty".
    pub inputs: Vec<(usize, u32)>,
    /// `(place, weight)`, weight ≥ 1.
    pub outputs: Vec<(usize, u32)>,
}

/// Which way an arc goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArcDirection {
    PlaceToTransition,
    TransitionToPlace,
}

/// An arc, kept in declaration order for [`SynchNet::describe`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Arc {
    pub place: usize,
    pub transition: usize,
    pub direction: ArcDirection,
    pub weight: u32,
    pub origin: Origin,
}

/// Why a configuration's synchronisation net, or its shared memory, cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum SynchError {
    #[error("{origin}: {message}")]
    Config { origin: Origin, message: String },
    #[error("invalid plc id `{plc_id}`: {reason}")]
    BadPlcId { plc_id: String, reason: String },
    #[error(
        "shared memory `{shm}` already exists although this process owns the PLC id: \
         something other than `petriplc run` made it"
    )]
    Exists { shm: String },
    #[error("shared memory `{shm}` does not exist: start the PLC first")]
    NotRunning { shm: String },
    #[error("shared memory `{shm}` holds a different synchronisation net: {reason}")]
    Mismatch { shm: String, reason: String },
    #[error("{what} `{shm}`: {source}")]
    Os {
        what: &'static str,
        shm: String,
        #[source]
        source: std::io::Error,
    },
}

fn config_error(origin: &Origin, message: String) -> SynchError {
    SynchError::Config {
        origin: origin.clone(),
        message,
    }
}

/// The synchronisation net of a configuration, and the transitions of each module's
/// `scan_beg` and `scan_end`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SynchNet {
    places: Vec<Place>,
    transitions: Vec<Transition>,
    arcs: Vec<Arc>,
    /// Module name → (scan_beg, scan_end), in configuration order.
    scans: Vec<(String, TransitionRef, TransitionRef)>,
}

/// What a name of the advanced form refers to.
#[derive(Clone, Copy)]
enum Node {
    Place(usize),
    Transition(usize),
}

impl SynchNet {
    /// Builds the net of `config`: its places, transitions and arcs, then the expansion of
    /// its `synch` rules and `synch_start` (see the module documentation), then each
    /// module's `scan_beg` / `scan_end`.
    pub fn from_config(config: &PlcConfig) -> Result<SynchNet, SynchError> {
        let decl = &config.synch;
        let mut net = SynchNet {
            places: Vec::new(),
            transitions: Vec::new(),
            arcs: Vec::new(),
            scans: Vec::new(),
        };
        // Places and transitions share one namespace so that an arc's ends are never
        // ambiguous.
        let mut names: HashMap<String, (Node, Origin)> = HashMap::new();

        for place in &decl.places {
            check_user_name(&place.name, &place.origin, "place")?;
            if place.name.contains("->") {
                return Err(config_error(
                    &place.origin,
                    format!(
                        "place name `{}` contains `->`, which is reserved for the places of \
                         `synch` rules",
                        place.name
                    ),
                ));
            }
            declare(
                &mut names,
                &place.name,
                Node::Place(net.places.len()),
                &place.origin,
            )?;
            net.places.push(Place {
                name: place.name.clone(),
                tokens: place.tokens,
                origin: place.origin.clone(),
            });
        }
        for (name, origin) in &decl.transitions {
            check_user_name(name, origin, "transition")?;
            if name.contains(':') {
                return Err(config_error(
                    origin,
                    format!(
                        "transition name `{name}` contains `:`, which is reserved for the \
                         `<module>:beg` / `<module>:end` transitions of `synch` rules"
                    ),
                ));
            }
            declare(
                &mut names,
                name,
                Node::Transition(net.transitions.len()),
                origin,
            )?;
            net.push_transition(name, origin);
        }
        for arc in &decl.arcs {
            let lookup = |name: &str| -> Result<Node, SynchError> {
                if name == NULL_TRANSITION {
                    return Err(config_error(
                        &arc.origin,
                        format!(
                            "arc `{} -> {}`: the NULL transition cannot have arcs",
                            arc.from, arc.to
                        ),
                    ));
                }
                names.get(name).map(|(node, _)| *node).ok_or_else(|| {
                    config_error(
                        &arc.origin,
                        format!(
                            "arc `{} -> {}`: `{name}` is neither a place nor a transition",
                            arc.from, arc.to
                        ),
                    )
                })
            };
            let (place, transition, direction) = match (lookup(&arc.from)?, lookup(&arc.to)?) {
                (Node::Place(p), Node::Transition(t)) => (p, t, ArcDirection::PlaceToTransition),
                (Node::Transition(t), Node::Place(p)) => t_p(p, t, arc.weight, arc)?,
                (Node::Place(_), Node::Place(_)) => {
                    return Err(config_error(
                        &arc.origin,
                        format!(
                            "arc `{} -> {}` joins two places: an arc goes from a place to a \
                             transition or from a transition to a place",
                            arc.from, arc.to
                        ),
                    ))
                }
                (Node::Transition(_), Node::Transition(_)) => {
                    return Err(config_error(
                        &arc.origin,
                        format!(
                            "arc `{} -> {}` joins two transitions: an arc goes from a place \
                             to a transition or from a transition to a place",
                            arc.from, arc.to
                        ),
                    ))
                }
            };
            net.add_arc(place, transition, direction, arc.weight, &arc.origin)?;
        }

        net.expand_rules(config)?;
        net.resolve_scans(config)?;
        Ok(net)
    }

    fn push_transition(&mut self, name: &str, origin: &Origin) -> usize {
        self.transitions.push(Transition {
            name: name.to_string(),
            origin: origin.clone(),
            inputs: Vec::new(),
            outputs: Vec::new(),
        });
        self.transitions.len() - 1
    }

    fn add_arc(
        &mut self,
        place: usize,
        transition: usize,
        direction: ArcDirection,
        weight: u32,
        origin: &Origin,
    ) -> Result<(), SynchError> {
        // Two arcs between the same place and transition in the same direction would leave
        // it unclear whether their weights add up or one replaces the other.
        if let Some(earlier) = self
            .arcs
            .iter()
            .find(|a| a.place == place && a.transition == transition && a.direction == direction)
        {
            let (from, to) = self.arc_ends(place, transition, direction);
            return Err(config_error(
                origin,
                format!(
                    "a second arc from `{from}` to `{to}` (the first is at {})",
                    earlier.origin
                ),
            ));
        }
        let t = &mut self.transitions[transition];
        match direction {
            ArcDirection::PlaceToTransition => t.inputs.push((place, weight)),
            ArcDirection::TransitionToPlace => t.outputs.push((place, weight)),
        }
        self.arcs.push(Arc {
            place,
            transition,
            direction,
            weight,
            origin: origin.clone(),
        });
        Ok(())
    }

    fn arc_ends(&self, place: usize, transition: usize, direction: ArcDirection) -> (&str, &str) {
        let p = self.places[place].name.as_str();
        let t = self.transitions[transition].name.as_str();
        match direction {
            ArcDirection::PlaceToTransition => (p, t),
            ArcDirection::TransitionToPlace => (t, p),
        }
    }

    fn expand_rules(&mut self, config: &PlcConfig) -> Result<(), SynchError> {
        let decl = &config.synch;
        // Module → (beg, end) transition indices, created on first mention.
        let mut module_transitions: HashMap<&str, (usize, usize)> = HashMap::new();
        let mut rule_places: HashMap<String, Origin> = HashMap::new();
        for rule in &decl.rules {
            if rule.weight == 0 {
                return Err(config_error(
                    &rule.origin,
                    format!(
                        "`synch {} -0-> {}`: a synch rule's weight must be at least 1",
                        rule.from, rule.to
                    ),
                ));
            }
            let mut ends = [0usize; 2];
            for (slot, module) in [rule.from.as_str(), rule.to.as_str()].iter().enumerate() {
                let decl = find_module(config, module).ok_or_else(|| {
                    config_error(
                        &rule.origin,
                        format!(
                            "`synch {} -> {}` names module `{module}`, which no `module` \
                             line declares",
                            rule.from, rule.to
                        ),
                    )
                })?;
                if decl.scan_beg.is_some() || decl.scan_end.is_some() {
                    let which = if decl.scan_beg.is_some() {
                        "scan_beg"
                    } else {
                        "scan_end"
                    };
                    let at = decl.settings.get(which).map_or(&decl.origin, |s| &s.origin);
                    return Err(config_error(
                        &rule.origin,
                        format!(
                            "module `{module}` is in a `synch` rule and also sets `{which}` \
                             (at {at}): use either the simple form or scan_beg/scan_end"
                        ),
                    ));
                }
                let (beg, end) = match module_transitions.get(module) {
                    Some(pair) => *pair,
                    None => {
                        let beg = self.push_transition(&format!("{module}:beg"), &rule.origin);
                        let end = self.push_transition(&format!("{module}:end"), &rule.origin);
                        module_transitions.insert(module, (beg, end));
                        (beg, end)
                    }
                };
                ends[slot] = if slot == 0 { end } else { beg };
            }
            let name = format!("{}->{}", rule.from, rule.to);
            if let Some(first) = rule_places.get(&name) {
                return Err(config_error(
                    &rule.origin,
                    format!(
                        "`synch {} -> {}` is written twice (first at {first})",
                        rule.from, rule.to
                    ),
                ));
            }
            rule_places.insert(name.clone(), rule.origin.clone());
            let place = self.places.len();
            self.places.push(Place {
                name,
                tokens: 0,
                origin: rule.origin.clone(),
            });
            self.add_arc(
                place,
                ends[0],
                ArcDirection::TransitionToPlace,
                rule.weight,
                &rule.origin,
            )?;
            self.add_arc(
                place,
                ends[1],
                ArcDirection::PlaceToTransition,
                1,
                &rule.origin,
            )?;
        }
        for (module, origin) in &decl.starts {
            if find_module(config, module).is_none() {
                return Err(config_error(
                    origin,
                    format!("`synch_start {module}`: no `module` line declares `{module}`"),
                ));
            }
            let Some(&(beg, _)) = module_transitions.get(module.as_str()) else {
                continue;
            };
            for &(place, weight) in &self.transitions[beg].inputs {
                self.places[place].tokens = weight;
            }
        }
        self.scans = config
            .modules
            .iter()
            .filter_map(|m| {
                module_transitions.get(m.name.as_str()).map(|&(b, e)| {
                    (
                        m.name.clone(),
                        TransitionRef::Index(b),
                        TransitionRef::Index(e),
                    )
                })
            })
            .collect();
        Ok(())
    }

    fn resolve_scans(&mut self, config: &PlcConfig) -> Result<(), SynchError> {
        for module in &config.modules {
            if self.scans.iter().any(|(name, _, _)| *name == module.name) {
                continue;
            }
            let beg = self.module_transition(module, "scan_beg", module.scan_beg.as_deref())?;
            let end = self.module_transition(module, "scan_end", module.scan_end.as_deref())?;
            if beg != TransitionRef::Null || end != TransitionRef::Null {
                self.scans.push((module.name.clone(), beg, end));
            }
        }
        // Keep configuration order whether a module came from a rule or from scan_beg.
        let order: HashMap<&str, usize> = config
            .modules
            .iter()
            .enumerate()
            .map(|(i, m)| (m.name.as_str(), i))
            .collect();
        self.scans.sort_by_key(|(name, _, _)| order[name.as_str()]);
        Ok(())
    }

    fn module_transition(
        &self,
        module: &ModuleDecl,
        setting: &str,
        name: Option<&str>,
    ) -> Result<TransitionRef, SynchError> {
        let Some(name) = name else {
            return Ok(TransitionRef::Null);
        };
        if name == NULL_TRANSITION {
            return Ok(TransitionRef::Null);
        }
        self.transition(name).ok_or_else(|| {
            let at = module
                .settings
                .get(setting)
                .map_or(&module.origin, |s| &s.origin);
            config_error(
                at,
                format!(
                    "module `{}`: {setting} = {name}, but there is no transition `{name}`",
                    module.name
                ),
            )
        })
    }

    /// The transition named `name` (`NULL` included), for modules that synchronise at
    /// other points of their scan.
    pub fn transition(&self, name: &str) -> Option<TransitionRef> {
        if name == NULL_TRANSITION {
            return Some(TransitionRef::Null);
        }
        self.transitions
            .iter()
            .position(|t| t.name == name)
            .map(TransitionRef::Index)
    }

    /// The transition `module` synchronises on before each scan: `NULL` for a module
    /// without one (or one the configuration does not declare).
    pub fn scan_beg(&self, module: &str) -> TransitionRef {
        self.scans
            .iter()
            .find(|(name, _, _)| name == module)
            .map_or(TransitionRef::Null, |s| s.1)
    }

    /// The transitions and scan slot of `module`, if it synchronises on anything but `NULL`.
    pub fn scan_ref(&self, module: &str) -> Option<ScanRef> {
        self.scans
            .iter()
            .position(|(name, _, _)| name == module)
            .map(|slot| ScanRef {
                slot,
                beg: self.scans[slot].1,
                end: self.scans[slot].2,
            })
    }

    /// How many modules synchronise on something but `NULL` (one scan slot each).
    pub fn scan_slots(&self) -> usize {
        self.scans.len()
    }

    /// The synchronised modules with their `scan_beg` and `scan_end`, in configuration order.
    pub fn scans(&self) -> impl Iterator<Item = (&str, TransitionRef, TransitionRef)> {
        self.scans.iter().map(|(m, b, e)| (m.as_str(), *b, *e))
    }

    /// The transition `module` synchronises on after each scan (see [`Self::scan_beg`]).
    pub fn scan_end(&self, module: &str) -> TransitionRef {
        self.scans
            .iter()
            .find(|(name, _, _)| name == module)
            .map_or(TransitionRef::Null, |s| s.2)
    }

    pub fn places(&self) -> &[Place] {
        &self.places
    }

    pub fn transitions(&self) -> &[Transition] {
        &self.transitions
    }

    pub fn arcs(&self) -> &[Arc] {
        &self.arcs
    }

    /// A transition's name, `NULL` included.
    pub fn transition_name(&self, t: TransitionRef) -> &str {
        match t {
            TransitionRef::Null => NULL_TRANSITION,
            TransitionRef::Index(i) => &self.transitions[i].name,
        }
    }

    /// The initial marking: each place's initial tokens.
    pub fn initial_marking(&self) -> Marking {
        Marking {
            tokens: self.places.iter().map(|p| p.tokens).collect(),
        }
    }

    /// Whether transition `t` may fire in `marking` (one entry per place). This and
    /// [`Self::fire_in`] are the one firing rule, used by [`Marking`] and by the shared
    /// marking alike.
    ///
    /// # Panics
    ///
    /// If `t` or `marking` does not belong to this net.
    pub fn enabled_in(&self, t: usize, marking: &[u32]) -> bool {
        assert_eq!(marking.len(), self.places.len(), "marking of another net");
        let transition = &self.transitions[t];
        let inputs_ok = transition.inputs.iter().all(|&(p, w)| {
            if w == 0 {
                marking[p] == 0
            } else {
                marking[p] >= w
            }
        });
        inputs_ok
            && transition.outputs.iter().all(|&(p, w)| {
                let taken = transition
                    .inputs
                    .iter()
                    .find(|&&(q, _)| q == p)
                    .map_or(0, |&(_, tw)| tw);
                (marking[p] - taken).checked_add(w).is_some()
            })
    }

    /// Fires `t` in `marking` if it is enabled (takes its input tokens, adds its output
    /// tokens) and says whether it did.
    pub fn fire_in(&self, t: usize, marking: &mut [u32]) -> bool {
        self.fire_in_with(t, marking, || {})
    }

    /// [`Self::fire_in`], calling `between` after the input tokens are taken and before the
    /// output tokens are added (where the test hook kills a firing half-way).
    pub(crate) fn fire_in_with(
        &self,
        t: usize,
        marking: &mut [u32],
        between: impl FnOnce(),
    ) -> bool {
        if !self.enabled_in(t, marking) {
            return false;
        }
        let transition = &self.transitions[t];
        for &(p, w) in &transition.inputs {
            marking[p] -= w;
        }
        between();
        for &(p, w) in &transition.outputs {
            marking[p] += w;
        }
        true
    }

    /// The net as text, with its initial marking (for `petriplc status` and tests).
    pub fn describe(&self) -> String {
        self.describe_marking(&self.initial_marking().tokens)
    }

    /// The net as text with the tokens of `marking` (e.g. [`SharedSynch::marking`]):
    /// places with tokens, transitions, arcs (`->` for weight 1, `-N->` otherwise) and
    /// each synchronised module's `scan_beg` / `scan_end`.
    pub fn describe_marking(&self, marking: &[u32]) -> String {
        let mut out = self.describe_structure(Some(marking));
        if !self.scans.is_empty() {
            out.push_str("scans:\n");
            for (module, beg, end) in &self.scans {
                let _ = writeln!(
                    out,
                    "  {module}: scan_beg = {}, scan_end = {}",
                    self.transition_name(*beg),
                    self.transition_name(*end)
                );
            }
        }
        out
    }

    fn describe_structure(&self, marking: Option<&[u32]>) -> String {
        let mut out = String::from("places:\n");
        for (i, place) in self.places.iter().enumerate() {
            let tokens = marking.map_or(place.tokens, |m| m[i]);
            let _ = writeln!(out, "  {} {tokens}", place.name);
        }
        out.push_str("transitions:\n");
        for t in &self.transitions {
            let _ = writeln!(out, "  {}", t.name);
        }
        out.push_str("arcs:\n");
        for arc in &self.arcs {
            let (from, to) = self.arc_ends(arc.place, arc.transition, arc.direction);
            let arrow = if arc.weight == 1 {
                "->".to_string()
            } else {
                format!("-{}->", arc.weight)
            };
            let _ = writeln!(out, "  {from} {arrow} {to}");
        }
        out
    }

    /// A hash of the places (with initial tokens), transitions and arcs, so that a process
    /// opening the shared marking can tell it was built from the same net.
    pub fn fingerprint(&self) -> u64 {
        // FNV-1a: stable across processes and builds, unlike std's RandomState.
        self.describe_structure(None)
            .bytes()
            .fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
                (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
            })
    }
}

/// `(transition, place)` → the arc's triple, refusing weight 0 out of a transition.
fn t_p(
    p: usize,
    t: usize,
    weight: u32,
    arc: &petriplc_config::ArcDecl,
) -> Result<(usize, usize, ArcDirection), SynchError> {
    if weight == 0 {
        return Err(config_error(
            &arc.origin,
            format!(
                "arc `{} -0-> {}`: weight 0 (\"only while empty\") is only allowed from a \
                 place to a transition",
                arc.from, arc.to
            ),
        ));
    }
    Ok((p, t, ArcDirection::TransitionToPlace))
}

fn check_user_name(name: &str, origin: &Origin, kind: &str) -> Result<(), SynchError> {
    if name.is_empty() || name.chars().any(char::is_whitespace) {
        return Err(config_error(
            origin,
            format!("invalid {kind} name `{name}`"),
        ));
    }
    if name == NULL_TRANSITION {
        return Err(config_error(
            origin,
            format!(
                "`{NULL_TRANSITION}` is reserved for the null transition and cannot name a {kind}"
            ),
        ));
    }
    Ok(())
}

fn declare(
    names: &mut HashMap<String, (Node, Origin)>,
    name: &str,
    node: Node,
    origin: &Origin,
) -> Result<(), SynchError> {
    if let Some((earlier, at)) = names.get(name) {
        let kind = match earlier {
            Node::Place(_) => "place",
            Node::Transition(_) => "transition",
        };
        return Err(config_error(
            origin,
            format!("`{name}` is already declared as a {kind} at {at}"),
        ));
    }
    names.insert(name.to_string(), (node, origin.clone()));
    Ok(())
}

fn find_module<'a>(config: &'a PlcConfig, name: &str) -> Option<&'a ModuleDecl> {
    config.modules.iter().find(|m| m.name == name)
}

/// A marking held in ordinary memory: the same firing rule as the shared marking, for
/// tests, simulation and tools.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Marking {
    tokens: Vec<u32>,
}

impl Marking {
    pub fn tokens(&self) -> &[u32] {
        &self.tokens
    }

    /// Tokens per place name.
    pub fn by_name<'a>(&self, net: &'a SynchNet) -> BTreeMap<&'a str, u32> {
        net.places
            .iter()
            .zip(&self.tokens)
            .map(|(p, &n)| (p.name.as_str(), n))
            .collect()
    }

    /// Whether `t` may fire (`NULL` always may).
    pub fn enabled(&self, net: &SynchNet, t: TransitionRef) -> bool {
        match t {
            TransitionRef::Null => true,
            TransitionRef::Index(i) => net.enabled_in(i, &self.tokens),
        }
    }

    /// Fires `t` if enabled and says whether it did (`NULL` fires without effect).
    pub fn fire(&mut self, net: &SynchNet, t: TransitionRef) -> bool {
        match t {
            TransitionRef::Null => true,
            TransitionRef::Index(i) => net.fire_in(i, &mut self.tokens),
        }
    }
}

#[cfg(test)]
mod tests;
