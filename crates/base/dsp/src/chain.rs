//! A module's blocks in the order of its `fblock` rows, run over an array of point values:
//! MatPLC's dsp module without the PLC. [`Chain::parse`] reads the rows (every bad row is
//! reported, none panics), designs the filters, and asks a [`Points`] for each point a row
//! names; [`Chain::scan`] runs every block once, each seeing the outputs of the blocks before
//! it, as MatPLC's did.
//!
//! Values are `f64`s holding exactly what the points hold: an `f32` point's value, or a whole
//! number. A block writing a point stores what the point can hold ([`convert`]), so a later
//! block reads what the point will show.

use std::fmt::Write as _;

use crate::block::{
    convert, Add, Alarm, AntiWindup, Delay, Fir, Hysteresis, Iir, Mult, Multiplexor, Nonlinear,
    NumType, Pid, PidInput, Pow, Ramp, Source,
};
use crate::design::{Band, Family};

/// Where a point's value lives in the value array, and what the point holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slot {
    pub index: usize,
    pub ty: NumType,
}

/// How a chain finds the points its rows name.
pub trait Points {
    /// The slot of point `name`; `write` when a block writes it (the point must be one the
    /// module may write). The error says what is wrong and how to fix it.
    fn slot(&mut self, name: &str, write: bool) -> Result<Slot, String>;
}

/// What the rows are read against.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Context {
    /// The module's scan period in seconds, when it has one: designed filters and timed
    /// delays sample at its inverse.
    pub scan_period: Option<f64>,
}

/// How an IIR filter was specified, for its description.
#[derive(Clone, Debug, PartialEq)]
enum Spec {
    Coefficients,
    Tolerances {
        family: Family,
        band: Band,
        gain: f64,
        pass_db: f64,
        stop_db: f64,
        edges: Vec<f64>,
        wn: Vec<f64>,
    },
    Order {
        family: Family,
        band: Band,
        gain: f64,
        wn: Vec<f64>,
    },
}

#[derive(Clone, Debug)]
enum Run {
    Iir {
        filter: Iir,
        order: usize,
        spec: Spec,
    },
    Fir {
        filter: Fir,
        design: Option<String>,
    },
}

/// One block with the slots it reads and writes.
#[derive(Clone, Debug)]
enum Node {
    TypeConv(Vec<(Slot, Slot)>),
    Add {
        out: Slot,
        ins: Vec<Slot>,
        block: Add,
    },
    Mult {
        out: Slot,
        ins: Vec<Slot>,
        block: Mult,
    },
    Pow {
        out: Slot,
        input: Slot,
        block: Pow,
    },
    Pid {
        input: Slot,
        out: Slot,
        sp: Option<Slot>,
        mode: Option<(Slot, Slot)>,
        block: Box<Pid>,
    },
    Filter {
        input: Slot,
        out: Slot,
        run: Box<Run>,
    },
    Ramp {
        input: Slot,
        out: Slot,
        block: Ramp,
    },
    Nonlinear {
        input: Slot,
        out: Slot,
        block: Nonlinear,
    },
    Alarm {
        input: Slot,
        outs: Vec<Slot>,
        block: Alarm,
    },
    Multiplexor {
        out: Slot,
        control: Slot,
        ins: Vec<Slot>,
        block: Multiplexor,
    },
    Hysteresis {
        input: Slot,
        out: Slot,
        block: Hysteresis,
    },
    Delay {
        input: Slot,
        out: Slot,
        block: Delay,
    },
    Source {
        out: Slot,
        block: Source,
    },
}

/// The blocks MatPLC's rows name, and the three it announced.
pub const BLOCKS: &[&str] = &[
    "typeconv",
    "add",
    "mult",
    "pow",
    "pid",
    "filter",
    "ramp",
    "nonlinear",
    "alarm",
    "multiplexor",
    "hysteresis",
    "delay",
    "source",
];

/// A module's blocks, in row order.
#[derive(Clone, Debug)]
pub struct Chain {
    nodes: Vec<(String, Node)>,
    last_t: Option<f64>,
}

/// A row's problem: the index of the row and the message.
pub type RowError = (usize, String);

impl Chain {
    /// Reads `rows` (the cells after `fblock`), each a block. Every bad row is reported, with
    /// its index in `rows`.
    pub fn parse(
        rows: &[Vec<String>],
        points: &mut dyn Points,
        ctx: &Context,
    ) -> Result<Chain, Vec<RowError>> {
        let mut nodes = Vec::new();
        let mut errors = Vec::new();
        for (i, cells) in rows.iter().enumerate() {
            let mut r = rows::Row {
                cells,
                points: &mut *points,
                ctx,
            };
            match r.node() {
                Ok(node) => nodes.push((cells.first().cloned().unwrap_or_default(), node)),
                Err(e) => errors.push((i, e)),
            }
        }
        if errors.is_empty() {
            Ok(Chain {
                nodes,
                last_t: None,
            })
        } else {
            Err(errors)
        }
    }

    /// How many blocks.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// How many second-order sections the filters run.
    pub fn sections(&self) -> usize {
        self.nodes
            .iter()
            .map(|(_, n)| match n {
                Node::Filter { run, .. } => match run.as_ref() {
                    Run::Iir { filter, .. } => filter.sections().len(),
                    Run::Fir { .. } => 0,
                },
                _ => 0,
            })
            .sum()
    }

    /// Runs every block once at time `t` seconds (the module's clock): `values` holds every
    /// point's value, read before and written back after. The time since the previous scan
    /// is what PID and ramp integrate over (0 at the first scan).
    pub fn scan(&mut self, values: &mut [f64], t: f64) {
        let dt = self.last_t.map_or(0.0, |last| (t - last).max(0.0));
        self.last_t = Some(t);
        for (_, node) in &mut self.nodes {
            node.run(values, t, dt);
        }
    }

    /// One line per block; a filter's line is followed by its order and coefficients.
    pub fn describe(&self) -> Vec<String> {
        let mut lines = Vec::new();
        for (kind, node) in &self.nodes {
            match node {
                Node::Filter { run, .. } => lines.extend(describe_filter(run)),
                Node::Pid { block, .. } => {
                    let c = block.config();
                    let (kp, ki, kd) = c.gains();
                    lines.push(format!(
                        "pid: kp={kp} ki={ki} kd={kd}, output {}..{}, anti-windup {}",
                        c.min_out,
                        c.max_out,
                        match c.anti_windup {
                            AntiWindup::None => "none".to_string(),
                            AntiWindup::Clamp => "clamp".to_string(),
                            AntiWindup::BackCalculation { tt } => format!("backcalc tt={tt}"),
                        }
                    ));
                }
                _ => lines.push(kind.clone()),
            }
        }
        lines
    }

    /// Filter descriptions only (order and coefficients), for status displays and logs.
    pub fn filters(&self) -> Vec<String> {
        self.nodes
            .iter()
            .filter_map(|(_, n)| match n {
                Node::Filter { run, .. } => Some(describe_filter(run)),
                _ => None,
            })
            .flatten()
            .collect()
    }

    /// How many times a PID held its output for an input that was not a number.
    pub fn bad_inputs(&self) -> u64 {
        self.nodes
            .iter()
            .map(|(_, n)| match n {
                Node::Pid { block, .. } => block.bad_inputs(),
                _ => 0,
            })
            .sum()
    }
}

fn list(v: &[f64]) -> String {
    v.iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(" ")
}

fn describe_filter(run: &Run) -> Vec<String> {
    let mut lines = Vec::new();
    match run {
        Run::Iir {
            filter,
            order,
            spec,
        } => {
            let head = match spec {
                Spec::Coefficients => {
                    format!(
                        "filter iir: {} as given",
                        plural(filter.sections().len(), "section")
                    )
                }
                Spec::Tolerances {
                    family,
                    band,
                    gain,
                    pass_db,
                    stop_db,
                    edges,
                    wn,
                } => format!(
                    "filter {} {band}: order {order} for {pass_db}/{stop_db} dB at {} Hz \
                     (critical {} Hz), gain {gain}, {}",
                    family_name(*family),
                    list(edges),
                    list(wn),
                    plural(filter.sections().len(), "section")
                ),
                Spec::Order {
                    family,
                    band,
                    gain,
                    wn,
                } => format!(
                    "filter {} {band}: order {order} at {} Hz, gain {gain}, {}",
                    family_name(*family),
                    list(wn),
                    plural(filter.sections().len(), "section")
                ),
            };
            lines.push(head);
            for (i, s) in filter.sections().iter().enumerate() {
                lines.push(format!(
                    "  section {}: b = {} {} {}  a = {} {} {}",
                    i + 1,
                    s[0],
                    s[1],
                    s[2],
                    s[3],
                    s[4],
                    s[5]
                ));
            }
        }
        Run::Fir { filter, design } => {
            let mut head = format!("filter fir: {} taps", filter.taps().len());
            if let Some(d) = design {
                let _ = write!(head, " ({d})");
            }
            lines.push(head);
            lines.push(format!("  taps: {}", list(filter.taps())));
        }
    }
    lines
}

fn plural(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

fn family_name(f: Family) -> String {
    match f {
        Family::Bessel(n) => format!("bessel ({} norm)", n.as_str()),
        f => f.name().to_string(),
    }
}

/// Writes `y` to an output slot as the point holds it.
fn put(values: &mut [f64], slot: Slot, y: f64) {
    values[slot.index] = convert(y, slot.ty);
}

impl Node {
    fn run(&mut self, v: &mut [f64], t: f64, dt: f64) {
        match self {
            Node::TypeConv(pairs) => {
                for (i, o) in pairs.iter() {
                    put(v, *o, v[i.index]);
                }
            }
            Node::Add { out, ins, block } => {
                let y = ins
                    .iter()
                    .zip(&block.gains)
                    .fold(0.0, |s, (i, k)| s + v[i.index] * k);
                put(v, *out, y);
            }
            Node::Mult { out, ins, block } => {
                let y = ins
                    .iter()
                    .zip(&block.offsets)
                    .fold(1.0, |p, (i, o)| p * (v[i.index] + o));
                put(v, *out, y);
            }
            Node::Pow { out, input, block } => put(v, *out, block.step(v[input.index])),
            Node::Pid {
                input,
                out,
                sp,
                mode,
                block,
            } => {
                let (auto, manual) = match mode {
                    Some((m, man)) => (v[m.index] != 0.0, v[man.index]),
                    None => (true, 0.0),
                };
                let pid_in = PidInput {
                    sp: sp.map_or(0.0, |s| v[s.index]),
                    pv: v[input.index],
                    error_input: sp.is_none(),
                    auto,
                    manual,
                };
                let y = block.step(pid_in, dt);
                put(v, *out, y);
            }
            Node::Filter { input, out, run } => {
                let x = v[input.index];
                let y = match run.as_mut() {
                    Run::Iir { filter, .. } => filter.step(x),
                    Run::Fir { filter, .. } => filter.step(x),
                };
                if let Some(y) = y {
                    put(v, *out, y);
                }
            }
            Node::Ramp { input, out, block } => {
                let y = block.step(v[input.index], dt);
                put(v, *out, y);
            }
            Node::Nonlinear { input, out, block } => put(v, *out, block.step(v[input.index])),
            Node::Alarm { input, outs, block } => {
                let states = block.step(v[input.index]);
                for (o, &s) in outs.iter().zip(states) {
                    put(v, *o, f64::from(u8::from(s)));
                }
            }
            Node::Multiplexor {
                out,
                control,
                ins,
                block,
            } => {
                if let Some(k) = block.select(v[control.index]) {
                    put(v, *out, v[ins[k].index]);
                }
            }
            Node::Hysteresis { input, out, block } => {
                let s = block.step(v[input.index]);
                put(v, *out, f64::from(u8::from(s)));
            }
            Node::Delay { input, out, block } => {
                let y = block.step(v[input.index]);
                put(v, *out, y);
            }
            Node::Source { out, block } => put(v, *out, block.step(t)),
        }
    }
}

mod rows;

#[cfg(test)]
mod tests;
