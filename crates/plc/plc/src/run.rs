//! A running PLC's modules: a thread per built-in module running instances of it (with its
//! watchdog, restarts and safe values on failure), a process per program watched by a
//! thread, and the scan loop framing every scan.

use std::os::fd::AsRawFd;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

use nix::sys::signal::Signal;
use petriplc_config::{ModuleDecl, PlcConfig};
use petriplc_runtime::image::{ModuleMap, PointId};
use petriplc_runtime::module::{Control, Factory, InitContext, Module, ModuleError, ScanContext};
use petriplc_runtime::period::{self, Period, ScanStats};
use petriplc_runtime::process::{self as proc, Pidfd};
use petriplc_runtime::report::{self, Receiver};
use petriplc_runtime::retained::{self, Adopt};
use petriplc_runtime::synch::{ScanRef, TransitionRef};
use petriplc_runtime::watchdog::ScanClock;

use crate::{ModuleState, RunError, Shared};

/// A thread module, initialised and ready.
pub(crate) struct Ready {
    pub index: usize,
    pub module: Box<dyn Module>,
    pub map: ModuleMap,
    pub factory: Factory,
}

/// How a module's restarts go (`on_failure = restart`): the delay doubles with each
/// failure in a row up to `restart_delay_max`; a run of `restart_delay_max` without failing
/// starts over; `restart_limit` failures in a row fail the module for good.
pub(crate) struct Restarts {
    pub in_a_row: u32,
    pub delay: Option<Duration>,
    /// When the module last (re)started.
    pub since: Instant,
}

impl Restarts {
    pub(crate) fn new() -> Self {
        Restarts {
            in_a_row: 0,
            delay: None,
            since: Instant::now(),
        }
    }

    /// The module (re)starts now.
    pub(crate) fn started(&mut self) {
        self.since = Instant::now();
    }

    /// After a failure: the delay before the next restart, or `None` past the limit.
    pub(crate) fn next(&mut self, policy: &petriplc_config::Restart) -> Option<Duration> {
        if self.since.elapsed() >= policy.delay_max {
            self.in_a_row = 0;
            self.delay = None;
        }
        if policy.limit != 0 && self.in_a_row >= policy.limit {
            return None;
        }
        self.in_a_row += 1;
        let delay = match self.delay {
            None => policy.delay,
            Some(d) => d.saturating_mul(2).min(policy.delay_max),
        };
        self.delay = Some(delay);
        Some(delay)
    }
}

/// A scan's duration for watchdog messages: to a tenth of a millisecond.
fn show_precise(d: Duration) -> String {
    if d < Duration::from_secs(1) {
        format!("{:.1} ms", d.as_secs_f64() * 1e3)
    } else {
        format!("{:.3} s", d.as_secs_f64())
    }
}

pub(crate) fn show_duration(d: Duration) -> String {
    if d < Duration::from_secs(1) {
        format!("{} ms", d.as_millis())
    } else {
        format!("{:.1} s", d.as_secs_f64())
    }
}

fn make(
    factory: Factory,
    decl: &ModuleDecl,
    config: &PlcConfig,
    map: &mut ModuleMap,
    base_dir: &Path,
    plc_id: &str,
    restored_points: &[PointId],
) -> Result<Box<dyn Module>, ModuleError> {
    let mut module = factory(decl)?;
    module.init(&mut InitContext {
        decl,
        config,
        map,
        base_dir,
        plc_id,
        restored_points,
    })?;
    Ok(module)
}

/// How a module instance's run ended.
enum Ended {
    /// The PLC is stopping (or the module stopped it).
    Stopped,
    /// The module failed; the message says how.
    Failed(String),
    /// A scan ran longer than the module's watchdog; the message says how long.
    Watchdog(String),
    /// The watchdog gave up on this instance while it was in a scan (which has now
    /// returned): it must write nothing and report nothing, another instance has taken over.
    Abandoned,
}

pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// A built-in module's thread: runs instances of the module until the PLC stops, handling
/// failures (errors, panics, scans past the watchdog) by its `on_failure`. With a
/// watchdog, each instance runs on a thread of its own that this one watches.
pub(crate) fn run_thread(shared: &Arc<Shared>, r: Ready) {
    let Ready {
        index,
        module,
        map,
        factory,
    } = r;
    let decl = shared.decl(index);
    let name = decl.name.clone();
    if decl.watchdog.is_none() {
        for w in period::realtime(decl.priority) {
            log::warn!("module {name}: {w}");
        }
    } else {
        // The watcher must get the CPU from a real-time module stuck in a loop.
        let _ = period::realtime(decl.priority.map(|p| p.saturating_add(1).min(99)));
    }
    let stats = Arc::new(Mutex::new(ScanStats::new()));
    let mut restarts = Restarts::new();
    let mut instance = Some((module, map));
    let mut first = true;
    loop {
        let (module, map) = match instance.take() {
            Some(i) => i,
            None => match fresh(shared, index, factory) {
                Ok(i) => i,
                Err(e) => {
                    let why = format!("it could not start again: {e}");
                    match shared.failure(index, &why, &mut restarts) {
                        Some(delay) if shared.pause(delay) => continue,
                        _ => break,
                    }
                }
            },
        };
        shared.set_status(index, |s| {
            s.state = ModuleState::Running;
            s.pid = std::process::id();
        });
        restarts.started();
        let (ended, close_panicked) = match decl.watchdog {
            None => run_instance(shared, index, module, map, &stats),
            Some(limit) => {
                let limit = limit + module.watchdog_grace();
                supervise(shared, index, module, map, &stats, limit, first)
            }
        };
        first = false;
        let why = match ended {
            Ended::Failed(why) => why,
            Ended::Watchdog(why) => {
                // A stuck module's outputs are stale whatever its on_failure: safe now.
                if let Err(e) = shared.write_safe_values(index) {
                    log::error!("module {name}: safe values not written: {e}");
                }
                why
            }
            Ended::Stopped | Ended::Abandoned if close_panicked && !shared.synch.is_stopping() => {
                "the module panicked while closing".to_string()
            }
            Ended::Stopped | Ended::Abandoned => break,
        };
        match shared.failure(index, &why, &mut restarts) {
            Some(delay) if shared.pause(delay) => {}
            _ => break,
        }
    }
    shared.stopped(index);
}

/// Runs one instance of a module until it ends, then closes it and publishes its status;
/// says how it ended and whether closing panicked.
fn run_instance(
    shared: &Shared,
    index: usize,
    mut module: Box<dyn Module>,
    map: ModuleMap,
    stats: &Mutex<ScanStats>,
) -> (Ended, bool) {
    let ended = catch_unwind(AssertUnwindSafe(|| {
        scan_loop(shared, index, &mut *module, map, stats)
    }))
    .unwrap_or_else(|_| Ended::Failed("the module panicked".into()));
    let closed = catch_unwind(AssertUnwindSafe(|| module.close()));
    if let Ended::Abandoned = ended {
        log::warn!(
            "module {}: the scan its watchdog gave up on has returned; that instance is closed \
             and what it did is discarded",
            shared.decl(index).name
        );
        return (Ended::Abandoned, false);
    }
    let (line, marking) =
        catch_unwind(AssertUnwindSafe(|| (module.status(), module.marking()))).unwrap_or_default();
    shared.set_status(index, |s| s.record(&lock(stats), line, marking));
    (ended, closed.is_err())
}

/// Runs one instance on a thread of its own and watches its scans: one that runs longer
/// than `limit` is taken from it (its outputs will never reach the image) and reported as
/// [`Ended::Watchdog`] at once, while the thread may still be stuck in it. A thread cannot
/// be killed: a stuck one is left behind, detached, and ends (or not) on its own; the PLC
/// goes on, and a restart runs a new instance on a new thread.
fn supervise(
    shared: &Arc<Shared>,
    index: usize,
    module: Box<dyn Module>,
    map: ModuleMap,
    stats: &Arc<Mutex<ScanStats>>,
    limit: Duration,
    first: bool,
) -> (Ended, bool) {
    let decl = shared.decl(index);
    let Some(clock) = shared.clocks.clock(index) else {
        return run_instance(shared, index, module, map, stats);
    };
    clock.reset();
    let (tx, rx) = mpsc::channel();
    let worker = {
        let (shared, stats) = (Arc::clone(shared), Arc::clone(stats));
        let (name, priority) = (decl.name.clone(), decl.priority);
        std::thread::Builder::new()
            .name(decl.name.clone())
            .spawn(move || {
                for w in period::realtime(priority) {
                    if first {
                        log::warn!("module {name}: {w}");
                    }
                }
                let _ = tx.send(run_instance(&shared, index, module, map, &stats));
            })
    };
    let worker = match worker {
        Ok(w) => w,
        Err(e) => {
            return (
                Ended::Failed(format!("cannot start its thread: {e}")),
                false,
            )
        }
    };
    // Often enough to see every scan before its deadline, then woken at the deadline.
    let poll = (limit / 2).clamp(Duration::from_millis(1), Duration::from_millis(50));
    loop {
        let wait = match clock.running() {
            Some(t) => (t.began() + limit).saturating_sub(period::now()),
            None => poll,
        };
        match rx.recv_timeout(wait) {
            Ok(ended) => {
                let _ = worker.join();
                return ended;
            }
            Err(RecvTimeoutError::Disconnected) => {
                let _ = worker.join();
                return (
                    Ended::Failed("its thread ended without a word".into()),
                    false,
                );
            }
            Err(RecvTimeoutError::Timeout) => {
                let Some(t) = clock.running() else { continue };
                let ran = period::now().saturating_sub(t.began());
                if ran >= limit && clock.expire(t) {
                    // Detached: never joined, so a stop does not wait for it either.
                    drop(worker);
                    return (
                        Ended::Watchdog(format!(
                            "its scan has run {} without ending, longer than its watchdog \
                             ({}): it is stuck or too slow; the scan is abandoned and nothing \
                             it writes reaches the image",
                            show_precise(ran),
                            show_precise(limit)
                        )),
                        false,
                    );
                }
            }
        }
    }
}

/// A fresh instance of a built-in module and a fresh map, as a new process would get.
fn fresh(
    shared: &Shared,
    index: usize,
    factory: Factory,
) -> Result<(Box<dyn Module>, ModuleMap), ModuleError> {
    let decl = shared.decl(index);
    let mut map = ModuleMap::new(&shared.layout, &decl.name, decl.location)
        .map_err(|e| ModuleError::new(e.to_string()))?;
    // Its retentive points go on from the last committed scan, not from their init values.
    retained::adopt(&mut map, &shared.global, Adopt::Retentive);
    map.update(&shared.global);
    shared.retain.registry.new_instance(&decl.name);
    // Every retentive point goes on from where the failed instance left it.
    let restored = retained::points(&shared.layout);
    let module = catch_unwind(AssertUnwindSafe(|| {
        make(
            factory,
            decl,
            &shared.config,
            &mut map,
            &shared.base_dir,
            &shared.plc_id,
            &restored,
        )
    }))
    .unwrap_or_else(|_| Err(ModuleError::new("the module panicked while starting")))?;
    Ok((module, map))
}

/// The scan loop of one instance of a built-in module.
fn scan_loop(
    shared: &Shared,
    index: usize,
    module: &mut dyn Module,
    mut map: ModuleMap,
    stats: &Mutex<ScanStats>,
) -> Ended {
    let decl = shared.decl(index);
    let name = &decl.name;
    let net = shared.synch.net();
    let scan_ref = net.scan_ref(name);
    // A module's own default period is for running alone: in the synchronisation net, the
    // net paces it.
    let mut period = decl
        .scan_period
        .or_else(|| module.default_scan_period().filter(|_| scan_ref.is_none()))
        .filter(|p| !p.is_zero())
        .map(|p| Period::starting_at(shared.t0, p));
    let watchdog: Option<(Duration, ScanClock)> = decl
        .watchdog
        .and_then(|limit| Some((limit, shared.clocks.clock(index)?)));
    // Retained data the module registered is committed with its end-of-scan update.
    let data = shared.retain.registry.module(name);
    let commits = !data.is_empty();
    let commit = |map: &mut ModuleMap| {
        if commits {
            data.commit(|| map.update(&shared.global));
        } else {
            map.update(&shared.global);
        }
    };
    // The status file is rewritten every 50 ms: a fresh status line and marking every 25 ms
    // is enough, and a module scanning every 100 µs does not pay for formatting them.
    let mut published = Duration::ZERO;
    let mut scan = 0u64;
    loop {
        let (late, missed, started) = match &mut period {
            Some(p) => {
                let w = p.wait();
                (w.late, w.missed, w.woke())
            }
            None => (Duration::ZERO, 0, period::now()),
        };
        if begin(shared, scan_ref.as_ref()).is_err() {
            return Ended::Stopped;
        }
        map.update(&shared.global);
        let token = watchdog.as_ref().map(|(_, c)| c.begin());
        let mut ctx = ScanContext {
            now: period::now().saturating_sub(shared.t0),
            scan,
            map: &mut map,
        };
        let result = module.scan(&mut ctx);
        if let (Some((limit, clock)), Some(t)) = (&watchdog, token) {
            if !clock.end(t) {
                return Ended::Abandoned;
            }
            let took = period::now().saturating_sub(t.began());
            // A module that failed its own scan for taking too long (the iec engine) says
            // where it was: its message is the better one.
            if took > *limit && result.is_ok() {
                data.discard();
                return Ended::Watchdog(format!(
                    "its scan took {}, longer than its watchdog ({}); its outputs were not \
                     written",
                    show_precise(took),
                    show_precise(*limit)
                ));
            }
        }
        match result {
            Ok(Control::Continue) => {}
            Ok(Control::StopPlc) => {
                log::info!("module {name} stops the PLC");
                commit(&mut map);
                shared.synch.stop();
                return Ended::Stopped;
            }
            // The failed scan's outputs are not written: its map is dropped unexchanged.
            Err(e) => {
                data.discard();
                return Ended::Failed(e.0);
            }
        }
        commit(&mut map);
        if end(shared, scan_ref.as_ref()).is_err() {
            return Ended::Stopped;
        }
        lock(stats).record(period::now().saturating_sub(started), late, missed);
        scan += 1;
        let now = period::now();
        if now.saturating_sub(published) >= Duration::from_millis(25) {
            published = now;
            let (line, marking) = (module.status(), module.marking());
            shared.set_status(index, |s| s.record(&lock(stats), line, marking));
        }
    }
}

fn begin(shared: &Shared, scan: Option<&ScanRef>) -> Result<(), petriplc_runtime::synch::Stopped> {
    match scan {
        Some(s) => shared.synch.begin_scan(s).map(drop),
        None => shared.synch.synch(TransitionRef::Null).map(drop),
    }
}

fn end(shared: &Shared, scan: Option<&ScanRef>) -> Result<(), petriplc_runtime::synch::Stopped> {
    match scan {
        Some(s) => shared.synch.end_scan(s).map(drop),
        None => shared.synch.synch(TransitionRef::Null).map(drop),
    }
}

/// Starts module `index`'s program, with a pipe for its scan statistics, tied to the calling
/// thread: it gets SIGKILL if that thread (the PLC) dies, so no module outlives a PLC killed
/// with `kill -9`.
pub(crate) fn spawn(
    shared: &Shared,
    index: usize,
    program: &Path,
) -> Result<(Child, Receiver), RunError> {
    let decl = shared.decl(index);
    let failed = |error| RunError::Spawn {
        module: decl.name.clone(),
        program: program.display().to_string(),
        error,
    };
    let (stats, stats_fd) = Receiver::pipe().map_err(failed)?;
    let mut command = Command::new(program);
    command
        .args(&decl.args)
        .env("PETRIPLC_CONFIG", &shared.config_path)
        .env("PETRIPLC_SET", &shared.overrides)
        .env("PETRIPLC_MODULE", &decl.name)
        .env("PETRIPLC_PLC_ID", &shared.plc_id)
        .env(report::STATS_FD, stats_fd.as_raw_fd().to_string());
    let child = proc::spawn_tied(&mut command, Signal::SIGKILL).map_err(failed)?;
    // The child has its copy; ours would only keep the pipe open.
    drop(stats_fd);
    let pid = child.id();
    shared.set_status(index, |s| {
        s.state = ModuleState::Running;
        s.pid = pid;
    });
    log::info!(
        "module {} runs as process {pid} ({})",
        decl.name,
        program.display()
    );
    Ok((child, stats))
}

/// Watches a module process: restarts it or stops the PLC when it dies unasked (through its
/// `on_failure`), and ends it when the PLC stops (it should leave on its own at its next
/// synch; else SIGTERM, SIGKILL). Its scan statistics come through `stats`. With a
/// watchdog, a scan that runs longer (as the process's scan clock shows) gets the process
/// killed, and the death goes through `on_failure` as a watchdog failure.
pub(crate) fn watch_process(
    shared: &Shared,
    index: usize,
    program: PathBuf,
    (mut child, mut stats): (Child, Receiver),
) {
    let decl = shared.decl(index);
    let name = decl.name.clone();
    let watchdog: Option<(Duration, ScanClock)> = decl
        .watchdog
        .and_then(|limit| Some((limit, shared.clocks.clock(index)?)));
    if watchdog.is_some() {
        // The watcher must get the CPU from a real-time module stuck in a loop.
        let _ = period::realtime(decl.priority.map(|p| p.saturating_add(1).min(99)));
    }
    let mut restarts = Restarts::new();
    // A pidfd wakes the watcher the moment the process exits; polling is the fallback.
    let mut pidfd = Pidfd::open(child.id()).ok();
    // Set when the watchdog killed the process: the reason its death is reported with.
    let mut killed: Option<String> = None;
    loop {
        // Read after the exit is seen, so that the process's last report is in.
        let exited = child.try_wait();
        if let Some(r) = stats.latest() {
            shared.set_status(index, |s| r.apply(s));
        }
        match exited {
            Ok(Some(exit)) if shared.synch.is_stopping() && killed.is_none() => {
                log::info!("module {name} (process) ended: {exit}");
                shared.stopped(index);
                return;
            }
            Ok(Some(exit)) => {
                let why = match killed.take() {
                    Some(why) => {
                        if let Err(e) = shared.write_safe_values(index) {
                            log::error!("module {name}: safe values not written: {e}");
                        }
                        why
                    }
                    None => format!("its process ended: {exit}"),
                };
                let delay = shared.failure(index, &why, &mut restarts);
                match delay {
                    Some(d) if shared.pause(d) => {}
                    _ => {
                        shared.stopped(index);
                        return;
                    }
                }
                if let Some((_, clock)) = &watchdog {
                    clock.reset();
                }
                match spawn(shared, index, &program) {
                    Ok(c) => {
                        (child, stats) = c;
                        pidfd = Pidfd::open(child.id()).ok();
                        restarts.started();
                    }
                    Err(e) => {
                        log::error!("{e}");
                        shared.fail(index);
                        shared.synch.stop();
                        return;
                    }
                }
            }
            Ok(None) if shared.synch.is_stopping() && killed.is_none() => {
                end_process(&name, &mut child);
                let last = stats.latest();
                shared.set_status(index, |s| {
                    if let Some(r) = last {
                        r.apply(s);
                    }
                });
                shared.stopped(index);
                return;
            }
            Ok(None) => {
                let wait = match &watchdog {
                    None => Duration::from_millis(50),
                    Some((limit, clock)) => match clock.running() {
                        Some(t) => (t.began() + *limit).saturating_sub(period::now()),
                        None => *limit / 2,
                    }
                    .clamp(Duration::from_micros(100), Duration::from_millis(50)),
                };
                match &pidfd {
                    Some(fd) => {
                        fd.wait_exit(wait);
                    }
                    None => std::thread::sleep(wait.min(Duration::from_millis(20))),
                }
                if let Some((limit, clock)) = &watchdog {
                    if let Some(t) = clock.running() {
                        let ran = period::now().saturating_sub(t.began());
                        if ran >= *limit && killed.is_none() && clock.expire(t) {
                            killed = Some(format!(
                                "its scan has run {} without ending, longer than its watchdog \
                                 ({}): it is stuck or too slow; its process is killed",
                                show_precise(ran),
                                show_precise(*limit)
                            ));
                            // Our own unreaped child: its pid cannot have been reused.
                            let _ = child.kill();
                        }
                    }
                }
            }
            Err(e) => {
                log::error!("module {name}: cannot watch its process: {e}");
                return;
            }
        }
    }
}

pub(crate) fn end_process(name: &str, child: &mut Child) {
    use nix::sys::signal::kill;
    use nix::unistd::Pid;
    let pid = Pid::from_raw(child.id() as i32);
    for (signal, grace) in [
        (None, 2000),
        (Some(Signal::SIGTERM), 2000),
        (Some(Signal::SIGKILL), 0),
    ] {
        if let Some(s) = signal {
            log::warn!("module {name} did not stop; sending {s}");
            // Our own unreaped child: its pid cannot have been reused.
            let _ = kill(pid, s);
        }
        for _ in 0..grace / 20 {
            if let Ok(Some(_)) = child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    let _ = child.wait();
}
