//! Thread modules under the watchdog, and module-private retained data, through the
//! runner's API with modules written for the test: a module that sleeps through ten of its
//! periods is failed by its watchdog while it sleeps, its safe value is what the other
//! modules read, and what it writes when it wakes never reaches the image; a module stuck
//! in an endless loop is left behind while the PLC goes on, restarts it as a new instance
//! and stops without waiting for it; a module's retained data comes back at the next start.
//!
//! No timing assertions: waits poll for a state with a generous safety limit.

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use petriplc_config::ModuleDecl;
use petriplc_plc::{Plc, RunOptions};
use petriplc_runtime::image::Handle;
use petriplc_runtime::module::{Control, Factory, InitContext, Module, ModuleError, ScanContext};

const SAFETY_NET: Duration = Duration::from_secs(30);

/// Every value the watcher read, in order (one test at a time uses it: see `SERIAL`).
static SEEN: Mutex<Vec<u32>> = Mutex::new(Vec::new());
/// Set by the sleeper when its long sleep is over.
static WOKE: AtomicBool = AtomicBool::new(false);
/// Holds the stuck module in its loop, and the sleeper past its nap, until the test lets it
/// go.
static RELEASE: AtomicBool = AtomicBool::new(false);
/// Instances of the stuck module made so far.
static INSTANCES: AtomicU32 = AtomicU32::new(0);
/// The tests share the statics above: one runs at a time.
static SERIAL: Mutex<()> = Mutex::new(());

fn setting(decl: &ModuleDecl, name: &str) -> u64 {
    decl.settings
        .get(name)
        .and_then(|s| s.value.parse().ok())
        .unwrap_or(0)
}

/// Writes `busy = 1` every scan; in scan `at` it sleeps `nap` ms (and on until the test
/// sets `RELEASE`) first and then writes 2.
struct Sleeper {
    busy: Option<Handle>,
    at: u64,
    nap: u64,
    stuck: bool,
}

impl Module for Sleeper {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        self.busy = Some(
            ctx.map
                .handle("busy")
                .map_err(|e| ModuleError::new(e.to_string()))?,
        );
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let busy = self.busy.unwrap();
        let mut value = 1;
        if ctx.scan == self.at {
            if self.stuck {
                // An endless loop, as far as the PLC can tell.
                while !RELEASE.load(Ordering::Acquire) {
                    std::thread::sleep(Duration::from_millis(1));
                }
            } else {
                std::thread::sleep(Duration::from_millis(self.nap));
                // Longer if the test is not done looking: on a loaded machine the nap could
                // end before the test saw what the watchdog did during it.
                while !RELEASE.load(Ordering::Acquire) {
                    std::thread::sleep(Duration::from_millis(1));
                }
                WOKE.store(true, Ordering::Release);
            }
            value = 2;
        }
        ctx.map.set_u32(&busy, value).unwrap();
        Ok(Control::Continue)
    }
}

/// Reads `busy` every scan into `SEEN`.
struct Watcher {
    busy: Option<Handle>,
}

impl Module for Watcher {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        self.busy = Some(
            ctx.map
                .handle("busy")
                .map_err(|e| ModuleError::new(e.to_string()))?,
        );
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let v = ctx.map.get_u32(&self.busy.unwrap());
        SEEN.lock().unwrap().push(v);
        Ok(Control::Continue)
    }
}

/// Keeps a running total of its scans as retained data (little-endian u64).
struct Totaliser {
    total: Option<petriplc_retain::Retained>,
    value: u64,
    /// Registers data without saying so (`retains_data`): a bug the runner refuses.
    sneaky: bool,
}

impl Module for Totaliser {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        let r = ctx.retain("total", "ULINT")?;
        self.value = r
            .get()
            .map(|b| u64::from_le_bytes(b.try_into().unwrap()))
            .unwrap_or(1000);
        self.total = Some(r);
        Ok(())
    }

    fn scan(&mut self, _ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        self.value += 1;
        self.total.as_ref().unwrap().set(self.value.to_le_bytes());
        Ok(Control::Continue)
    }

    fn status(&self) -> String {
        format!("total {}", self.value)
    }

    fn retains_data(&self) -> bool {
        !self.sneaky
    }
}

fn sleeper(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(Sleeper {
        busy: None,
        at: setting(decl, "at"),
        nap: setting(decl, "nap"),
        stuck: false,
    }))
}

fn stuck(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    // Only the first instance gets stuck; its successors scan on.
    let first = INSTANCES.fetch_add(1, Ordering::AcqRel) == 0;
    Ok(Box::new(Sleeper {
        busy: None,
        at: if first { setting(decl, "at") } else { u64::MAX },
        nap: 0,
        stuck: true,
    }))
}

fn registry(kind: &str) -> Option<Factory> {
    match kind {
        "sleeper" => Some(sleeper),
        "stuck" => Some(stuck),
        "watcher" => Some(|_| Ok(Box::new(Watcher { busy: None }))),
        "totaliser" => Some(|_| {
            Ok(Box::new(Totaliser {
                total: None,
                value: 0,
                sneaky: false,
            }))
        }),
        "sneaky" => Some(|_| {
            Ok(Box::new(Totaliser {
                total: None,
                value: 0,
                sneaky: true,
            }))
        }),
        _ => None,
    }
}

fn start(dir: &Path, name: &str, conf: &str) -> Plc {
    let path = dir.join("plc.conf");
    std::fs::write(&path, conf).unwrap();
    let opts = RunOptions {
        plc_id: format!("threads-{name}-{}", std::process::id()),
        duration: None,
        known_kinds: &["sleeper", "stuck", "watcher", "totaliser", "sneaky"],
        overrides: Vec::new(),
    };
    Plc::start(&path, registry, &opts).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn data_registered_without_saying_so_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plc.conf");
    std::fs::write(&path, "[PLC]\nmodule s sneaky\n").unwrap();
    let opts = RunOptions {
        plc_id: format!("threads-sneaky-{}", std::process::id()),
        duration: None,
        known_kinds: &[],
        overrides: Vec::new(),
    };
    let e = Plc::start(&path, registry, &opts).err().unwrap();
    assert!(e.is_bad_input());
    assert_eq!(
        e.to_string(),
        "module s: module s registers retained data (`total`) but its kind does not say so \
         (`Module::retains_data`), so the PLC opened no retain file for it: a bug in the module"
    );
}

/// Waits until `SEEN` satisfies `done`.
fn until(what: &str, done: impl Fn(&[u32]) -> bool) {
    let started = Instant::now();
    while !done(&SEEN.lock().unwrap()) {
        assert!(
            started.elapsed() < SAFETY_NET,
            "{what}: the watcher saw {:?}",
            SEEN.lock().unwrap()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn stop(plc: Plc) -> petriplc_plc::PlcStatus {
    let stop = AtomicBool::new(true);
    plc.wait(&stop)
}

#[test]
fn a_module_sleeping_ten_periods_is_failed_while_it_sleeps() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    SEEN.lock().unwrap().clear();
    RELEASE.store(false, Ordering::Release);
    WOKE.store(false, Ordering::Release);
    let dir = tempfile::tempdir().unwrap();
    // Scan 3 sleeps 10 periods of 50 ms (and on until released); the watchdog is 2 periods.
    let plc = start(
        dir.path(),
        "sleep",
        "[PLC]\nmodule sleeper sleeper\nmodule watcher watcher\n\
         point busy \"\" sleeper u8\n\
         [sleeper]\nscan_period = T#50ms\nwatchdog = T#100ms\non_failure = ignore\n\
         safe busy 0\nat = 3\nnap = 500\n\
         [watcher]\nscan_period = T#5ms\n",
    );
    // The sleeper sleeps until released: a watchdog that acted only once the scan returned
    // would never show the safe value here, and the wait would time out.
    until("the safe value after the 1s", |s| {
        s.iter()
            .position(|&v| v == 1)
            .is_some_and(|i| s[i..].contains(&0))
    });
    // The safe value is written before the failure is recorded: wait for that too.
    let started = Instant::now();
    while !plc.failed() {
        assert!(started.elapsed() < SAFETY_NET, "the sleeper was not failed");
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(!WOKE.load(Ordering::Acquire));
    // The sleeper wakes and writes 2: the image never shows it.
    RELEASE.store(true, Ordering::Release);
    let started = Instant::now();
    while !WOKE.load(Ordering::Acquire) {
        assert!(started.elapsed() < SAFETY_NET);
        std::thread::sleep(Duration::from_millis(5));
    }
    let after = SEEN.lock().unwrap().len();
    until("more scans of the watcher", |s| s.len() > after + 20);
    let last = stop(plc);
    let seen = SEEN.lock().unwrap().clone();
    assert!(
        !seen.contains(&2),
        "the abandoned scan's output reached the image: {seen:?}"
    );
    assert_eq!(*seen.last().unwrap(), 0, "{seen:?}");
    let sleeper = &last.modules[0];
    assert_eq!(sleeper.state, petriplc_plc::ModuleState::Failed);
    let watcher = &last.modules[1];
    assert!(watcher.scans > 50, "the watcher stopped scanning: {last}");
}

#[test]
fn a_module_stuck_for_ever_is_left_behind_and_restarted() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    SEEN.lock().unwrap().clear();
    RELEASE.store(false, Ordering::Release);
    let dir = tempfile::tempdir().unwrap();
    let plc = start(
        dir.path(),
        "stuck",
        "[PLC]\nmodule stuck stuck\nmodule watcher watcher\npoint busy \"\" stuck u8\n\
         [stuck]\nscan_period = T#10ms\nwatchdog = T#40ms\non_failure = restart\n\
         restart_delay = T#50ms\nsafe busy 0\nat = 2\n\
         [watcher]\nscan_period = T#5ms\n",
    );
    // 1s, the safe 0 while the first instance is stuck, then the new instance's 1s.
    until("1, then the safe 0, then 1 again", |s| {
        let Some(one) = s.iter().position(|&v| v == 1) else {
            return false;
        };
        let Some(zero) = s[one..].iter().position(|&v| v == 0) else {
            return false;
        };
        s[one + zero..].contains(&1)
    });
    assert!(INSTANCES.load(Ordering::Acquire) >= 2);
    // The PLC stops without waiting for the stuck thread.
    let last = stop(plc);
    assert_eq!(
        last.modules[0].state,
        petriplc_plc::ModuleState::Stopped,
        "{last}"
    );
    assert_eq!(last.modules[0].restarts, 1, "{last}");
    RELEASE.store(true, Ordering::Release);
    assert!(!SEEN.lock().unwrap().contains(&2));
}

#[test]
fn module_data_is_retained_over_a_restart_of_the_plc() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    // No retentive point, no retain_file: the module's word opens the default file.
    let conf = "[PLC]\nmodule tot totaliser\n[tot]\nscan_period = T#2ms\n";
    let total = |last: &petriplc_plc::PlcStatus| -> u64 {
        last.modules[0]
            .detail
            .strip_prefix("total ")
            .unwrap()
            .parse()
            .unwrap()
    };
    // Each run until it has scanned (not for a fixed time, which a loaded machine may not
    // scan in), then stopped.
    let scanned_past = |plc: &Plc, n: u64| {
        let started = Instant::now();
        while plc.status().modules[0]
            .detail
            .strip_prefix("total ")
            .and_then(|t| t.parse::<u64>().ok())
            .unwrap_or(0)
            <= n
        {
            assert!(started.elapsed() < SAFETY_NET, "no scan");
            std::thread::sleep(Duration::from_millis(2));
        }
    };
    let plc = start(dir.path(), "data", conf);
    scanned_past(&plc, 1000);
    let first = total(&stop(plc));
    assert!(first > 1000);
    let plc = start(dir.path(), "data", conf);
    scanned_past(&plc, first);
    let second = total(&stop(plc));
    assert!(
        second > first,
        "{second} after {first}: the total started afresh"
    );
    let snap = petriplc_retain::file::peek(&dir.path().join("plc.retain"))
        .unwrap()
        .snapshot
        .unwrap();
    assert_eq!(snap.entries[0].name, "tot/total");
    assert_eq!(
        snap.entries[0].value,
        petriplc_retain::Value::Data {
            signature: "ULINT".into(),
            bytes: second.to_le_bytes().to_vec()
        }
    );
}
