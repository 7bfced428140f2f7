//! What the hmi tests share: the registry of every built-in kind, the mixer configuration
//! with an hmi on a free port, an HTTP client, and a real PLC (petriplc-plc) to run it.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use petriplc_plc::{Plc, PlcStatus, RunOptions};
use petriplc_runtime::harness::{self, ms};
use petriplc_runtime::module::Factory;
use serde_json::Value;

pub const TOKEN: &str = "test-token-4f0c9a";

pub fn registry(kind: &str) -> Option<Factory> {
    petriplc_modules::builtin(kind).or_else(|| petriplc_hmi::builtin(kind))
}

pub fn mixer_dir() -> PathBuf {
    harness::examples("mixer")
}

/// The points of examples/mixer/plc.conf.
pub const MIXER_POINTS: &str = r#"
point B1    "start button"                operator
point N1    "level sensor: empty"         tank
point N2    "level sensor: half"          tank
point N3    "level sensor: full"          tank
point L1    "lamp: ready"                 controller
point L2    "lamp: filling"               controller
point L3    "lamp: draining"              controller
point V1    "valve: solvent"              controller
point V2    "valve: solute"               controller
point V3    "valve: drain"                controller
point A1    "heater"                      controller
point M1    "mixer motor"                 controller
"#;

/// examples/mixer/plc.conf with an hmi on a free port and `TOKEN` (paths absolute, so the
/// file can live anywhere).
pub fn mixer_config() -> String {
    let dir = mixer_dir();
    let dir = dir.display();
    format!(
        "[PLC]\nmodule operator timeline\nmodule tank plant\nmodule controller petrinet\n\
         module hmi hmi\nsynch operator -> tank\nsynch tank -> controller\n\
         synch controller -> operator\nsynch_start operator\n{MIXER_POINTS}\n\
         [operator]\nfile = {dir}/operator.csv\nrepeat = yes\nscan_period = T#10ms\n\
         [tank]\nplant = tank\nspeed = 5\nscan_period = T#10ms\n\
         [controller]\nnet = {dir}/mixer.pnml\nnames = sipn\nscan_period = T#10ms\n\
         [hmi]\nlisten = 127.0.0.1:0\ntoken = {TOKEN}\n"
    )
}

/// An HTTP client that reports every status as a response and gives up after 10 s.
pub fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        .timeout_global(Some(Duration::from_secs(10)))
        .build()
        .into()
}

/// Status and body of a GET.
pub fn get(url: &str) -> (u16, String) {
    let mut r = agent()
        .get(url)
        .call()
        .unwrap_or_else(|e| panic!("GET {url}: {e}"));
    let status = r.status().as_u16();
    (status, r.body_mut().read_to_string().unwrap())
}

pub fn get_json(url: &str) -> Value {
    let (status, body) = get(url);
    assert_eq!(status, 200, "GET {url}: {body}");
    serde_json::from_str(&body).unwrap_or_else(|e| panic!("GET {url}: {e}: {body}"))
}

/// Status and JSON body of a POST with `token` as bearer token (none when `None`).
pub fn post(url: &str, token: Option<&str>, body: &str) -> (u16, Value) {
    let mut req = agent().post(url).content_type("application/json");
    if let Some(t) = token {
        req = req.header("Authorization", &format!("Bearer {t}"));
    }
    let mut r = req.send(body).unwrap_or_else(|e| panic!("POST {url}: {e}"));
    let status = r.status().as_u16();
    let text = r.body_mut().read_to_string().unwrap();
    let v = serde_json::from_str(&text).unwrap_or_else(|e| panic!("POST {url}: {e}: {text}"));
    (status, v)
}

/// The page's address in an hmi module's status line (`http://…/ — N pages connected`).
pub fn url_in(status: &str) -> Option<String> {
    let url = status.split(' ').next()?;
    url.starts_with("http://").then(|| url.to_string())
}

/// A point of a snapshot.
pub fn point<'a>(snapshot: &'a Value, name: &str) -> &'a Value {
    snapshot["points"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == name)
        .unwrap_or_else(|| panic!("no point {name} in {snapshot}"))
}

/// A PLC run by petriplc-plc's runner on threads, as `petriplc run` does (its `wait`, which
/// also writes the status file the hmi reads, on a thread of its own).
pub struct Running {
    pub url: String,
    pub dir: tempfile::TempDir,
    stop: Arc<AtomicBool>,
    last: Option<mpsc::Receiver<PlcStatus>>,
}

/// Starts the mixer configuration with the hmi and waits until the hmi says its address.
pub fn run_mixer() -> Running {
    let dir = tempfile::tempdir().unwrap();
    let conf = dir.path().join("plc.conf");
    std::fs::write(&conf, mixer_config()).unwrap();
    let plc = Plc::start(
        &conf,
        registry,
        &RunOptions {
            plc_id: harness::plc_id(),
            duration: None,
            known_kinds: &["timeline", "plant", "petrinet", "hmi"],
            overrides: Vec::new(),
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let url = wait_for(Duration::from_secs(20), || {
        let s = plc.status();
        let hmi = s.modules.iter().find(|m| m.name == "hmi")?;
        url_in(&hmi.detail)
    });
    let stop = Arc::new(AtomicBool::new(false));
    let (tx, last) = mpsc::channel();
    let flag = Arc::clone(&stop);
    std::thread::spawn(move || {
        let _ = tx.send(plc.wait(&flag));
    });
    let mut running = Running {
        url: String::new(),
        dir,
        stop,
        last: Some(last),
    };
    match url {
        Some(url) => running.url = url,
        None => {
            running.stop();
            panic!("the hmi module never said its address in its status line");
        }
    }
    running
}

impl Running {
    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    /// Stops the PLC and waits for every module (at most 20 s).
    pub fn stop(&mut self) -> Option<PlcStatus> {
        let last = self.last.take()?;
        self.stop.store(true, Ordering::Relaxed);
        Some(
            last.recv_timeout(Duration::from_secs(20))
                .expect("the PLC did not stop within 20 s"),
        )
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if !std::thread::panicking() {
            self.stop();
        }
    }
}

/// Calls `f` until it gives a value or `limit` has passed.
pub fn wait_for<T>(limit: Duration, mut f: impl FnMut() -> Option<T>) -> Option<T> {
    let start = Instant::now();
    loop {
        if let Some(v) = f() {
            return Some(v);
        }
        if start.elapsed() > limit {
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The mixer's modules stepped in-process, with a logger of B1, L1 and SP (a signed point
/// nobody writes) and the hmi.
pub fn mixer_harness(log: &std::path::Path) -> (harness::Plc, String) {
    let text = format!(
        "[PLC]\nmodule operator timeline\nmodule tank plant\nmodule controller petrinet\n\
         module log logger\nmodule hmi hmi\n{MIXER_POINTS}\n\
         point SP \"set point\" operator i16 init 7\n\
         point T \"temperature\" operator f32 init 21.5\n\
         [operator]\nfile = operator.csv\nrepeat = yes\n\
         [tank]\nplant = tank\nspeed = 5\n\
         [controller]\nnet = mixer.pnml\nnames = sipn\n\
         [log]\nfile = {}\npoints = B1 SP L1\n\
         [hmi]\nlisten = 127.0.0.1:0\ntoken = {TOKEN}\nrefresh = T#20ms\n",
        log.display()
    );
    let plc = harness::start(&text, &mixer_dir(), registry).unwrap_or_else(|e| panic!("{e}"));
    let url = url_in(&plc.status("hmi")).expect("no address in the hmi's status line");
    (plc, url)
}

/// Runs `f` on another thread while the PLC scans on this one, at `now` advanced by `step`
/// each scan (zero: time stands still), until `f` returns.
pub fn while_scanning<T: Send>(
    plc: &mut harness::Plc,
    now: &mut Duration,
    step: Duration,
    f: impl FnOnce() -> T + Send,
) -> T {
    std::thread::scope(|s| {
        let h = s.spawn(f);
        while !h.is_finished() {
            plc.tick(*now).unwrap();
            *now += step;
            std::thread::sleep(Duration::from_millis(2));
        }
        h.join().unwrap()
    })
}

/// Scans until `until` (10 ms scans).
pub fn run_to(plc: &mut harness::Plc, now: &mut Duration, until: Duration) {
    while *now < until {
        plc.tick(*now).unwrap();
        *now += ms(10);
    }
}
