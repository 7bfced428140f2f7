//! Why a simulation could not be set up or could not go on: one error for nets and IEC
//! programs, shared by the wiring (set-up) and the driver (run).

use std::time::Duration;

use petriplc_net::time::format_seconds;
use petriplc_net::ScanError;

use crate::plant::PlantError;

/// Why a simulation of a net or an IEC program could not be set up or could not go on.
#[derive(Clone, Debug, thiserror::Error)]
pub enum SimError {
    #[error("the scan period is 0; give a period greater than zero (e.g. 0.01 or T#10ms)")]
    ZeroPeriod,
    #[error("timeline {timeline}: column `{column}` is not an input of the controller{}; {}", plant_part(.plant), known_inputs(.known))]
    UnknownColumn {
        timeline: String,
        column: String,
        plant: Option<String>,
        known: Vec<String>,
    },
    #[error("timeline {timeline}: column `{column}` is an output of the controller; a timeline drives inputs only (the controller computes its outputs)")]
    ColumnIsOutput { timeline: String, column: String },
    #[error("`{signal}` is driven by both {first} and {second}; drop it from one of them")]
    DrivenTwice {
        signal: String,
        first: String,
        second: String,
    },
    #[error("timeline column `{column}` sets boolean input `{column}` to {value} at t={}s; write 0/1 or TRUE/FALSE, or declare the input as int", format_seconds(*time))]
    NotBoolean {
        column: String,
        time: Duration,
        value: i64,
    },
    #[error("`{name}` is not an input of this simulation; inputs: {}; check the spelling", list(.known))]
    UnknownInput { name: String, known: Vec<String> },
    #[error("`{name}` is an output of the controller; only inputs can be set")]
    SetOutput { name: String },
    #[error("boolean input `{name}` cannot be set to {value}; use 0 or 1")]
    NotBooleanValue { name: String, value: i64 },
    #[error("controller")]
    Scan {
        time: Duration,
        #[source]
        source: ScanError,
    },
    /// A value the controller cannot hold given to one of its inputs during the run (an IEC
    /// variable's range), by the timeline or the plant.
    #[error("at t={}s: {name} cannot take {value}: {why}", format_seconds(*time))]
    BadValue {
        time: Duration,
        name: String,
        value: i64,
        why: String,
    },
    /// A controller's own run-time fault other than a net's (an IEC program's, with its POU,
    /// line and values), whole in the message.
    #[error("at t={}s: {fault}", format_seconds(*time))]
    Fault {
        time: Duration,
        fault: std::sync::Arc<dyn std::error::Error + Send + Sync>,
    },
    #[error("at t={}s", format_seconds(*time))]
    Plant {
        time: Duration,
        #[source]
        source: PlantError,
    },
}

impl SimError {
    /// The simulated time of a failure during the run (`None` for set-up errors).
    pub fn time(&self) -> Option<Duration> {
        match self {
            SimError::Scan { time, .. }
            | SimError::Plant { time, .. }
            | SimError::BadValue { time, .. }
            | SimError::Fault { time, .. } => Some(*time),
            _ => None,
        }
    }
}

fn plant_part(plant: &Option<String>) -> String {
    plant
        .as_ref()
        .map_or(String::new(), |p| format!(" nor of plant `{p}`"))
}

fn known_inputs(names: &[String]) -> String {
    if names.is_empty() {
        "it has no inputs at all".to_string()
    } else {
        format!("known inputs: {}; check the spelling", names.join(", "))
    }
}

fn list(names: &[String]) -> String {
    if names.is_empty() {
        "(none)".to_string()
    } else {
        names.join(", ")
    }
}
