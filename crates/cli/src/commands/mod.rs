//! One module per subcommand; `run` dispatches. `read_net` is how every command reads the
//! net it is given.

mod analyze;
mod check;
mod compile;
mod run;
mod sim;
mod step_through;
#[cfg(feature = "opcua")]
mod user;

use std::path::Path;

use petriplc_net::Net;
use petriplc_pnml::{Naming, ReadOptions};

use crate::args::{Cli, Command, Names};
use crate::failure::{BadInputExt, Failure};

pub fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Sim(args) => sim::run(args),
        Command::Check(args) => check::run(args),
        Command::Analyze(args) => analyze::run(args),
        Command::Compile(args) => compile::run(args),
        Command::Run(args) => run::run(args),
        Command::Status(args) => run::status(args),
        Command::Stop(args) => run::stop(args),
        #[cfg(feature = "opcua")]
        Command::User(args) => user::run(args),
        #[cfg(not(feature = "opcua"))]
        Command::User(_) => Err(Failure::BadInput(anyhow::anyhow!(
            "`petriplc user` edits the users file of an OPC UA server, and this petriplc was \
             built without its `opcua` feature; rebuild with `cargo build --release -p \
             petriplc --features opcua` (it is in the default build)"
        ))),
    }
}

/// A net read as `names` says.
fn read_net(path: &Path, names: Names) -> Result<Net, Failure> {
    let naming = match names {
        Names::Plain => Naming::Plain,
        Names::Sipn => Naming::Sipn,
    };
    Ok(petriplc_pnml::read_file(path, &ReadOptions { naming })
        .bad_input()?
        .net)
}

/// `did you mean --names sipn?` when `net`, read from `path` with plain names, has no
/// signals, but read with the SIPN convention it has inputs that `given` (a timeline's
/// columns, a plant's outputs, described by `by`) provides.
fn sipn_hint(path: &Path, names: Names, net: &Net, given: &[String], by: &str) -> Option<String> {
    if names != Names::Plain || !net.signals().is_empty() || given.is_empty() {
        return None;
    }
    let options = ReadOptions {
        naming: Naming::Sipn,
    };
    let sipn = petriplc_pnml::read_file(path, &options).ok()?.net;
    let matching: Vec<&str> = sipn
        .inputs()
        .map(|s| sipn.signal(s).name.as_str())
        .filter(|name| given.iter().any(|g| g == name))
        .collect();
    (!matching.is_empty()).then(|| {
        format!(
            "did you mean --names sipn? Read with plain names, {} has no inputs; read with \
             --names sipn (a place's name is its output, a transition's its input condition), \
             it has inputs {} that {by} provides",
            path.display(),
            matching.join(", ")
        )
    })
}
