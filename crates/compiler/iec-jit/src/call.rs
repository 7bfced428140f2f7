//! Entering the generated code, and the helpers it calls back: the only `unsafe` of the
//! engine. What makes it sound:
//! - the generated code touches the machine's memory only at slots it has checked against
//!   the memory's length (a frame's slots at the function's entry, absolute slots when it was
//!   compiled), and the length is the one it was compiled for ([`Jit::run`] and
//!   [`JitScanner::scan`] check it);
//! - while it runs, the memory is reached only through the one raw pointer taken from the
//!   caller's `&mut [u64]`: by the generated code, and by the helpers, which make a slice of
//!   it for the duration of one instruction;
//! - a helper never unwinds into the generated code: it catches a panic and returns
//!   [`PANIC`], which is reported as [`Ran::Panic`] (the VM's internal fault);
//! - the code memory lives as long as the [`Jit`] (owned by the engine; a [`JitScanner`]
//!   holds the engine), and is only read.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;

use cranelift_jit::JITModule;
use petriplc_iec_vm::exec::{self, Budget, Control, FaultKind, RawFault};
use petriplc_iec_vm::op::Op;
use petriplc_iec_vm::{Compiled, Engine, Ran, Scanner};

/// Status words returned by generated functions and helpers.
pub(crate) const OK: u32 = 0;
pub(crate) const FAULT: u32 = 1;
pub(crate) const HALT: u32 = 2;
pub(crate) const PANIC: u32 = 3;
/// [`h_for`]: go round the loop again.
pub(crate) const AGAIN: u32 = 10;

/// A generated function: `(memory, base, context) -> status`.
type Entry = extern "C" fn(*mut u64, u64, *mut u8) -> u32;

/// What one run of generated code shares with its helpers. The generated code reads and
/// writes the first four fields (offsets 0, 8, 16 and 24) and passes the rest through.
/// Plain pointers, no lifetimes: a [`JitScanner`] keeps one for all the scans of its
/// machine and fills in only what changes from scan to scan.
#[repr(C)]
pub(crate) struct Ctx {
    pub iterations: u64,
    pub depth: u64,
    /// The iteration budget each program instance starts with (the whole-scan entry copies
    /// it into `iterations` before each instance).
    pub start_iterations: u64,
    /// The program instance running (set by the whole-scan entry), for the message of an
    /// internal error.
    pub instance: u64,
    mem: *mut u64,
    len: usize,
    engine: *const Engine,
    now: i64,
    /// The caller's watchdog check, by a thin pointer to the caller's `&mut dyn FnMut`:
    /// copying the wide pointer itself (just written by the caller as two words) would
    /// stall on store forwarding every scan.
    check: *mut u8,
    fault: Option<Box<RawFault>>,
}

pub(crate) const ITERATIONS_AT: i32 = 0;
pub(crate) const DEPTH_AT: i32 = 8;
pub(crate) const START_ITERATIONS_AT: i32 = 16;
pub(crate) const INSTANCE_AT: i32 = 24;

/// The context behind the pointer the generated code passes.
fn ctx<'x>(p: *mut u8) -> &'x mut Ctx {
    // SAFETY: `p` is the `&mut Ctx` that `Jit::run` or `JitScanner::scan` passed to the
    // generated code, which hands it on unchanged; neither touches the context until the
    // code returns.
    unsafe { &mut *(p as *mut Ctx) }
}

impl Ctx {
    fn mem<'m>(&self) -> &'m mut [u64] {
        // SAFETY: `mem`/`len` come from the `&mut [u64]` given to `Jit::run` or
        // `JitScanner::scan` for this run, alive and not otherwise borrowed while the
        // generated code runs; the generated code does not run while this slice is in use
        // (it is waiting for this helper).
        unsafe { std::slice::from_raw_parts_mut(self.mem, self.len) }
    }

    fn engine<'e>(&self) -> &'e Engine {
        // SAFETY: set from an `&Engine` (`Jit::run`) or the `Arc<Engine>` a scanner owns,
        // alive for the whole run.
        unsafe { &*self.engine }
    }

    fn check<'f>(&self) -> &'f mut dyn FnMut() -> bool {
        // SAFETY: `check` points to the `&mut dyn FnMut() -> bool` of the caller of
        // `Jit::run` or `JitScanner::scan`, alive and untouched by it for the whole run;
        // only one helper runs at a time, and each drops this borrow before returning.
        unsafe { &mut **(self.check as *mut &mut dyn FnMut() -> bool) }
    }

    fn catch(&mut self, f: impl FnOnce(&mut Self) -> u32) -> u32 {
        // The payload is dropped: the machine reports an internal error, as for the VM.
        catch_unwind(AssertUnwindSafe(|| f(self))).unwrap_or(PANIC)
    }

    fn fault(&mut self, f: RawFault) -> u32 {
        self.fault = Some(Box::new(f));
        FAULT
    }
}

/// Runs the data instruction at `pc` in the VM.
pub(crate) extern "C" fn h_step(c: *mut u8, pc: u32, base: u64) -> u32 {
    let c = ctx(c);
    c.catch(|c| {
        let engine = c.engine();
        let (code, natives, now) = (&engine.code, engine.natives(), c.now);
        match exec::exec_one(code, natives, c.mem(), pc, base as usize, now) {
            Ok(()) => OK,
            Err(f) => c.fault(f),
        }
    })
}

/// The fault of a control instruction (`what`: [`Control`] as a number).
pub(crate) extern "C" fn h_fault(c: *mut u8, pc: u32, what: u32) -> u32 {
    let what = match what {
        0 => Control::Loop,
        1 => Control::For,
        2 => Control::Check,
        _ => Control::Depth,
    };
    ctx(c).fault(exec::control_fault(pc, what))
}

/// The watchdog check, every 65 536 iterations.
pub(crate) extern "C" fn h_check(c: *mut u8, pc: u32) -> u32 {
    let c = ctx(c);
    c.catch(|c| {
        if (c.check())() {
            OK
        } else {
            c.fault(exec::control_fault(pc, Control::Check))
        }
    })
}

/// The end of a FOR iteration at `pc`: [`AGAIN`], [`OK`] (leave the loop) or a fault.
pub(crate) extern "C" fn h_for(c: *mut u8, pc: u32, base: u64) -> u32 {
    let c = ctx(c);
    c.catch(|c| {
        let Some(&Op::ForNext {
            v, to, by, r, u, ..
        }) = c.engine().code.ops.get(pc as usize)
        else {
            return c.fault(RawFault {
                pc,
                error: FaultKind::Internal,
                detail: "not a FOR loop's end".into(),
            });
        };
        let mem = c.mem();
        let mut budget = Budget {
            iterations: c.iterations,
            check: c.check(),
        };
        let r = exec::for_next(mem, base as usize, v, to, by, r, u, &mut budget);
        c.iterations = budget.iterations;
        match r {
            Ok(true) => AGAIN,
            Ok(false) => OK,
            Err(k) => c.fault(exec::control_fault(pc, k)),
        }
    })
}

/// A frame that does not fit the memory: the VM would have stopped on an index out of
/// bounds (a bug in the engine), so the same panic.
pub(crate) extern "C" fn h_oob(c: *mut u8, pc: u32) -> u32 {
    let c = ctx(c);
    c.catch(|_| panic!("frame out of the machine's memory at instruction {pc}"))
}

/// Machine code owned with its entry points.
pub struct Jit {
    module: Option<JITModule>,
    /// Per program instance: its generated entry, and the call depth it starts at (1 when
    /// it is the program itself, its instance's glue being only the call).
    entries: Vec<Option<(*const u8, u64)>>,
    /// The whole scan (every instance once, in order, each with the full budget), and the
    /// depth it starts at: the one instance's entry when there is one, else a generated
    /// function calling them all.
    scan: (*const u8, u64),
    slots: usize,
}

// SAFETY: after `finalize_definitions` the module is never used again except to free its
// memory on drop; the code it holds is immutable and position-independent of any thread,
// so calling the entries from several threads at once is sound (each call has its own
// memory and context).
unsafe impl Send for Jit {}
unsafe impl Sync for Jit {}

impl std::fmt::Debug for Jit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Jit")
            .field("instances", &self.compiled_instances())
            .field("slots", &self.slots)
            .finish()
    }
}

impl Drop for Jit {
    fn drop(&mut self) {
        if let Some(m) = self.module.take() {
            // SAFETY: the Jit is dropped with its engine, when no machine runs it any more
            // (a scanner holds the engine).
            unsafe { m.free_memory() };
        }
    }
}

impl Jit {
    pub(crate) fn new(
        module: JITModule,
        entries: Vec<Option<(*const u8, u64)>>,
        scan: (*const u8, u64),
        slots: usize,
    ) -> Self {
        Jit {
            module: Some(module),
            entries,
            scan,
            slots,
        }
    }

    /// How many program instances have machine code.
    pub fn compiled_instances(&self) -> usize {
        self.entries.iter().filter(|e| e.is_some()).count()
    }
}

/// Calls generated function `entry` on `mem` with context `c`.
///
/// # Safety
/// `entry` is a finalized function of a live [`Jit`] with the [`Entry`] signature,
/// compiled for memories of `c.len` slots, and `c` points to `mem`/`len` and to a live
/// engine and check for the whole call.
#[inline(always)]
unsafe fn enter(entry: *const u8, c: &mut Ctx) -> u32 {
    // SAFETY: see the function's contract; the module's comment says why the generated
    // code's accesses are in bounds.
    let f: Entry = unsafe { std::mem::transmute::<*const u8, Entry>(entry) };
    f(c.mem, 0, c as *mut Ctx as *mut u8)
}

impl Compiled for Jit {
    fn run(
        &self,
        engine: &Engine,
        instance: usize,
        mem: &mut [u64],
        now: i64,
        budget: &mut Budget<'_>,
    ) -> Ran {
        let Some(&Some((entry, depth))) = self.entries.get(instance) else {
            return Ran::NotCompiled;
        };
        // The length is what the generated code's accesses were checked against (the code
        // itself is only read by the helpers, by safe indexing).
        if mem.len() != self.slots {
            return Ran::NotCompiled;
        }
        let mut c = Ctx {
            iterations: budget.iterations,
            depth,
            start_iterations: budget.iterations,
            instance: instance as u64,
            mem: mem.as_mut_ptr(),
            len: mem.len(),
            engine,
            now,
            check: &mut budget.check as *mut &mut dyn FnMut() -> bool as *mut u8,
            fault: None,
        };
        // SAFETY: `entry` is a finalized function of `self.module`, compiled for memories
        // of `self.slots` slots (checked above); `c` points to `mem`, `engine` and
        // `budget.check`, borrowed for this call.
        let status = unsafe { enter(entry, &mut c) };
        budget.iterations = c.iterations;
        match status {
            OK | HALT => Ran::Done,
            _ => stopped(status, c.fault.take()),
        }
    }

    fn scanner(&self, engine: &Arc<Engine>) -> Option<Box<dyn Scanner>> {
        // Only for the engine this code was made for: its entries are in it.
        let own = engine
            .compiled()
            .is_some_and(|c| std::ptr::addr_eq(c as *const dyn Compiled, self as *const Jit));
        if !own {
            return None;
        }
        let first = engine.scan_order().first().copied().unwrap_or(0);
        Some(Box::new(JitScanner {
            entry: self.scan.0,
            depth: self.scan.1,
            slots: self.slots,
            ctx: Ctx {
                iterations: 0,
                depth: 0,
                start_iterations: 0,
                // The whole-scan function sets it when it runs several instances.
                instance: u64::from(first),
                mem: std::ptr::null_mut(),
                len: self.slots,
                engine: Arc::as_ptr(engine),
                now: 0,
                check: std::ptr::null_mut(),
                fault: None,
            },
            _engine: engine.clone(),
        }))
    }
}

/// Whole scans of one machine on machine code: the context is made once, each scan only
/// sets what changes (the memory's address, the time, the budget, the check) and enters
/// the generated whole-scan function.
pub struct JitScanner {
    entry: *const u8,
    depth: u64,
    slots: usize,
    ctx: Ctx,
    /// Keeps the engine, and with it the machine code, alive.
    _engine: Arc<Engine>,
}

// SAFETY: the raw pointers are the engine's code and the engine itself (kept alive by the
// `Arc`, immutable, shared between threads as the `Jit` and `Engine` are), and the memory
// and check of a scan, set at the start of each scan and used only during it.
unsafe impl Send for JitScanner {}
unsafe impl Sync for JitScanner {}

impl Scanner for JitScanner {
    fn scan(
        &mut self,
        mem: &mut [u64],
        now: i64,
        iterations: u64,
        mut check: &mut dyn FnMut() -> bool,
    ) -> Ran {
        if mem.len() != self.slots {
            return Ran::NotCompiled;
        }
        let c = &mut self.ctx;
        c.iterations = iterations;
        c.start_iterations = iterations;
        c.depth = self.depth;
        c.mem = mem.as_mut_ptr();
        c.now = now;
        c.check = &mut check as *mut &mut dyn FnMut() -> bool as *mut u8;
        // SAFETY: `entry` is the whole-scan function of the `Jit` of `self.engine` (alive,
        // held by the `Arc`), compiled for memories of `self.slots` slots (checked above);
        // the context points to `mem` and `check`, borrowed for this call.
        let status = unsafe { enter(self.entry, c) };
        match status {
            OK | HALT => Ran::Done,
            _ => stopped(status, c.fault.take()),
        }
    }

    fn instance(&self) -> usize {
        self.ctx.instance as usize
    }
}

/// A run that stopped on a fault or a panic.
#[cold]
fn stopped(status: u32, fault: Option<Box<RawFault>>) -> Ran {
    match (status, fault) {
        (FAULT, Some(f)) => Ran::Fault(f),
        _ => Ran::Panic,
    }
}
