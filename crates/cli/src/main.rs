//! The `petriplc` command line: parses arguments, runs one command, maps failures to exit
//! codes (2 for bad input, 1 for a failure while running).

mod args;
mod commands;
mod diagnostics;
mod failure;
mod heap;
mod log_queue;
mod logging;
mod output;
mod panic;

use std::process::ExitCode;

use clap::Parser;
use petriplc_pnml::PnmlError;

fn main() -> ExitCode {
    let cli = args::Cli::parse();
    if !matches!(cli.command, args::Command::Run(_)) {
        panic::exit_on_panic();
        panic::test_hook();
    }
    match panic::catch(|| commands::run(cli)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            report(failure.error());
            ExitCode::from(failure.exit_code())
        }
    }
}

/// Prints an error for a person: file diagnostics one per line, compiler style (at most
/// [`petriplc_diag::cap::MAX_PRINTED`], then their count), then a closing line; anything else as
/// `error: ` and its chain of causes.
fn report(error: &anyhow::Error) {
    match error
        .downcast_ref::<PnmlError>()
        .map(PnmlError::diagnostics)
    {
        Some(diagnostics) if !diagnostics.is_empty() => {
            let lines: Vec<String> = diagnostics.iter().map(ToString::to_string).collect();
            let n = diagnostics.len();
            let file = &diagnostics[0].span.file;
            diagnostics::eprint(&format!(
                "{}\nerror: {file} is not a valid net ({n} problem{}); nothing was run",
                lines.join("\n"),
                if n == 1 { "" } else { "s" }
            ));
        }
        _ => match error.downcast_ref::<petriplc_iec::IecError>() {
            Some(petriplc_iec::IecError::Invalid(lines)) => {
                let n = lines.lines().filter(|l| l.contains(": error[")).count();
                diagnostics::eprint(&format!(
                    "{lines}\nerror: {n} problem{} found; nothing was run",
                    if n == 1 { "" } else { "s" }
                ));
            }
            _ => diagnostics::eprint(&format!("error: {error:#}")),
        },
    }
}
