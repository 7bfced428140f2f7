//! Times one scan of a Structured Text program on the engine, every BOOL input TRUE:
//! `cargo run --release -p petriplc-iec --example scan_time -- FILE.st SCANS REPEATS`
//! prints the median wall-clock ns per scan, the process CPU ns per scan over all runs
//! (from /proc, 10 ms resolution), the compile time in seconds (read, parse, check,
//! bytecode) and the time its machine code takes to make, even past the size limit of
//! petriplc-iec-jit (bench/iec_scan.sh compares the scan with the generated C). A fourth argument `vm` runs the bytecode VM instead
//! of the machine code.

use std::time::Instant;

use petriplc_iec::{build_file, Select};
use petriplc_iec_sema::ir::VarClass;
use petriplc_iec_sema::value::Value;
use petriplc_iec_vm::{Backend, Machine};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 && args.len() != 5 {
        eprintln!("usage: scan_time FILE.st SCANS REPEATS [vm]");
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
    // What its machine code takes to make (whatever its size).
    let t1 = Instant::now();
    let jit_ok = petriplc_iec::jit::compile_limited(&build.engine, usize::MAX).is_ok();
    let jit = t1.elapsed();
    let scans: u64 = args[2].parse().unwrap_or(1000);
    let repeats: usize = args[3].parse().unwrap_or(11);
    let engine = build.engine.clone();
    let mut m = Machine::new(engine.clone());
    if args.get(4).map(String::as_str) == Some("vm") {
        m.set_backend(Backend::Vm);
    }
    let inst = &engine.instances()[0];
    for (name, class, _) in engine.instance_vars(0) {
        if class == VarClass::Input {
            let v = engine.lookup(&format!("{}.{name}", inst.name)).unwrap();
            m.set(v, &Value::Int(1)).unwrap();
        }
    }
    let mut now = 0i64;
    let mut times = Vec::new();
    let cpu0 = cpu_ticks();
    for _ in 0..repeats {
        let t = Instant::now();
        for _ in 0..scans {
            m.scan(now, &mut || true).unwrap();
            now += 10_000_000;
        }
        times.push(t.elapsed().as_nanos() as f64 / scans as f64);
    }
    let cpu = (cpu_ticks() - cpu0) as f64 * 1e7 / (scans as f64 * repeats as f64);
    times.sort_by(|a, b| a.total_cmp(b));
    println!(
        "{:.1} {cpu:.1} {:.3} {:.3}",
        times[repeats / 2],
        compile.as_secs_f64(),
        if jit_ok { jit.as_secs_f64() } else { f64::NAN }
    );
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

/// User plus system CPU time of this process in clock ticks (1/100 s), from /proc.
fn cpu_ticks() -> u64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the command name (which may hold spaces, so cut at the last ')').
    let rest = stat.rsplit_once(')').map_or("", |r| r.1);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let n = |i: usize| f.get(i).and_then(|x| x.parse::<u64>().ok()).unwrap_or(0);
    // utime and stime are fields 14 and 15 of the line, 12 and 13 after the ')'.
    n(11) + n(12)
}
