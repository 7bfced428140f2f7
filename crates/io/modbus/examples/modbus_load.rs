//! A Modbus TCP load generator for bench/modbus.sh: N clients, each with its own connection,
//! send "read holding registers" requests back to back for a while; prints requests per
//! second and latency percentiles as one line of `key=value`s.
//!
//! It frames requests itself over blocking sockets (one thread per client), so the client
//! side costs the same whichever server is measured.
//!
//! Usage: modbus_load HOST:PORT CLIENTS SECONDS [REGISTERS]

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::process::ExitCode;
use std::time::{Duration, Instant};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let parsed = (|| -> Option<(SocketAddr, usize, f64, u16)> {
        Some((
            args.first()?.parse().ok()?,
            args.get(1)?.parse().ok()?,
            args.get(2)?.parse().ok()?,
            args.get(3).map_or(Some(10), |a| a.parse().ok())?,
        ))
    })();
    let Some((addr, clients, seconds, registers)) = parsed else {
        eprintln!("usage: modbus_load HOST:PORT CLIENTS SECONDS [REGISTERS (default 10)]");
        return ExitCode::from(2);
    };
    if !(1..=125).contains(&registers) || clients == 0 || seconds <= 0.0 {
        eprintln!("modbus_load: 1 to 125 registers, 1 or more clients, a positive duration");
        return ExitCode::from(2);
    }
    let duration = Duration::from_secs_f64(seconds);
    let start = Instant::now() + Duration::from_millis(200);
    let workers: Vec<_> = (0..clients)
        .map(|_| std::thread::spawn(move || client(addr, registers, start, duration)))
        .collect();
    let mut latencies = Vec::new();
    let mut failed = false;
    for w in workers {
        match w.join() {
            Ok(Ok(l)) => latencies.extend(l),
            Ok(Err(e)) => {
                eprintln!("modbus_load: {e}");
                failed = true;
            }
            Err(_) => failed = true,
        }
    }
    if failed || latencies.is_empty() {
        return ExitCode::FAILURE;
    }
    latencies.sort_unstable();
    let pct = |p: f64| {
        let i = ((latencies.len() as f64 * p).ceil() as usize).clamp(1, latencies.len()) - 1;
        latencies[i] as f64 / 1000.0
    };
    println!(
        "clients={clients} requests={} req_per_s={:.0} p50_us={:.1} p99_us={:.1} max_us={:.1}",
        latencies.len(),
        latencies.len() as f64 / seconds,
        pct(0.50),
        pct(0.99),
        pct(1.0)
    );
    ExitCode::SUCCESS
}

/// One client: requests back to back from `start` for `duration`; latencies in ns.
fn client(
    addr: SocketAddr,
    registers: u16,
    start: Instant,
    duration: Duration,
) -> Result<Vec<u64>, String> {
    let mut s = TcpStream::connect(addr).map_err(|e| format!("connect {addr}: {e}"))?;
    s.set_nodelay(true).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(5)))
        .map_err(|e| e.to_string())?;
    let mut response = vec![0u8; 9 + 2 * registers as usize];
    let mut latencies = Vec::with_capacity(1 << 16);
    std::thread::sleep(start.saturating_duration_since(Instant::now()));
    let end = start + duration;
    let mut tid: u16 = 0;
    loop {
        let t0 = Instant::now();
        if t0 >= end {
            return Ok(latencies);
        }
        tid = tid.wrapping_add(1);
        let [t1, t2] = tid.to_be_bytes();
        let [n1, n2] = registers.to_be_bytes();
        // MBAP (transaction, protocol 0, length 6, unit 1), FC 3, address 0, quantity.
        let request = [t1, t2, 0, 0, 0, 6, 1, 3, 0, 0, n1, n2];
        s.write_all(&request).map_err(|e| format!("send: {e}"))?;
        s.read_exact(&mut response)
            .map_err(|e| format!("receive: {e}"))?;
        if response[..2] != [t1, t2] || response[7] != 3 {
            return Err(format!(
                "unexpected response {:02x?} to transaction {tid}",
                &response[..9]
            ));
        }
        latencies.push(t0.elapsed().as_nanos() as u64);
    }
}
