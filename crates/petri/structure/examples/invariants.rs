//! Prints invariant counts and timings for PNML files: `invariants [MAX_ROWS MAX_WORK] FILE…`.

use std::time::Instant;

use petriplc_pnml::{read_file, ReadOptions};
use petriplc_structure::{p_invariants, structurally_bounded, t_invariants, Limits};

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut limits = Limits::default();
    if args.len() > 2 && args[0].parse::<usize>().is_ok() {
        limits.max_rows = args.remove(0).parse().unwrap();
        limits.max_work = args.remove(0).parse().unwrap();
    }
    for path in args {
        let net = read_file(path.as_ref(), &ReadOptions::default())
            .unwrap()
            .net;
        let start = Instant::now();
        let p = p_invariants(&net, limits);
        let tp = start.elapsed();
        let start = Instant::now();
        let t = t_invariants(&net, limits);
        let tt = start.elapsed();
        println!(
            "{path}: P {} {} {:?} | T {} {} {:?} | bounded {}",
            p.vectors.len(),
            p.complete,
            tp,
            t.vectors.len(),
            t.complete,
            tt,
            structurally_bounded(&net, &p)
        );
    }
}
