//! Entering the generated code, and the helpers it calls back: the only `unsafe` of the
//! engine. What makes it sound:
//! - the generated code touches the machine's memory only at slots it has checked against
//!   the memory's length (a frame's slots at the function's entry, absolute slots when it was
//!   compiled), and the length is the one it was compiled for ([`Jit::run`] checks it);
//! - while it runs, the memory is reached only through the one raw pointer taken from the
//!   caller's `&mut [u64]`: by the generated code, and by the helpers, which make a slice of
//!   it for the duration of one instruction;
//! - a helper never unwinds into the generated code: it catches a panic, keeps it, and
//!   [`Jit::run`] resumes it once the generated code has returned;
//! - the code memory lives as long as the [`Jit`] (owned by the engine), and is only read.

use std::any::Any;
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};

use cranelift_jit::JITModule;
use petriplc_iec_vm::compile::Code;
use petriplc_iec_vm::exec::{self, Budget, Control, FaultKind, RawFault};
use petriplc_iec_vm::op::Op;
use petriplc_iec_vm::{Compiled, Engine, NativeFb, Ran};

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
pub(crate) struct Ctx<'a> {
    pub iterations: u64,
    pub depth: u64,
    mem: *mut u64,
    len: usize,
    code: &'a Code,
    natives: &'a [Box<dyn NativeFb>],
    now: i64,
    check: &'a mut dyn FnMut() -> bool,
    fault: Option<RawFault>,
    panic: Option<Box<dyn Any + Send>>,
}

pub(crate) const ITERATIONS_AT: i32 = 0;
pub(crate) const DEPTH_AT: i32 = 8;

/// The context behind the pointer the generated code passes.
fn ctx<'x>(p: *mut u8) -> &'x mut Ctx<'x> {
    // SAFETY: `p` is the `&mut Ctx` that `Jit::run` passed to the generated code, which
    // hands it on unchanged; `Jit::run` does not touch the context until the code returns.
    unsafe { &mut *(p as *mut Ctx<'x>) }
}

impl Ctx<'_> {
    fn mem<'m>(&self) -> &'m mut [u64] {
        // SAFETY: `mem`/`len` come from the `&mut [u64]` given to `Jit::run`, alive and
        // not otherwise borrowed while the generated code runs; the generated code does
        // not run while this slice is in use (it is waiting for this helper).
        unsafe { std::slice::from_raw_parts_mut(self.mem, self.len) }
    }

    fn catch(&mut self, f: impl FnOnce(&mut Self) -> u32) -> u32 {
        match catch_unwind(AssertUnwindSafe(|| f(self))) {
            Ok(s) => s,
            Err(p) => {
                self.panic = Some(p);
                PANIC
            }
        }
    }

    fn fault(&mut self, f: RawFault) -> u32 {
        self.fault = Some(f);
        FAULT
    }
}

/// Runs the data instruction at `pc` in the VM.
pub(crate) extern "C" fn h_step(c: *mut u8, pc: u32, base: u64) -> u32 {
    let c = ctx(c);
    c.catch(|c| {
        let (code, natives, now) = (c.code, c.natives, c.now);
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
        if (c.check)() {
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
        }) = c.code.ops.get(pc as usize)
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
            check: &mut *c.check,
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
    /// Per program instance: its generated entry.
    entries: Vec<Option<*const u8>>,
    ops: usize,
    slots: usize,
}

// SAFETY: after `finalize_definitions` the module is never used again except to free its
// memory on drop; the code it holds is immutable and position-independent of any thread,
// so calling the entries from several threads at once is sound (each call has its own
// memory and context).
unsafe impl Send for Jit {}
unsafe impl Sync for Jit {}

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
        entries: Vec<Option<*const u8>>,
        ops: usize,
        slots: usize,
    ) -> Self {
        Jit {
            module: Some(module),
            entries,
            ops,
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
        let Some(&Some(entry)) = self.entries.get(instance) else {
            return Ran::NotCompiled;
        };
        if mem.len() != self.slots
            || engine.code.init.len() != self.slots
            || engine.code.ops.len() != self.ops
        {
            return Ran::NotCompiled;
        }
        let mut c = Ctx {
            iterations: budget.iterations,
            depth: 0,
            mem: mem.as_mut_ptr(),
            len: mem.len(),
            code: &engine.code,
            natives: engine.natives(),
            now,
            check: &mut *budget.check,
            fault: None,
            panic: None,
        };
        // SAFETY: `entry` is a finalized function of `self.module` with the `Entry`
        // signature, compiled for memories of `self.slots` slots (checked above); see the
        // module's comment for why its memory accesses are in bounds.
        let f: Entry = unsafe { std::mem::transmute::<*const u8, Entry>(entry) };
        let status = f(c.mem, 0, &mut c as *mut Ctx as *mut u8);
        budget.iterations = c.iterations;
        match status {
            OK | HALT => Ran::Done,
            _ => stopped(status, c.fault.take(), c.panic.take()),
        }
    }
}

/// A run that stopped on a fault or a panic.
#[cold]
fn stopped(status: u32, fault: Option<RawFault>, panic: Option<Box<dyn Any + Send>>) -> Ran {
    match (status, fault, panic) {
        (FAULT, Some(f), _) => Ran::Fault(Box::new(f)),
        (_, _, Some(p)) => resume_unwind(p),
        _ => panic!("machine code returned status {status} without its cause"),
    }
}
