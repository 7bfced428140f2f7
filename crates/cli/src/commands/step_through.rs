//! Interactive stepwise simulation (seed 002): show the marking, the enabled transitions and
//! why the others are not; Enter runs a scan, a signal name toggles that input.

use std::io::{self, BufRead, Write};

use anyhow::Context;
use petriplc_net::time::format_seconds;
use petriplc_net::{Net, SignalDirection, SignalType};
use petriplc_sim::Simulation;

use crate::failure::{Failure, RunExt};

const HELP: &str =
    "Enter: run one scan | NAME: toggle a boolean input | NAME=VALUE: set an input | q: quit";

pub fn run(sim: &mut Simulation<'_>) -> Result<(), Failure> {
    match session(sim) {
        // The reader went away (`| head`): end quietly, as at the end of input.
        Err(Failure::Run(e))
            if e.downcast_ref::<io::Error>()
                .is_some_and(|e| e.kind() == io::ErrorKind::BrokenPipe) =>
        {
            Ok(())
        }
        other => other,
    }
}

fn session(sim: &mut Simulation<'_>) -> Result<(), Failure> {
    let stdin = io::stdin();
    let mut out = io::stdout();
    writeln!(out, "{HELP}").run_failure()?;
    show(sim, &mut out).run_failure()?;
    let mut line = String::new();
    loop {
        write!(out, "> ").and_then(|()| out.flush()).run_failure()?;
        line.clear();
        if stdin
            .lock()
            .read_line(&mut line)
            .context("cannot read standard input")
            .run_failure()?
            == 0
        {
            writeln!(out).run_failure()?;
            return Ok(());
        }
        let command = line.trim();
        match command {
            "" => match sim.step().run_failure()? {
                Some(_) => show(sim, &mut out).run_failure()?,
                None => {
                    writeln!(out, "reached --until; simulation over").run_failure()?;
                    return Ok(());
                }
            },
            "q" | "quit" | "exit" => return Ok(()),
            "?" | "h" | "help" => writeln!(out, "{HELP}").run_failure()?,
            _ => match set_input(sim, command) {
                Ok(msg) => writeln!(out, "{msg}").run_failure()?,
                Err(msg) => writeln!(out, "{msg}").run_failure()?,
            },
        }
    }
}

fn set_input(sim: &mut Simulation<'_>, command: &str) -> Result<String, String> {
    let net = sim.scanner().net();
    let (name, value) = match command.split_once('=') {
        Some((n, v)) => {
            let v = v.trim();
            let value = match v.to_ascii_uppercase().as_str() {
                "TRUE" => 1,
                "FALSE" => 0,
                _ => v.parse::<i64>().map_err(|_| {
                    format!("`{v}` is not a value: write 0, 1, TRUE, FALSE or an integer")
                })?,
            };
            (n.trim(), value)
        }
        None => {
            let id = input_named(net, command)?;
            if net.signal(id).ty != SignalType::Bool {
                return Err(format!(
                    "{command} is an integer input: set it with {command}=VALUE"
                ));
            }
            (
                command,
                i64::from(sim.pending_input(command).unwrap_or(0) == 0),
            )
        }
    };
    input_named(net, name)?;
    sim.set_input(name, value).map_err(|e| e.to_string())?;
    Ok(format!("{name} := {value} (from the next scan)"))
}

fn input_named(net: &Net, name: &str) -> Result<petriplc_net::SignalId, String> {
    match net.signal_by_name(name) {
        Some(id) if net.signal(id).direction == SignalDirection::Input => Ok(id),
        _ => {
            let inputs: Vec<&str> = net.inputs().map(|s| net.signal(s).name.as_str()).collect();
            Err(format!(
                "`{name}` is not an input of this net; inputs: {}. {HELP}",
                inputs.join(", ")
            ))
        }
    }
}

fn show(sim: &Simulation<'_>, out: &mut impl Write) -> io::Result<()> {
    let scanner = sim.scanner();
    let net = scanner.net();
    let signals = sim.signals();
    let values = |dir: SignalDirection| -> String {
        net.signals()
            .iter()
            .enumerate()
            .filter(|(_, s)| s.direction == dir)
            .map(|(i, s)| format!("{}={}", s.name, signals[i]))
            .collect::<Vec<_>>()
            .join(" ")
    };
    match sim.scans() {
        0 => writeln!(
            out,
            "before the first scan (at t={}s)",
            format_seconds(sim.next_time())
        )?,
        n => writeln!(
            out,
            "after scan {n} at t={}s (next at t={}s)",
            format_seconds(sim.now()),
            format_seconds(sim.next_time())
        )?,
    }
    let marking: Vec<String> = net
        .place_ids()
        .map(|p| format!("{}={}", net.place_label(p), scanner.marking()[p]))
        .collect();
    writeln!(out, "  marking: {}", marking.join(" "))?;
    writeln!(out, "  inputs:  {}", values(SignalDirection::Input))?;
    writeln!(out, "  outputs: {}", values(SignalDirection::Output))?;
    let fired: Vec<&str> = scanner
        .fired()
        .iter()
        .map(|&t| net.transition_label(t))
        .collect();
    writeln!(
        out,
        "  fired last scan: {}",
        if fired.is_empty() {
            "-".to_string()
        } else {
            fired.join(" ")
        }
    )?;
    let preview = sim.preview_signals();
    let next = sim.next_time();
    let mut enabled = Vec::new();
    let mut blocked = Vec::new();
    for t in net.transition_ids() {
        let why = scanner.blockers(t, next, &preview);
        if why.is_empty() {
            enabled.push(net.transition_label(t));
        } else {
            let reasons: Vec<String> = why.iter().map(ToString::to_string).collect();
            blocked.push(format!(
                "    {}: {}",
                net.transition_label(t),
                reasons.join("; ")
            ));
        }
    }
    writeln!(
        out,
        "  enabled: {}",
        if enabled.is_empty() {
            "-".to_string()
        } else {
            enabled.join(" ")
        }
    )?;
    if !blocked.is_empty() {
        writeln!(out, "  blocked:")?;
        for b in blocked {
            writeln!(out, "{b}")?;
        }
    }
    Ok(())
}
