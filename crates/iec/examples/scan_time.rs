//! Times one scan of a Structured Text program on the engine, every BOOL input TRUE:
//! `cargo run --release -p petriplc-iec --example scan_time -- FILE.st SCANS REPEATS`
//! (bench/iec_scan.sh compares it with the generated C).

use std::time::Instant;

use petriplc_iec::{build_file, Select};
use petriplc_iec_sema::ir::VarClass;
use petriplc_iec_sema::value::Value;
use petriplc_iec_vm::Machine;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 {
        eprintln!("usage: scan_time FILE.st SCANS REPEATS");
        std::process::exit(2);
    }
    let t0 = Instant::now();
    let build = match build_file(std::path::Path::new(&args[1]), &Select::Auto) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    let compile = t0.elapsed();
    let scans: u64 = args[2].parse().unwrap_or(1000);
    let repeats: usize = args[3].parse().unwrap_or(11);
    let engine = build.engine.clone();
    let mut m = Machine::new(engine.clone());
    let inst = &engine.instances()[0];
    for (name, class, _) in engine.instance_vars(0) {
        if class == VarClass::Input {
            let v = engine.lookup(&format!("{}.{name}", inst.name)).unwrap();
            m.set(v, &Value::Int(1)).unwrap();
        }
    }
    let mut now = 0i64;
    let mut times = Vec::new();
    for _ in 0..repeats {
        let t = Instant::now();
        for _ in 0..scans {
            m.scan(now, &mut || true).unwrap();
            now += 10_000_000;
        }
        times.push(t.elapsed().as_nanos() as f64 / scans as f64);
    }
    times.sort_by(|a, b| a.total_cmp(b));
    println!("{:.1} {:.3}", times[repeats / 2], compile.as_secs_f64());
    if std::env::var_os("SCAN_TIME_OPS").is_some() {
        eprintln!(
            "{} instructions, {} slots",
            engine.code.ops.len(),
            engine.code.init.len()
        );
        for op in engine.code.ops.iter().take(80) {
            eprintln!("{op:?}");
        }
    }
}
