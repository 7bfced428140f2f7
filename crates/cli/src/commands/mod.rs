//! One module per subcommand; `run` dispatches.

mod analyze;
mod check;
mod compile;
mod run;
mod sim;
mod step_through;

use crate::args::{Cli, Command};
use crate::failure::Failure;

pub fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Sim(args) => sim::run(args),
        Command::Check(args) => check::run(args),
        Command::Analyze(args) => analyze::run(args),
        Command::Compile(args) => compile::run(args),
        Command::Run(args) => run::run(args),
        Command::Status(args) => run::status(args),
        Command::Stop(args) => run::stop(args),
    }
}
