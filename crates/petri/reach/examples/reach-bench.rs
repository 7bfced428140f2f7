//! Explores a PNML net's state space without keeping the graph and prints states, edges and
//! seconds: petriplc's side of bench/statespace.sh.
//!
//! `cargo run --release -p petriplc-reach --example reach-bench -- MODEL.pnml [THREADS]`

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use petriplc_reach::{explore, ExploreOptions};

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let Some(path) = args.next().map(PathBuf::from) else {
        eprintln!("usage: reach-bench MODEL.pnml [THREADS]");
        return ExitCode::from(2);
    };
    let threads = args.next().map_or(0, |t| t.parse().unwrap_or(0));
    let doc = match petriplc_pnml::read_file(&path, &Default::default()) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let opts = ExploreOptions {
        threads,
        ..Default::default()
    };
    let start = Instant::now();
    match explore(&doc.net, &opts) {
        Ok(space) => {
            let s = start.elapsed().as_secs_f64();
            println!(
                "states {} edges {} time {:.3} s  => {:.0} states/s, {:.0} edges/s",
                space.states(),
                space.edges(),
                s,
                space.states() as f64 / s,
                space.edges() as f64 / s
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}
