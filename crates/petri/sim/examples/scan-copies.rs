//! Scans of N copies of seed 002's mixer where one copy's input changes per scan: petriplc's
//! side of bench/scan.sh, against the C that `petriplc compile --lang c` writes for the same
//! net (bench/scan/driver.c runs it on the same schedule).
//!
//! ```text
//! scan-copies write N FILE.pnml     # the net: N mixers, inputs B1_c N2_c N3_c N1_c
//! scan-copies run FILE.pnml SCANS [reference]
//! ```
//!
//! The schedule: scan k changes one input of copy k mod N, walking every copy through its
//! cycle (B1 on, off, N2 on, off, N3 on, off, N1 on, off), at k·10 ms. `run` prints the time
//! per scan of the scan loop alone and a checksum of the final marking, which the C prints
//! too.

use std::path::Path;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use petriplc_net::guard::parse;
use petriplc_net::{
    ArcKind, ArcSpec, Net, NetBuilder, PlaceSpec, ScanOptions, Scanner, TransitionSpec,
};

const INPUTS: [&str; 4] = ["B1", "N2", "N3", "N1"];

/// Per phase: the input (an index into `INPUTS`) and its new value.
const PHASES: [(usize, i64); 8] = [
    (0, 1),
    (0, 0),
    (1, 1),
    (1, 0),
    (2, 1),
    (2, 0),
    (3, 1),
    (3, 0),
];

/// N mixers: places L1 A1 V1 L2 V2 M1 V3 L3 (capacity 1, L1 marked, each driving an output),
/// transitions B1 N2 N3 N1 guarded by the input of their name.
fn mixers(n: usize) -> Net {
    let mut b = NetBuilder::new("mixers", "mixers");
    for c in 0..n {
        for p in ["L1", "A1", "V1", "L2", "V2", "M1", "V3", "L3"] {
            b.place(PlaceSpec {
                id: format!("{p}_{c}"),
                name: format!("{p}_{c}"),
                initial: u32::from(p == "L1"),
                capacity: Some(1),
                output: Some(format!("Y{p}_{c}")),
                ..Default::default()
            });
        }
        let transitions: [(&str, &[&str], &[&str]); 4] = [
            ("B1", &["L1"], &["A1", "V1", "L2"]),
            ("N2", &["V1"], &["V2", "M1"]),
            ("N3", &["V2", "M1", "A1", "L2"], &["V3", "L3"]),
            ("N1", &["V3", "L3"], &["L1"]),
        ];
        for (t, pre, post) in transitions {
            let input = format!("{t}_{c}");
            let id = format!("t{input}");
            b.transition(TransitionSpec {
                id: id.clone(),
                name: id.clone(),
                guard: parse(&input).expect("a guard"),
            });
            let arcs = pre
                .iter()
                .map(|p| (format!("{p}_{c}"), id.clone()))
                .chain(post.iter().map(|p| (id.clone(), format!("{p}_{c}"))));
            for (i, (source, target)) in arcs.enumerate() {
                b.arc(ArcSpec {
                    id: format!("{id}_a{i}"),
                    source,
                    target,
                    kind: ArcKind::Normal,
                    weight: 1,
                    delay: None,
                });
            }
        }
    }
    b.build().expect("the mixers are valid")
}

/// Runs the schedule; the time of the scan loop and the marking's checksum.
fn run(net: &Net, scans: u64, reference: bool) -> Result<(Duration, u64), String> {
    let n = (net.inputs().count() / 4).max(1) as u64;
    let opts = ScanOptions::of(net);
    let mut scanner = if reference {
        Scanner::new(net, opts)
    } else {
        Scanner::incremental(net, opts)
    };
    let ids = (0..n)
        .map(|c| {
            INPUTS
                .iter()
                .map(|i| {
                    let name = format!("{i}_{c}");
                    net.signal_by_name(&name)
                        .map(|s| s.index())
                        .ok_or(format!("the net has no input {name}"))
                })
                .collect::<Result<Vec<usize>, String>>()
        })
        .collect::<Result<Vec<_>, String>>()?;
    let mut signals = vec![0i64; net.signals().len()];
    let started = Instant::now();
    for k in 0..scans {
        let (input, value) = PHASES[((k / n) % 8) as usize];
        signals[ids[(k % n) as usize][input]] = value;
        scanner
            .scan(Duration::from_millis(10 * k), &mut signals)
            .map_err(|e| e.to_string())?;
    }
    let elapsed = started.elapsed();
    let checksum = scanner
        .marking()
        .0
        .iter()
        .enumerate()
        .fold(0u64, |h, (p, &m)| {
            h.wrapping_add(u64::from(m) * (p as u64 + 1))
        });
    Ok((elapsed, checksum))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let usage =
        "usage: scan-copies write N FILE.pnml | scan-copies run FILE.pnml SCANS [reference]";
    match args.as_slice() {
        ["write", n, file] => {
            let Ok(n) = n.parse::<usize>() else {
                eprintln!("{usage}");
                return ExitCode::from(2);
            };
            let text = petriplc_pnml::write_string(&mixers(n), None);
            if let Err(e) = std::fs::write(file, text) {
                eprintln!("scan-copies: cannot write {file}: {e}");
                return ExitCode::FAILURE;
            }
            ExitCode::SUCCESS
        }
        ["run", file, scans, rest @ ..] => {
            let net = match petriplc_pnml::read_file(Path::new(file), &Default::default()) {
                Ok(d) => d.net,
                Err(e) => {
                    eprintln!("{e}");
                    return ExitCode::from(2);
                }
            };
            let Ok(scans) = scans.parse::<u64>() else {
                eprintln!("{usage}");
                return ExitCode::from(2);
            };
            match run(&net, scans, rest.first() == Some(&"reference")) {
                Ok((elapsed, checksum)) => {
                    println!(
                        "scans={scans} ns_per_scan={:.1} checksum={checksum}",
                        elapsed.as_nanos() as f64 / scans.max(1) as f64
                    );
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("scan-copies: {e}");
                    ExitCode::FAILURE
                }
            }
        }
        _ => {
            eprintln!("{usage}");
            ExitCode::from(2)
        }
    }
}
