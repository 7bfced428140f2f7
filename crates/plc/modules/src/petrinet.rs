//! `petrinet`: a PNML net scanned once per PLC scan with the core's semantics, its input
//! signals read from points and its output signals written to the points it owns.
//!
//! ```text
//! [ctl]
//! net = mixer.pnml          # relative to the configuration file
//! names = sipn              # plain (default) or sipn
//! step = maximal-step       # or sequential; default: the net's own
//! evolve = one-pass         # or until-stable; default: the net's own
//! max_passes = 1000         # until-stable's bound
//! map B1 START_BUTTON       # signal B1 is point START_BUTTON (default: a point named B1)
//! ```

use petriplc_config::ModuleDecl;
use petriplc_net::{Scanner, SignalId};
use petriplc_runtime::module::{Control, InitContext, Module, ModuleError, ScanContext};

use crate::common::{self, at, error, Bound, NetSettings, Port, NET_OPTIONS};

const KIND: &str = "petrinet";

pub(crate) fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(Petrinet::new(decl)?))
}

/// The `petrinet` module.
pub struct Petrinet {
    name: String,
    settings: NetSettings,
    run: Option<Run>,
}

/// What `init` sets up.
struct Run {
    scanner: Scanner<'static>,
    /// Indexed by the net's `SignalId`s, as `Scanner::scan` wants them.
    signals: Vec<i64>,
    inputs: Vec<(SignalId, Bound)>,
    outputs: Vec<(SignalId, Bound)>,
    /// How often each transition has fired since the start, for `status`.
    fired: Vec<u64>,
    /// Whether the outputs were written once (later scans write them when they change).
    written: bool,
}

impl Petrinet {
    /// Checks the settings; the net is read by `init`.
    pub fn new(decl: &ModuleDecl) -> Result<Petrinet, ModuleError> {
        let known: Vec<&str> = ["net"].iter().chain(NET_OPTIONS).copied().collect();
        common::check_decl(decl, KIND, &known)?;
        let file = common::require(decl, "net")?;
        Ok(Petrinet {
            name: decl.name.clone(),
            settings: NetSettings::parse(decl, file)?,
            run: None,
        })
    }
}

impl Module for Petrinet {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        let net = self.settings.load(&self.name, ctx.base_dir)?;
        let ports = |ids: Vec<SignalId>| -> Vec<Port> {
            ids.iter()
                .map(|&s| Port {
                    name: net.signal(s).name.clone(),
                    ty: net.signal(s).ty,
                    scale: None,
                })
                .collect()
        };
        let (in_ids, out_ids): (Vec<SignalId>, Vec<SignalId>) =
            (net.inputs().collect(), net.outputs().collect());
        let what = format!("net `{}`", self.settings.file);
        let (ins, outs) = common::bind(
            ctx,
            KIND,
            &what,
            &ports(in_ids.clone()),
            &ports(out_ids.clone()),
        )?;
        self.run = Some(Run {
            // Only what changed is evaluated; the scans are those of the reference evaluator.
            scanner: Scanner::incremental(net, self.settings.options(net)),
            signals: vec![0; net.signals().len()],
            inputs: in_ids.into_iter().zip(ins).collect(),
            outputs: out_ids.into_iter().zip(outs).collect(),
            fired: vec![0; net.transitions().len()],
            written: false,
        });
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let Some(run) = &mut self.run else {
            return Err(error(&self.name, "scanned before init"));
        };
        for (s, b) in &run.inputs {
            run.signals[s.index()] = b.read(ctx.map);
        }
        run.scanner
            .scan(ctx.now, &mut run.signals)
            .map_err(|e| error(&self.name, format!("net `{}`: {e}", self.settings.file)))?;
        for t in run.scanner.fired() {
            run.fired[t.index()] += 1;
        }
        if run.written && !run.scanner.outputs_changed() {
            return Ok(Control::Continue);
        }
        run.written = true;
        for (s, b) in &run.outputs {
            let v = run.signals[s.index()];
            b.write(ctx.map, v).map_err(|e| {
                error(
                    &self.name,
                    format!("{}: output signal `{}` = {v}: {e}", at(ctx.now), b.signal),
                )
            })?;
        }
        Ok(Control::Continue)
    }

    /// The marking (`place=tokens` for every marked place), then how often each transition
    /// has fired: `marking L1=1; fired B1:3 N2:3 N3:3 N1:3`.
    fn default_scan_period(&self) -> Option<std::time::Duration> {
        Some(crate::common::DEFAULT_PERIOD)
    }

    fn status(&self) -> String {
        let Some(run) = &self.run else {
            return String::new();
        };
        let net = run.scanner.net();
        let m = run.scanner.marking();
        let marking = net
            .place_ids()
            .filter(|&p| m[p] > 0)
            .map(|p| format!("{}={}", net.place_label(p), m[p]))
            .collect::<Vec<_>>()
            .join(" ");
        let fired = net
            .transition_ids()
            .map(|t| format!("{}:{}", net.transition_label(t), run.fired[t.index()]))
            .collect::<Vec<_>>()
            .join(" ");
        format!("marking {marking}; fired {fired}")
    }

    fn marking(&self) -> Vec<(String, u64)> {
        let Some(run) = &self.run else {
            return Vec::new();
        };
        let net = run.scanner.net();
        let m = run.scanner.marking();
        net.place_ids()
            .map(|p| (net.place_label(p).to_string(), u64::from(m[p])))
            .collect()
    }
}
