//! Entering the generated code, and the helpers it calls back: the only `unsafe` of the
//! engine. What makes it sound:
//! - the generated code touches the machine's memory only at slots it has checked against
//!   the memory's length (a frame's slots at the function's entry, absolute slots when it was
//!   compiled), and the length is the one it was compiled for ([`Jit::run`] checks it);
//! - while it runs, the memory is reached only through the one raw pointer taken from the
//!   caller's `&mut [u64]`: by the generated code, and by the helpers, which make a slice of
//!   it for the duration of one instruction;
//! - a helper never unwinds into the generated code: it catches a panic and returns
//!   [`PANIC`], which [`Jit::run`] reports as [`Ran::Panic`] (the VM's internal fault);
//! - the code memory lives as long as the [`Jit`] (owned by the engine), and is only read.

use std::panic::{catch_unwind, AssertUnwindSafe};

use cranelift_jit::JITModule;
use petriplc_iec_vm::exec::{self, Budget, Control, FaultKind, RawFault};
use petriplc_iec_vm::op::Op;
use petriplc_iec_vm::{Compiled, Engine, Ran};

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
/// writes the first two fields (offsets 0 and 8) and passes the rest through.
#[repr(C)]
pub(crate) struct Ctx<'a, 'b> {
    pub iterations: u64,
    pub depth: u64,
    mem: *mut u64,
    len: usize,
    engine: &'a Engine,
    now: i64,
    /// The caller's budget, by a thin pointer: copying its `check` (a wide pointer the
    /// caller has just written as two words) would stall on store forwarding every scan.
    budget: &'a mut Budget<'b>,
    fault: Option<Box<RawFault>>,
}

pub(crate) const ITERATIONS_AT: i32 = 0;
pub(crate) const DEPTH_AT: i32 = 8;

/// The context behind the pointer the generated code passes.
fn ctx<'x>(p: *mut u8) -> &'x mut Ctx<'x, 'x> {
    // SAFETY: `p` is the `&mut Ctx` that `Jit::run` passed to the generated code, which
    // hands it on unchanged; `Jit::run` does not touch the context until the code returns.
    unsafe { &mut *(p as *mut Ctx<'x, 'x>) }
}

impl Ctx<'_, '_> {
    fn mem<'m>(&self) -> &'m mut [u64] {
        // SAFETY: `mem`/`len` come from the `&mut [u64]` given to `Jit::run`, alive and
        // not otherwise borrowed while the generated code runs; the generated code does
        // not run while this slice is in use (it is waiting for this helper).
        unsafe { std::slice::from_raw_parts_mut(self.mem, self.len) }
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
        let (code, natives, now) = (&c.engine.code, c.engine.natives(), c.now);
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
        if (c.budget.check)() {
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
        }) = c.engine.code.ops.get(pc as usize)
        else {
            return c.fault(RawFault {
                pc,
                error: FaultKind::Internal,
                detail: "not a FOR loop's end".into(),
            });
        };
        let mem = c.mem();
        c.budget.iterations = c.iterations;
        let r = exec::for_next(mem, base as usize, v, to, by, r, u, c.budget);
        c.iterations = c.budget.iterations;
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
            // SAFETY: the Jit is dropped with its engine, when no machine runs it any more.
            unsafe { m.free_memory() };
        }
    }
}

impl Jit {
    pub(crate) fn new(
        module: JITModule,
        entries: Vec<Option<(*const u8, u64)>>,
        slots: usize,
    ) -> Self {
        Jit {
            module: Some(module),
            entries,
            slots,
        }
    }

    /// How many program instances have machine code.
    pub fn compiled_instances(&self) -> usize {
        self.entries.iter().filter(|e| e.is_some()).count()
    }
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
            mem: mem.as_mut_ptr(),
            len: mem.len(),
            engine,
            now,
            budget,
            fault: None,
        };
        // SAFETY: `entry` is a finalized function of `self.module` with the `Entry`
        // signature, compiled for memories of `self.slots` slots (checked above); see the
        // module's comment for why its memory accesses are in bounds.
        let f: Entry = unsafe { std::mem::transmute::<*const u8, Entry>(entry) };
        let status = f(c.mem, 0, &mut c as *mut Ctx as *mut u8);
        c.budget.iterations = c.iterations;
        match status {
            OK | HALT => Ran::Done,
            _ => stopped(status, c.fault.take()),
        }
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
