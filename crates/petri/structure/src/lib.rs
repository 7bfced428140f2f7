//! Structural analysis of petriplc nets: minimal P- and T-invariants with the conservation
//! laws and bounds they give, structural and effective conflicts, and exact satisfiability
//! of guards over input signals.
//!
//! Everything here reads the [`Net`](petriplc_net::Net) only; results are vectors in a
//! deterministic order (docs/ARCHITECTURE.md: no hash order in results).

pub mod conflicts;
pub mod invariants;
pub mod satisfy;

#[cfg(test)]
mod testnet;

pub use conflicts::{
    effective_conflicts, structural_conflicts, ConflictCheck, EffectiveConflict, StructuralConflict,
};
pub use invariants::{
    conservation_laws, covered_places, p_invariants, structural_bounds, structurally_bounded,
    t_invariants, Invariants, Limits,
};
pub use satisfy::{input_condition, satisfiable};
