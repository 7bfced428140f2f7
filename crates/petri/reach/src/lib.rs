//! Reachability graphs, coverability and behavioural properties of petriplc nets under the
//! interleaving semantics (docs/semantics.md §8), counted as the Model Checking Contest counts
//! them.
//!
//! - [`explore`]: breadth-first state-space exploration on all cores, with packed markings; the
//!   figures and the state numbering do not depend on the thread count or timing.
//! - [`properties`]: bounds, safeness, deadlocks with a shortest trace, quasi-liveness, and from
//!   the graph's strongly connected components liveness, reversibility, home markings.
//! - [`coverability`]: Karp–Miller with ω, for nets not known to be bounded.
//!
//! Enabling is always [`petriplc_net::TransitionArcs::allow`], the net's one rule.

mod cover;
mod explore;
mod layout;
mod props;
mod rules;
mod scc;
mod shard;
mod space;
mod sweep;
#[cfg(test)]
mod testnet;

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use petriplc_net::Net;

pub use cover::{coverability, Coverability};
pub use props::{properties, properties_with, Properties, PropertyOptions};
pub use space::{StateId, StateSpace};

/// How [`explore`] runs.
#[derive(Clone, Default)]
pub struct ExploreOptions {
    /// Stop (with [`StateSpace::complete`] false) once this many states are stored. The check
    /// runs between rounds of at most 16 384 expanded states, so a few more may be stored.
    pub max_states: Option<u64>,
    /// Stop (with [`StateSpace::complete`] false) once the states and the frontier take this
    /// many bytes, checked between rounds like `max_states`; and skip the liveness
    /// computations of [`properties_with`] that would need more.
    pub max_memory: Option<u64>,
    /// Threads to use; 0 means one per core.
    pub threads: usize,
    /// Keep the reachability graph: needed for [`StateSpace::successors`] and for liveness,
    /// reversibility and home markings.
    pub keep_graph: bool,
    /// Set to stop early (with [`StateSpace::complete`] false).
    pub cancel: Option<Arc<AtomicBool>>,
    /// Called about every 100 ms during the exploration.
    pub progress: Option<Arc<dyn Fn(Progress) + Send + Sync>>,
}

impl std::fmt::Debug for ExploreOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ExploreOptions")
            .field("max_states", &self.max_states)
            .field("max_memory", &self.max_memory)
            .field("threads", &self.threads)
            .field("keep_graph", &self.keep_graph)
            .field("cancel", &self.cancel)
            .field("progress", &self.progress.as_ref().map(|_| "Fn"))
            .finish()
    }
}

/// How far an exploration has got.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    pub states: u64,
    pub edges: u64,
    pub elapsed: Duration,
    /// Bytes the states and the frontier hold.
    pub bytes: u64,
}

/// What stopped an exploration before its end ([`StateSpace::limit`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Limit {
    /// [`ExploreOptions::max_states`].
    States(u64),
    /// [`ExploreOptions::max_memory`], in bytes.
    Memory(u64),
    /// [`ExploreOptions::cancel`] was set.
    Cancelled,
}

/// Why an exploration failed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ReachError {
    #[error("place {place}: a reachable marking has more than {} tokens, the limit of petriplc's 32-bit token counters (which says nothing about boundedness)", u32::MAX)]
    TokenOverflow { place: String },
    #[error("more than {} reachable states; petriplc numbers states with 32 bits", u32::MAX - 1)]
    TooManyStates,
}

/// Explores the reachable markings of `net` breadth-first.
///
/// Terminates on bounded nets; on an unbounded net it runs until `max_states`, a cancel or a
/// token overflow, so run [`coverability`] first when the net is not known to be bounded.
pub fn explore(net: &Net, opts: &ExploreOptions) -> Result<StateSpace, ReachError> {
    explore_with(net, opts, None)
}

/// The threads to use for a setting where 0 means every core.
pub(crate) fn threads(setting: usize) -> usize {
    match setting {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    }
}

/// [`explore`] with a borrowed cancel flag as well.
pub(crate) fn explore_with(
    net: &Net,
    opts: &ExploreOptions,
    cancel: Option<&AtomicBool>,
) -> Result<StateSpace, ReachError> {
    let engine = explore::Engine::new(net, opts, cancel);
    let threads = engine.threads();
    let mut space = engine.run_all()?;
    if opts.keep_graph {
        space.build_graph(threads);
    }
    Ok(space)
}
