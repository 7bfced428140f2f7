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

use std::path::Path;

use petriplc_config::{ModuleDecl, PlcConfig};
use petriplc_net::{Scanner, SignalId};
use petriplc_pnml::ReadOptions;
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

/// One `petrinet` module's net, read as that module reads it: for the modules that draw,
/// serve or show the configuration's nets (hmi, opcua_server, vitrine).
#[derive(Debug)]
pub struct ModuleNet {
    /// Its position among the configuration's `petrinet` modules.
    pub index: usize,
    /// The module's name.
    pub module: String,
    /// Its `net` setting as written, relative to the configuration file.
    pub file: String,
    pub doc: petriplc_pnml::Document,
}

/// A `petrinet` module's net that could not be read.
#[derive(Debug, thiserror::Error)]
#[error("the net of module {module} (`net = {file}`)")]
pub struct ModuleNetError {
    pub module: String,
    pub file: String,
    #[source]
    pub source: petriplc_pnml::PnmlError,
}

/// The configuration's `petrinet` modules, in declaration order.
pub fn petrinet_modules(config: &PlcConfig) -> impl Iterator<Item = &ModuleDecl> {
    config.modules.iter().filter(|m| m.kind == KIND)
}

/// The nets of the configuration's `petrinet` modules, in declaration order, each read with
/// its module's naming. A module whose `net` setting is missing or invalid is left out: it
/// reports that itself.
pub fn petrinet_nets(
    config: &PlcConfig,
    base_dir: &Path,
) -> Result<Vec<ModuleNet>, ModuleNetError> {
    let mut nets = Vec::new();
    for (index, decl) in petrinet_modules(config).enumerate() {
        let Some(file) = common::setting(decl, "net") else {
            continue;
        };
        let Ok(settings) = NetSettings::parse(decl, file) else {
            continue;
        };
        let doc = petriplc_pnml::read_file(
            &base_dir.join(&settings.file),
            &ReadOptions {
                naming: settings.naming,
            },
        )
        .map_err(|source| ModuleNetError {
            module: decl.name.clone(),
            file: file.to_string(),
            source,
        })?;
        nets.push(ModuleNet {
            index,
            module: decl.name.clone(),
            file: file.to_string(),
            doc,
        });
    }
    Ok(nets)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The nets found in `conf` (with `a.pnml`, SIPN-named, and `b.pnml` beside it), as
    /// `index module file places`, or the error.
    fn check(conf: &str, expect: &str) {
        let dir = tempfile::tempdir().unwrap();
        let pnml = |places: &str| {
            format!(
                r#"<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml"><net id="n" type="http://www.pnml.org/version-2009/grammar/ptnet"><page id="pg">{places}</page></net></pnml>"#
            )
        };
        std::fs::write(
            dir.path().join("a.pnml"),
            pnml(r#"<place id="L1"/><place id="L2"/>"#),
        )
        .unwrap();
        std::fs::write(dir.path().join("b.pnml"), pnml(r#"<place id="p"/>"#)).unwrap();
        let config = petriplc_config::parse_str(conf, "test.conf", dir.path()).unwrap();
        let got = match petrinet_nets(&config, dir.path()) {
            Ok(nets) => nets
                .iter()
                .map(|n| {
                    let net = &n.doc.net;
                    let places: Vec<&str> = net.place_ids().map(|p| net.place_label(p)).collect();
                    format!("{} {} {} {}", n.index, n.module, n.file, places.join(","))
                })
                .collect::<Vec<_>>()
                .join("; "),
            Err(e) => common::chain(&e).replace(&dir.path().display().to_string(), "DIR"),
        };
        assert_eq!(got, expect);
    }

    #[test]
    fn finds_every_petrinet_modules_net_in_declaration_order() {
        check(
            "[PLC]\nmodule second petrinet\nmodule log logger\nmodule first petrinet\n\
             [second]\nnet = b.pnml\n[first]\nnet = a.pnml\n",
            "0 second b.pnml p; 1 first a.pnml L1,L2",
        );
    }

    #[test]
    fn a_module_without_a_valid_net_setting_is_left_to_report_itself() {
        check(
            "[PLC]\nmodule bad petrinet\nmodule none petrinet\nmodule ok petrinet\n\
             [bad]\nnet = a.pnml\nnames = odd\n[ok]\nnet = b.pnml\n",
            "2 ok b.pnml p",
        );
    }

    #[test]
    fn an_unreadable_net_names_its_module_and_file() {
        check(
            "[PLC]\nmodule ctl petrinet\n[ctl]\nnet = missing.pnml\n",
            "the net of module ctl (`net = missing.pnml`): could not read `DIR/missing.pnml`: \
             no such file",
        );
    }
}
