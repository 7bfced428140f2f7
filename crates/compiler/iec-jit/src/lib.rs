//! The IEC engine's compiled form: the VM's register bytecode ([`petriplc_iec_vm::op`])
//! translated to machine code with Cranelift, one function per code entry (a program
//! instance's glue, a program, a function block body, a function), run in place of the
//! instruction loop on the same memory.
//!
//! The same meaning by construction:
//! - what it compiles inline (moves, BOOL logic, the fused instructions of generated code,
//!   comparisons, jumps, calls, narrow integer `+`/`-`) computes what the VM computes;
//!   a fault it detects (an overflow) is handed to the VM's own instruction
//!   ([`exec::exec_one`]), which reports it with the VM's message;
//! - every other data instruction (conversions, standard functions, strings, arrays through
//!   pointers, native function blocks, the arithmetic that can fault in more ways) is a call
//!   to that same VM instruction;
//! - loop budgets, the watchdog check every 65 536 iterations and the call depth are the
//!   VM's, with its messages ([`exec::control_fault`], [`exec::for_next`]).
//!
//! Code the translator does not understand (a jump out of the code) makes [`compile`] fail;
//! the engine then runs on the VM alone. `PETRIPLC_JIT_DUMP=DIR` writes each function's
//! machine code to `DIR/iec_ENTRY.bin` (for `objdump -D -b binary -m i386:x86-64`).

#[allow(unsafe_code)] // the one module that enters generated code: see its comment
mod call;
mod wrap;

use std::collections::{BTreeMap, BTreeSet};

use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::{
    types, AbiParam, Block, FuncRef, InstBuilder, MemFlags, Signature, UserFuncName, Value,
};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_codegen::Context;
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{default_libcall_names, FuncId, Linkage, Module};
use petriplc_iec_vm::compile::Code;
use petriplc_iec_vm::exec::{self, MAX_DEPTH};
use petriplc_iec_vm::op::{Arith, Cmp, Op, RANGES};
use petriplc_iec_vm::Engine;

pub use call::Jit;

/// Why machine code could not be made (the VM runs the program instead).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JitError(pub String);

impl std::fmt::Display for JitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "no machine code: {}", self.0)
    }
}

impl std::error::Error for JitError {}

fn err(e: impl std::fmt::Display) -> JitError {
    JitError(e.to_string())
}

/// Programs larger than this many instructions are left to the VM: measured on the mixer
/// copies (bench/iec_scan.sh), machine code is 1.7x faster than the VM at 1 500
/// instructions (100 copies) but 1.4x slower at 15 000 (1000 copies, where straight-line
/// code of about 1 MB misses the instruction cache every scan while the VM's loop stays in
/// it), and its compile time would grow past the bytecode's.
pub const MAX_OPS: usize = 8192;

/// Compiles every program instance of `engine` to machine code, unless it is larger than
/// [`MAX_OPS`] instructions.
pub fn compile(engine: &Engine) -> Result<Jit, JitError> {
    compile_limited(engine, MAX_OPS)
}

/// Compiles every program instance of `engine` to machine code, unless it is larger than
/// `max_ops` instructions.
pub fn compile_limited(engine: &Engine, max_ops: usize) -> Result<Jit, JitError> {
    let code = &engine.code;
    let mut flags = settings::builder();
    // Cranelift's optimiser gains nothing measurable on this code (loads and stores of
    // slots, short branches) and costs a quarter of the compile time (docs/iec.md, Speed).
    flags.set("opt_level", "none").map_err(err)?;
    // The translator makes well-formed functions (the tests run with the verifier on, in
    // debug builds); in release it would cost a tenth of the compile time.
    let verify = if cfg!(debug_assertions) {
        "true"
    } else {
        "false"
    };
    flags.set("enable_verifier", verify).map_err(err)?;
    let isa = cranelift_native::builder()
        .map_err(err)?
        .finish(settings::Flags::new(flags))
        .map_err(err)?;
    let mut jb = JITBuilder::with_isa(isa, default_libcall_names());
    jb.symbol("petriplc_iec_step", call::h_step as *const u8);
    jb.symbol("petriplc_iec_fault", call::h_fault as *const u8);
    jb.symbol("petriplc_iec_check", call::h_check as *const u8);
    jb.symbol("petriplc_iec_for", call::h_for as *const u8);
    jb.symbol("petriplc_iec_oob", call::h_oob as *const u8);
    let mut module = JITModule::new(jb);
    let ptr = module.target_config().pointer_type();
    let cc = module.isa().default_call_conv();

    // Signatures: entries (mem, base, ctx) -> status; helpers (ctx, pc, x) -> status.
    let mut entry_sig = Signature::new(cc);
    entry_sig.params.extend([
        AbiParam::new(ptr),
        AbiParam::new(types::I64),
        AbiParam::new(ptr),
    ]);
    entry_sig.returns.push(AbiParam::new(types::I32));
    let mut h3 = Signature::new(cc);
    h3.params.extend([
        AbiParam::new(ptr),
        AbiParam::new(types::I32),
        AbiParam::new(types::I64),
    ]);
    h3.returns.push(AbiParam::new(types::I32));
    let mut h2 = Signature::new(cc);
    h2.params
        .extend([AbiParam::new(ptr), AbiParam::new(types::I32)]);
    h2.returns.push(AbiParam::new(types::I32));
    let mut h_fault_sig = h2.clone();
    h_fault_sig.params.push(AbiParam::new(types::I32));
    let helpers = Helpers {
        step: module
            .declare_function("petriplc_iec_step", Linkage::Import, &h3)
            .map_err(err)?,
        fault: module
            .declare_function("petriplc_iec_fault", Linkage::Import, &h_fault_sig)
            .map_err(err)?,
        check: module
            .declare_function("petriplc_iec_check", Linkage::Import, &h2)
            .map_err(err)?,
        for_next: module
            .declare_function("petriplc_iec_for", Linkage::Import, &h3)
            .map_err(err)?,
        oob: module
            .declare_function("petriplc_iec_oob", Linkage::Import, &h2)
            .map_err(err)?,
    };

    // Every code entry reachable from the instances, with the pcs of its body.
    let mut funcs: BTreeMap<u32, (FuncId, BTreeSet<u32>)> = BTreeMap::new();
    let mut todo: Vec<u32> = code.instances.iter().map(|i| i.entry).collect();
    while let Some(e) = todo.pop() {
        if funcs.contains_key(&e) {
            continue;
        }
        let (body, callees) = body_of(code, e)?;
        let id = module
            .declare_function(&format!("iec_{e}"), Linkage::Local, &entry_sig)
            .map_err(err)?;
        funcs.insert(e, (id, body));
        todo.extend(callees);
    }

    let size: usize = funcs.values().map(|(_, body)| body.len()).sum();
    if size > max_ops {
        return Err(JitError(format!(
            "{size} instructions: past {max_ops}, the VM runs faster (docs/iec.md, Speed)"
        )));
    }

    let mut ctx = Context::new();
    let mut fctx = FunctionBuilderContext::new();
    for (&entry, (id, body)) in &funcs {
        ctx.func.signature = entry_sig.clone();
        ctx.func.name = UserFuncName::user(0, id.as_u32());
        {
            let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
            let mut refs = Refs {
                helpers: [
                    module.declare_func_in_func(helpers.step, b.func),
                    module.declare_func_in_func(helpers.fault, b.func),
                    module.declare_func_in_func(helpers.check, b.func),
                    module.declare_func_in_func(helpers.for_next, b.func),
                    module.declare_func_in_func(helpers.oob, b.func),
                ],
                funcs: BTreeMap::new(),
            };
            for op in body.iter().map(|&pc| code.ops[pc as usize]) {
                if let Op::CallFb { entry: c, .. }
                | Op::CallFbI { entry: c, .. }
                | Op::CallAbs { entry: c } = op
                {
                    if let std::collections::btree_map::Entry::Vacant(v) = refs.funcs.entry(c) {
                        v.insert(module.declare_func_in_func(funcs[&c].0, b.func));
                    }
                }
            }
            Translator {
                code,
                b: &mut b,
                refs: &refs,
                slots: code.init.len() as u64,
            }
            .function(entry, body)?;
            b.seal_all_blocks();
            b.finalize();
        }
        module.define_function(*id, &mut ctx).map_err(err)?;
        if let Some(dir) = std::env::var_os("PETRIPLC_JIT_DUMP") {
            if let Some(cc) = ctx.compiled_code() {
                let _ = std::fs::write(
                    std::path::Path::new(&dir).join(format!("iec_{entry}.bin")),
                    cc.code_buffer(),
                );
            }
        }
        module.clear_context(&mut ctx);
    }
    // Per instance: the function it starts in and the call depth there. Glue that is only
    // `CallAbs program; Halt`: the program is the entry, one call deep (the glue's call
    // could not fail its depth check).
    let starts: Vec<(u32, u64)> = code
        .instances
        .iter()
        .map(
            |i| match code.ops.get(i.entry as usize..i.entry as usize + 2) {
                Some([Op::CallAbs { entry }, Op::Halt]) => (*entry, 1),
                _ => (i.entry, 0),
            },
        )
        .collect();
    // The whole scan (the instances in the engine's scan order): the one instance's function
    // itself, or a function running them all.
    let order = engine.scan_order();
    let scan = match order {
        [i] => Err(starts[*i as usize]),
        _ => Ok(scan_function(
            &mut module,
            &mut ctx,
            &mut fctx,
            &entry_sig,
            &order
                .iter()
                .map(|&i| {
                    let (e, d) = starts[i as usize];
                    (funcs[&e].0, d, i)
                })
                .collect::<Vec<_>>(),
        )?),
    };
    module.finalize_definitions().map_err(err)?;
    let entries = starts
        .iter()
        .map(|&(e, depth)| Some((module.get_finalized_function(funcs[&e].0), depth)))
        .collect();
    let scan = match scan {
        Err((e, depth)) => (module.get_finalized_function(funcs[&e].0), depth),
        Ok(id) => (module.get_finalized_function(id), 0),
    };
    Ok(Jit::new(module, entries, scan, code.init.len()))
}

/// A function `(mem, base, ctx) -> status` that runs every instance once, in order (`entries`:
/// each one's function, starting call depth and number), each with the full iteration
/// budget, and stops at the first that does not end normally (a fault or a panic), returning
/// its status.
fn scan_function(
    module: &mut JITModule,
    ctx: &mut Context,
    fctx: &mut FunctionBuilderContext,
    sig: &Signature,
    entries: &[(FuncId, u64, u32)],
) -> Result<FuncId, JitError> {
    let id = module
        .declare_function("iec_scan", Linkage::Local, sig)
        .map_err(err)?;
    ctx.func.signature = sig.clone();
    ctx.func.name = UserFuncName::user(0, id.as_u32());
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, fctx);
        let start = b.create_block();
        b.append_block_params_for_function_params(start);
        b.switch_to_block(start);
        let mem = b.block_params(start)[0];
        let c = b.block_params(start)[2];
        let t = MemFlags::trusted();
        for &(f, depth, i) in entries {
            let fr = module.declare_func_in_func(f, b.func);
            let it = b.ins().load(types::I64, t, c, call::START_ITERATIONS_AT);
            b.ins().store(t, it, c, call::ITERATIONS_AT);
            let d = b.ins().iconst(types::I64, depth as i64);
            b.ins().store(t, d, c, call::DEPTH_AT);
            let k = b.ins().iconst(types::I64, i as i64);
            b.ins().store(t, k, c, call::INSTANCE_AT);
            let base = b.ins().iconst(types::I64, 0);
            let r = b.ins().call(fr, &[mem, base, c]);
            let r = b.inst_results(r)[0];
            // OK and HALT go on; FAULT and PANIC stop the scan.
            let bad = b.ins().band_imm(r, !(call::HALT as i64));
            let stop = b.create_block();
            let go = b.create_block();
            b.ins().brif(bad, stop, &[], go, &[]);
            b.switch_to_block(stop);
            b.ins().return_(&[r]);
            b.switch_to_block(go);
        }
        let ok = b.ins().iconst(types::I32, call::OK as i64);
        b.ins().return_(&[ok]);
        b.seal_all_blocks();
        b.finalize();
    }
    module.define_function(id, ctx).map_err(err)?;
    module.clear_context(ctx);
    Ok(id)
}

struct Helpers {
    step: FuncId,
    fault: FuncId,
    check: FuncId,
    for_next: FuncId,
    oob: FuncId,
}

struct Refs {
    /// step, fault, check, for, oob.
    helpers: [FuncRef; 5],
    funcs: BTreeMap<u32, FuncRef>,
}

/// The pcs of the code from `entry` (following jumps, to its `Ret`s and `Halt`s) and the
/// entries it calls.
fn body_of(code: &Code, entry: u32) -> Result<(BTreeSet<u32>, Vec<u32>), JitError> {
    let mut seen = BTreeSet::new();
    let mut callees = Vec::new();
    let mut todo = vec![entry];
    while let Some(pc) = todo.pop() {
        if !seen.insert(pc) {
            continue;
        }
        let Some(op) = code.ops.get(pc as usize) else {
            return Err(JitError(format!("code runs past its end from {entry}")));
        };
        match *op {
            Op::Ret | Op::Halt => {}
            Op::Jmp { t } | Op::Loop { t } => todo.push(t),
            Op::JmpF { t, .. } | Op::JmpT { t, .. } | Op::ForNext { t, .. } => {
                todo.push(t);
                todo.push(pc + 1);
            }
            Op::CallFb { entry: c, .. }
            | Op::CallFbI { entry: c, .. }
            | Op::CallAbs { entry: c } => {
                callees.push(c);
                todo.push(pc + 1);
            }
            _ => todo.push(pc + 1),
        }
    }
    Ok((seen, callees))
}

/// The highest frame slot an instruction compiled inline touches (relative to the base),
/// `None` when it touches none or is run by the VM.
fn frame_reach(code: &Code, op: &Op) -> Option<u64> {
    let max = |xs: &[u32]| xs.iter().copied().max().map(u64::from);
    match *op {
        Op::Mov { d, s } | Op::Not { d, s } | Op::BNot { d, s, .. } => max(&[d, s]),
        Op::MovK { d, .. } | Op::Lea { d, .. } | Op::LeaG { d, .. } => max(&[d]),
        Op::CondMovK { c, d, .. } | Op::CondNotMovK { c, d, .. } => max(&[c, d]),
        Op::LdG { d, .. } => max(&[d]),
        Op::StG { s, .. } => max(&[s]),
        Op::AndLits { d, start, len } | Op::OrLits { d, start, len } => {
            let lits = code.lits.get(start as usize..(start + len) as usize)?;
            lits.iter().map(|l| u64::from(l.0)).chain([d as u64]).max()
        }
        Op::CondStore { c, start, len, .. } => {
            let st = code.stores.get(start as usize..(start + len) as usize)?;
            st.iter().map(|l| u64::from(l.0)).chain([c as u64]).max()
        }
        Op::MovN { d, s, n } if n <= 16 && n > 0 => Some(u64::from(d.max(s)) + u64::from(n) - 1),
        Op::And { d, a, b }
        | Op::AndN { d, a, b }
        | Op::Or { d, a, b }
        | Op::OrN { d, a, b }
        | Op::Xor { d, a, b }
        | Op::CmpI { d, a, b, .. }
        | Op::CmpU { d, a, b, .. }
        | Op::CmpF { d, a, b, .. } => max(&[d, a, b]),
        Op::ArN {
            op: Arith::Add | Arith::Sub,
            d,
            a,
            b,
            ..
        } => max(&[d, a, b]),
        Op::ArNW {
            op: Arith::Add | Arith::Sub | Arith::Mul,
            d,
            a,
            b,
            ..
        }
        | Op::ArLW {
            op: Arith::Add | Arith::Sub | Arith::Mul,
            d,
            a,
            b,
        }
        | Op::ArUW {
            op: Arith::Add | Arith::Sub | Arith::Mul,
            d,
            a,
            b,
        } => max(&[d, a, b]),
        Op::NegNW { d, s, .. } | Op::NegLW { d, s } => max(&[d, s]),
        Op::GetBit { d, s, n, w } if n < 64 && w < 64 => max(&[d, s]),
        Op::AddrK { d, p, .. } => max(&[d, p]),
        Op::JmpF { c, .. } | Op::JmpT { c, .. } => max(&[c]),
        Op::CallFbI { p, .. } => max(&[p]),
        _ => None,
    }
}

struct Translator<'a, 'b, 'c> {
    code: &'a Code,
    b: &'a mut FunctionBuilder<'b>,
    refs: &'c Refs,
    slots: u64,
}

/// What follows an instruction.
enum Flow {
    Next,
    Ended,
}

impl Translator<'_, '_, '_> {
    fn function(&mut self, entry: u32, body: &BTreeSet<u32>) -> Result<(), JitError> {
        let ops = &self.code.ops;
        // Blocks start at jump targets and after conditional jumps.
        let mut leaders = BTreeSet::from([entry]);
        for &pc in body {
            match ops[pc as usize] {
                Op::Jmp { t } | Op::Loop { t } => {
                    leaders.insert(t);
                }
                Op::JmpF { t, .. } | Op::JmpT { t, .. } | Op::ForNext { t, .. } => {
                    leaders.insert(t);
                    leaders.insert(pc + 1);
                }
                _ => {}
            }
        }
        let start = self.b.create_block();
        self.b.append_block_params_for_function_params(start);
        self.b.switch_to_block(start);
        let params = self.b.block_params(start).to_vec();
        let (mem, base, ctx) = (params[0], params[1], params[2]);
        let blocks: BTreeMap<u32, Block> = leaders
            .iter()
            .map(|&pc| (pc, self.b.create_block()))
            .collect();

        // The frame's slots must lie in the memory: checked once here, so every access
        // below is in bounds.
        let reach = body
            .iter()
            .filter_map(|&pc| frame_reach(self.code, &ops[pc as usize]))
            .max();
        let fp = if let Some(reach) = reach {
            if reach >= self.slots || reach > (i32::MAX as u64) / 8 {
                return Err(JitError(format!("frame of {entry} too large")));
            }
            let limit = self.b.ins().iconst(types::I64, (self.slots - reach) as i64);
            let ok = self.b.ins().icmp(IntCC::UnsignedLessThan, base, limit);
            let bad = self.b.create_block();
            let go = self.b.create_block();
            self.b.ins().brif(ok, go, &[], bad, &[]);
            self.b.switch_to_block(bad);
            let pc = self.b.ins().iconst(types::I32, entry as i64);
            let call = self.b.ins().call(self.refs.helpers[4], &[ctx, pc]);
            let r = self.b.inst_results(call)[0];
            self.b.ins().return_(&[r]);
            self.b.switch_to_block(go);
            let off = self.b.ins().ishl_imm(base, 3);
            self.b.ins().iadd(mem, off)
        } else {
            mem
        };
        self.b.ins().jump(blocks[&entry], &[]);

        let env = Env { mem, base, ctx, fp };
        let mut open = false;
        for &pc in body {
            if let Some(&blk) = blocks.get(&pc) {
                if open {
                    self.b.ins().jump(blk, &[]);
                }
                self.b.switch_to_block(blk);
                open = true;
            }
            if !open {
                return Err(JitError(format!(
                    "instruction {pc} reached without a block"
                )));
            }
            let next = || -> Result<Block, JitError> {
                blocks
                    .get(&(pc + 1))
                    .copied()
                    .ok_or_else(|| JitError(format!("no block after {pc}")))
            };
            let flow = match ops[pc as usize] {
                Op::Jmp { t } => {
                    self.b.ins().jump(blocks[&t], &[]);
                    Flow::Ended
                }
                Op::JmpF { c, t } | Op::JmpT { c, t } => {
                    let v = self.ld(&env, c);
                    let after = next()?;
                    if matches!(ops[pc as usize], Op::JmpF { .. }) {
                        self.b.ins().brif(v, after, &[], blocks[&t], &[]);
                    } else {
                        self.b.ins().brif(v, blocks[&t], &[], after, &[]);
                    }
                    Flow::Ended
                }
                Op::Loop { t } => {
                    self.spend(&env, pc);
                    self.b.ins().jump(blocks[&t], &[]);
                    Flow::Ended
                }
                Op::ForNext { t, .. } => {
                    let r = self.helper(3, &env, pc, Some(base));
                    let again = self.b.ins().icmp_imm(IntCC::Equal, r, call::AGAIN as i64);
                    let other = self.b.create_block();
                    self.b.ins().brif(again, blocks[&t], &[], other, &[]);
                    self.b.switch_to_block(other);
                    let after = next()?;
                    let ret = self.b.create_block();
                    self.b.ins().brif(r, ret, &[], after, &[]);
                    self.b.switch_to_block(ret);
                    self.b.ins().return_(&[r]);
                    Flow::Ended
                }
                Op::CallFb { entry: e, inst } => {
                    let nb = self.b.ins().iadd_imm(base, inst as i64);
                    self.call(&env, pc, e, nb);
                    Flow::Next
                }
                Op::CallFbI { entry: e, p } => {
                    let nb = self.ld(&env, p);
                    self.call(&env, pc, e, nb);
                    Flow::Next
                }
                Op::CallAbs { entry: e } => {
                    let nb = self.b.ins().iconst(types::I64, 0);
                    self.call(&env, pc, e, nb);
                    Flow::Next
                }
                Op::Ret => {
                    let r = self.b.ins().iconst(types::I32, call::OK as i64);
                    self.b.ins().return_(&[r]);
                    Flow::Ended
                }
                Op::Halt => {
                    let r = self.b.ins().iconst(types::I32, call::HALT as i64);
                    self.b.ins().return_(&[r]);
                    Flow::Ended
                }
                op => {
                    if frame_reach(self.code, &op).is_some() {
                        self.data(&env, pc, op);
                    } else {
                        self.vm(&env, pc);
                    }
                    Flow::Next
                }
            };
            if let Flow::Ended = flow {
                open = false;
            }
        }
        if open {
            return Err(JitError(format!("code of {entry} runs past its end")));
        }
        Ok(())
    }

    /// An absolute slot the generated code may touch directly.
    fn abs_ok(&self, g: u32) -> bool {
        u64::from(g) < self.slots && g <= i32::MAX as u32 / 8
    }

    fn ld(&mut self, env: &Env, slot: u32) -> Value {
        self.b
            .ins()
            .load(types::I64, MemFlags::trusted(), env.fp, (slot * 8) as i32)
    }

    fn st(&mut self, env: &Env, slot: u32, v: Value) {
        self.b
            .ins()
            .store(MemFlags::trusted(), v, env.fp, (slot * 8) as i32);
    }

    fn ld_abs(&mut self, env: &Env, slot: u32) -> Value {
        self.b
            .ins()
            .load(types::I64, MemFlags::trusted(), env.mem, (slot * 8) as i32)
    }

    fn st_abs(&mut self, env: &Env, slot: u32, v: Value) {
        self.b
            .ins()
            .store(MemFlags::trusted(), v, env.mem, (slot * 8) as i32);
    }

    fn k(&mut self, v: u64) -> Value {
        self.b.ins().iconst(types::I64, v as i64)
    }

    /// Calls helper `h` (0 step, 3 for) with `(ctx, pc, x)`; returns its status.
    fn helper(&mut self, h: usize, env: &Env, pc: u32, x: Option<Value>) -> Value {
        let pcv = self.b.ins().iconst(types::I32, pc as i64);
        let args = match x {
            Some(x) => vec![env.ctx, pcv, x],
            None => vec![env.ctx, pcv],
        };
        let call = self.b.ins().call(self.refs.helpers[h], &args);
        self.b.inst_results(call)[0]
    }

    /// Returns `status` from the function when it is not OK.
    fn bail(&mut self, status: Value) {
        let ret = self.b.create_block();
        let go = self.b.create_block();
        self.b.ins().brif(status, ret, &[], go, &[]);
        self.b.switch_to_block(ret);
        self.b.ins().return_(&[status]);
        self.b.switch_to_block(go);
    }

    /// The VM runs the instruction at `pc`.
    fn vm(&mut self, env: &Env, pc: u32) {
        let r = self.helper(0, env, pc, Some(env.base));
        self.bail(r);
    }

    /// The fault of a control instruction: returned at once.
    fn control_fault(&mut self, env: &Env, pc: u32, what: u32) {
        let pcv = self.b.ins().iconst(types::I32, pc as i64);
        let w = self.b.ins().iconst(types::I32, what as i64);
        let call = self.b.ins().call(self.refs.helpers[1], &[env.ctx, pcv, w]);
        let r = self.b.inst_results(call)[0];
        self.b.ins().return_(&[r]);
    }

    /// One iteration of the budget ([`exec::spend`]).
    fn spend(&mut self, env: &Env, pc: u32) {
        let it = self.b.ins().load(
            types::I64,
            MemFlags::trusted(),
            env.ctx,
            call::ITERATIONS_AT,
        );
        let dec = self.b.ins().iadd_imm(it, -1);
        let zero = self.k(0);
        let it1 = self.b.ins().select(it, dec, zero);
        self.b
            .ins()
            .store(MemFlags::trusted(), it1, env.ctx, call::ITERATIONS_AT);
        let out = self.b.create_block();
        let go = self.b.create_block();
        self.b.ins().brif(it1, go, &[], out, &[]);
        self.b.switch_to_block(out);
        self.control_fault(env, pc, 0);
        self.b.switch_to_block(go);
        let low = self.b.ins().band_imm(it1, (exec::CHECK_EVERY - 1) as i64);
        let check = self.b.create_block();
        let done = self.b.create_block();
        self.b.ins().brif(low, done, &[], check, &[]);
        self.b.switch_to_block(check);
        let r = self.helper(2, env, pc, None);
        self.bail(r);
        self.b.ins().jump(done, &[]);
        self.b.switch_to_block(done);
    }

    /// A call of the code at `entry` with base `nb`, the VM's depth limit kept.
    fn call(&mut self, env: &Env, pc: u32, entry: u32, nb: Value) {
        let depth = self
            .b
            .ins()
            .load(types::I64, MemFlags::trusted(), env.ctx, call::DEPTH_AT);
        let deep =
            self.b
                .ins()
                .icmp_imm(IntCC::UnsignedGreaterThanOrEqual, depth, MAX_DEPTH as i64);
        let out = self.b.create_block();
        let go = self.b.create_block();
        self.b.ins().brif(deep, out, &[], go, &[]);
        self.b.switch_to_block(out);
        self.control_fault(env, pc, 3);
        self.b.switch_to_block(go);
        let d1 = self.b.ins().iadd_imm(depth, 1);
        self.b
            .ins()
            .store(MemFlags::trusted(), d1, env.ctx, call::DEPTH_AT);
        let f = self.refs.funcs[&entry];
        let call = self.b.ins().call(f, &[env.mem, nb, env.ctx]);
        let r = self.b.inst_results(call)[0];
        self.b
            .ins()
            .store(MemFlags::trusted(), depth, env.ctx, call::DEPTH_AT);
        self.bail(r);
    }

    /// A data instruction compiled inline (its frame slots are in bounds).
    fn data(&mut self, env: &Env, pc: u32, op: Op) {
        let code = self.code;
        match op {
            Op::Mov { d, s } => {
                let v = self.ld(env, s);
                self.st(env, d, v);
            }
            Op::MovK { d, k } => {
                let v = self.k(k);
                self.st(env, d, v);
            }
            Op::CondMovK { c, d, k } | Op::CondNotMovK { c, d, k } => {
                let cv = self.ld(env, c);
                let then = self.b.create_block();
                let after = self.b.create_block();
                if matches!(op, Op::CondMovK { .. }) {
                    self.b.ins().brif(cv, then, &[], after, &[]);
                } else {
                    self.b.ins().brif(cv, after, &[], then, &[]);
                }
                self.b.switch_to_block(then);
                let v = self.k(k);
                self.st(env, d, v);
                self.b.ins().jump(after, &[]);
                self.b.switch_to_block(after);
            }
            Op::AndLits { d, start, len } | Op::OrLits { d, start, len } => {
                // Stops at the first literal that decides, as the VM does: a branch per
                // literal (a load and a compare with the literal's mask) instead of
                // computing every literal, so a transition whose first place is empty costs
                // two instructions.
                let and = matches!(op, Op::AndLits { .. });
                // The literal that decides jumps to one block storing the result; no block
                // arguments (an argument on a branch to a block of several predecessors is a
                // critical edge Cranelift would split: a block per literal more to compile).
                let hit = self.b.create_block();
                let after = self.b.create_block();
                for &(s, neg) in &code.lits[start as usize..(start + len) as usize] {
                    let x = self.ld(env, s);
                    // AND: FALSE at the first literal that is FALSE (`x ^ neg == 0`); OR:
                    // TRUE at the first that is TRUE.
                    let cc = if and { IntCC::Equal } else { IntCC::NotEqual };
                    let decides = self.b.ins().icmp_imm(cc, x, neg as i64);
                    let next = self.b.create_block();
                    self.b.ins().brif(decides, hit, &[], next, &[]);
                    self.b.switch_to_block(next);
                }
                let rest = self.k(and as u64);
                self.st(env, d, rest);
                self.b.ins().jump(after, &[]);
                self.b.switch_to_block(hit);
                let decided = self.k(!and as u64);
                self.st(env, d, decided);
                self.b.ins().jump(after, &[]);
                self.b.switch_to_block(after);
            }
            Op::CondStore { c, neg, start, len } => {
                let cv = self.ld(env, c);
                let then = self.b.create_block();
                let after = self.b.create_block();
                if neg {
                    self.b.ins().brif(cv, after, &[], then, &[]);
                } else {
                    self.b.ins().brif(cv, then, &[], after, &[]);
                }
                self.b.switch_to_block(then);
                for &(s, k) in &code.stores[start as usize..(start + len) as usize] {
                    let v = self.k(k);
                    self.st(env, s, v);
                }
                self.b.ins().jump(after, &[]);
                self.b.switch_to_block(after);
            }
            Op::MovN { d, s, n } => {
                // In order, as the VM does for short runs.
                for k in 0..n {
                    let v = self.ld(env, s + k);
                    self.st(env, d + k, v);
                }
            }
            Op::And { d, a, b }
            | Op::AndN { d, a, b }
            | Op::Or { d, a, b }
            | Op::OrN { d, a, b }
            | Op::Xor { d, a, b } => {
                let x = self.ld(env, a);
                let y = self.ld(env, b);
                let v = match op {
                    Op::And { .. } => self.b.ins().band(x, y),
                    Op::AndN { .. } => {
                        let ny = self.b.ins().bxor_imm(y, 1);
                        self.b.ins().band(x, ny)
                    }
                    Op::Or { .. } => self.b.ins().bor(x, y),
                    Op::OrN { .. } => {
                        let ny = self.b.ins().bxor_imm(y, 1);
                        self.b.ins().bor(x, ny)
                    }
                    _ => self.b.ins().bxor(x, y),
                };
                self.st(env, d, v);
            }
            Op::Not { d, s } => {
                let x = self.ld(env, s);
                let v = self.b.ins().bxor_imm(x, 1);
                self.st(env, d, v);
            }
            Op::BNot { d, s, bits } => {
                let mask = if bits >= 64 {
                    u64::MAX
                } else {
                    (1u64 << bits) - 1
                };
                let x = self.ld(env, s);
                let nx = self.b.ins().bnot(x);
                let v = self.b.ins().band_imm(nx, mask as i64);
                self.st(env, d, v);
            }
            Op::GetBit { d, s, n, w } => {
                let x = self.ld(env, s);
                let sh = self.b.ins().ushr_imm(x, n as i64);
                let v = self.b.ins().band_imm(sh, ((1u64 << w) - 1) as i64);
                self.st(env, d, v);
            }
            Op::CmpI { op: c, d, a, b } | Op::CmpU { op: c, d, a, b } => {
                let signed = matches!(op, Op::CmpI { .. });
                let cc = match (c, signed) {
                    (Cmp::Eq, _) => IntCC::Equal,
                    (Cmp::Ne, _) => IntCC::NotEqual,
                    (Cmp::Lt, true) => IntCC::SignedLessThan,
                    (Cmp::Le, true) => IntCC::SignedLessThanOrEqual,
                    (Cmp::Gt, true) => IntCC::SignedGreaterThan,
                    (Cmp::Ge, true) => IntCC::SignedGreaterThanOrEqual,
                    (Cmp::Lt, false) => IntCC::UnsignedLessThan,
                    (Cmp::Le, false) => IntCC::UnsignedLessThanOrEqual,
                    (Cmp::Gt, false) => IntCC::UnsignedGreaterThan,
                    (Cmp::Ge, false) => IntCC::UnsignedGreaterThanOrEqual,
                };
                let x = self.ld(env, a);
                let y = self.ld(env, b);
                let t = self.b.ins().icmp(cc, x, y);
                let v = self.b.ins().uextend(types::I64, t);
                self.st(env, d, v);
            }
            Op::CmpF { op: c, d, a, b } => {
                let cc = match c {
                    Cmp::Eq => FloatCC::Equal,
                    Cmp::Ne => FloatCC::NotEqual,
                    Cmp::Lt => FloatCC::LessThan,
                    Cmp::Le => FloatCC::LessThanOrEqual,
                    Cmp::Gt => FloatCC::GreaterThan,
                    Cmp::Ge => FloatCC::GreaterThanOrEqual,
                };
                let x = self.ld(env, a);
                let y = self.ld(env, b);
                let fx = self.b.ins().bitcast(types::F64, MemFlags::new(), x);
                let fy = self.b.ins().bitcast(types::F64, MemFlags::new(), y);
                let t = self.b.ins().fcmp(cc, fx, fy);
                let v = self.b.ins().uextend(types::I64, t);
                self.st(env, d, v);
            }
            Op::ArN { op: ar, d, a, b, r } => {
                // Narrow values are far inside i64: the sum cannot wrap before the range
                // check, as in the VM.
                let x = self.ld(env, a);
                let y = self.ld(env, b);
                let v = if ar == Arith::Add {
                    self.b.ins().iadd(x, y)
                } else {
                    self.b.ins().isub(x, y)
                };
                let (lo, hi) = RANGES[r as usize];
                let ge = self
                    .b
                    .ins()
                    .icmp_imm(IntCC::SignedGreaterThanOrEqual, v, lo);
                let le = self.b.ins().icmp_imm(IntCC::SignedLessThanOrEqual, v, hi);
                let ok = self.b.ins().band(ge, le);
                let fast = self.b.create_block();
                let slow = self.b.create_block();
                let after = self.b.create_block();
                self.b.ins().brif(ok, fast, &[], slow, &[]);
                self.b.switch_to_block(fast);
                self.st(env, d, v);
                self.b.ins().jump(after, &[]);
                self.b.switch_to_block(slow);
                // The VM runs it again and reports the overflow in its words.
                self.vm(env, pc);
                self.b.ins().jump(after, &[]);
                self.b.switch_to_block(after);
            }
            // Wrapping arithmetic: 64-bit wrapping, then the type's low bits (the VM's
            // `wrap_to`); division and MOD, which can fault, are the VM's.
            Op::ArNW {
                op: ar @ (Arith::Add | Arith::Sub | Arith::Mul),
                d,
                a,
                b,
                r,
            } => {
                let x = self.ld(env, a);
                let y = self.ld(env, b);
                let v = wrap::wrapping(self.b, ar, x, y);
                let v = wrap::wrap_to(self.b, v, r);
                self.st(env, d, v);
            }
            Op::ArLW {
                op: ar @ (Arith::Add | Arith::Sub | Arith::Mul),
                d,
                a,
                b,
            }
            | Op::ArUW {
                op: ar @ (Arith::Add | Arith::Sub | Arith::Mul),
                d,
                a,
                b,
            } => {
                let x = self.ld(env, a);
                let y = self.ld(env, b);
                let v = wrap::wrapping(self.b, ar, x, y);
                self.st(env, d, v);
            }
            Op::NegNW { d, s, r } => {
                let x = self.ld(env, s);
                let v = self.b.ins().ineg(x);
                let v = wrap::wrap_to(self.b, v, r);
                self.st(env, d, v);
            }
            Op::NegLW { d, s } => {
                let x = self.ld(env, s);
                let v = self.b.ins().ineg(x);
                self.st(env, d, v);
            }
            Op::Lea { d, s } => {
                let v = self.b.ins().iadd_imm(env.base, s as i64);
                self.st(env, d, v);
            }
            Op::LeaG { d, g } => {
                let v = self.k(g as u64);
                self.st(env, d, v);
            }
            Op::AddrK { d, p, off } => {
                let x = self.ld(env, p);
                let v = self.b.ins().iadd_imm(x, off as i64);
                self.st(env, d, v);
            }
            Op::StG { g, s } if self.abs_ok(g) => {
                let v = self.ld(env, s);
                self.st_abs(env, g, v);
            }
            Op::LdG { d, g } if self.abs_ok(g) => {
                let v = self.ld_abs(env, g);
                self.st(env, d, v);
            }
            _ => self.vm(env, pc),
        }
    }
}

struct Env {
    mem: Value,
    base: Value,
    ctx: Value,
    /// `mem + base` in bytes: the frame.
    fp: Value,
}

#[cfg(test)]
mod tests;
