//! modbus_server in the real runner (petriplc_plc::Plc, modules on threads, no scan_period
//! set): a client's write reaches another module through the process image — a coil the
//! server owns is the `shutdown` module's point, so writing it stops the PLC — and the server
//! closes with a client still connected.

mod server_support;

use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use petriplc_plc::{Plc, RunOptions};
use server_support::{adu, tcp_address, Raw, PATIENCE};

fn registry(kind: &str) -> Option<petriplc_runtime::module::Factory> {
    petriplc_modbus::builtin(kind).or_else(|| petriplc_modules::builtin(kind))
}

#[test]
fn a_client_write_stops_the_plc_through_another_module() {
    let dir = tempfile::tempdir().unwrap();
    let conf = dir.path().join("plc.conf");
    std::fs::write(
        &conf,
        "[PLC]\nmodule mb modbus_server\nmodule stop shutdown\n\
         point QUIT \"stop the PLC\" mb\npoint H \"a register\" mb u16 init 321\n\
         [mb]\nlisten = 127.0.0.1:0\ncoil 0 QUIT\nholding 0 H\n[stop]\npoint = QUIT\n",
    )
    .unwrap();
    let opts = RunOptions {
        plc_id: petriplc_runtime::harness::plc_id(),
        duration: Some(Duration::from_secs(60)),
        known_kinds: petriplc_modbus::KINDS,
        overrides: Vec::new(),
    };
    let plc = Plc::start(&conf, registry, &opts).unwrap_or_else(|e| panic!("{e}"));
    // The port appears in the module's status line once it has scanned.
    let start = Instant::now();
    let addr = loop {
        let status = plc.status();
        let detail = status
            .modules
            .iter()
            .find(|m| m.name == "mb")
            .map(|m| m.detail.clone())
            .unwrap_or_default();
        if let Some(a) = tcp_address(&detail) {
            break a;
        }
        assert!(start.elapsed() < PATIENCE, "no address in `{detail}`");
        std::thread::sleep(Duration::from_millis(10));
    };
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let last = plc.wait(&AtomicBool::new(false));
        let _ = tx.send(last);
    });
    let mut raw = Raw::connect(addr);
    assert_eq!(raw.request(1, &[0x03, 0, 0, 0, 1]), [0x03, 2, 0x01, 0x41]);
    raw.send(&adu(2, 1, &[0x05, 0, 0, 0xFF, 0]));
    assert_eq!(raw.read_adu(), (2, 1, vec![0x05, 0, 0, 0xFF, 0]));
    let last = rx
        .recv_timeout(PATIENCE)
        .expect("the PLC stops once the shutdown module sees the coil");
    let mb = last.modules.iter().find(|m| m.name == "mb").unwrap();
    assert!(mb.scans > 0, "{mb:?}");
    // The server has closed: the connection ends.
    assert!(raw.closed());
}
