//! The instruction loop.

use petriplc_iec_sema::ops::OpError;

use crate::compile::Code;
use crate::ext::{self, read_str, OpFault};
use crate::native::{NativeCtx, NativeFb};
use crate::op::{arith_wrapping_i64, arith_wrapping_u64, wrap_to, Arith, Cmp, Op, RANGES};

/// A run-time fault at an instruction.
#[derive(Clone, Debug, PartialEq)]
pub struct RawFault {
    pub pc: u32,
    pub error: FaultKind,
    pub detail: String,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FaultKind {
    Op(OpError),
    IndexOutOfRange,
    /// The iteration budget of a scan is spent (a loop that does not end).
    Watchdog,
    /// A native function block reported an error.
    Native,
    /// The VM's own limits (call depth) or an internal error.
    Internal,
}

/// What one run may spend: loop iterations, and a check called every 65 536 iterations
/// (a wall-clock watchdog) that stops the run when it returns false.
pub struct Budget<'a> {
    pub iterations: u64,
    pub check: &'a mut dyn FnMut() -> bool,
}

pub const CHECK_EVERY: u64 = 65_536;
pub const MAX_DEPTH: usize = 4096;

#[inline(always)]
fn cmp_i(op: Cmp, a: i64, b: i64) -> bool {
    match op {
        Cmp::Eq => a == b,
        Cmp::Ne => a != b,
        Cmp::Lt => a < b,
        Cmp::Le => a <= b,
        Cmp::Gt => a > b,
        Cmp::Ge => a >= b,
    }
}

#[inline(always)]
fn cmp_u(op: Cmp, a: u64, b: u64) -> bool {
    match op {
        Cmp::Eq => a == b,
        Cmp::Ne => a != b,
        Cmp::Lt => a < b,
        Cmp::Le => a <= b,
        Cmp::Gt => a > b,
        Cmp::Ge => a >= b,
    }
}

fn cmp_f(op: Cmp, a: f64, b: f64) -> bool {
    match op {
        Cmp::Eq => a == b,
        Cmp::Ne => a != b,
        Cmp::Lt => a < b,
        Cmp::Le => a <= b,
        Cmp::Gt => a > b,
        Cmp::Ge => a >= b,
    }
}

/// A comparison's result from the operands' order.
fn cmp_ord(op: Cmp, o: std::cmp::Ordering) -> bool {
    use std::cmp::Ordering::*;
    match op {
        Cmp::Eq => o == Equal,
        Cmp::Ne => o != Equal,
        Cmp::Lt => o == Less,
        Cmp::Le => o != Greater,
        Cmp::Gt => o == Greater,
        Cmp::Ge => o != Less,
    }
}

fn sym(op: Arith) -> &'static str {
    match op {
        Arith::Add => "+",
        Arith::Sub => "-",
        Arith::Mul => "*",
        Arith::Div => "/",
        Arith::Mod => "MOD",
    }
}

fn range_text(r: u8) -> String {
    let (lo, hi) = RANGES[r as usize];
    format!("{lo}..{hi}")
}

/// The instructions generated code is mostly made of, in one `match` with the caller's
/// other arms (`$rest`): the instruction loop dispatches once, and [`exec_one`] runs the
/// same text.
macro_rules! hot {
    ($op:expr, $code:ident, $mem:ident, $base:ident, { $($rest:tt)* }) => {
        match $op {
            Op::Mov { d, s } => $mem[$base + d as usize] = $mem[$base + s as usize],
            Op::MovK { d, k } => $mem[$base + d as usize] = k,
            Op::CondMovK { c, d, k } => {
                if $mem[$base + c as usize] != 0 {
                    $mem[$base + d as usize] = k
                }
            }
            Op::CondNotMovK { c, d, k } => {
                if $mem[$base + c as usize] == 0 {
                    $mem[$base + d as usize] = k
                }
            }
            Op::AndLits { d, start, len } => {
                let mut v = 1;
                for &(s, neg) in &$code.lits[start as usize..(start + len) as usize] {
                    if $mem[$base + s as usize] ^ neg == 0 {
                        v = 0;
                        break;
                    }
                }
                $mem[$base + d as usize] = v;
            }
            Op::OrLits { d, start, len } => {
                let mut v = 0;
                for &(s, neg) in &$code.lits[start as usize..(start + len) as usize] {
                    if $mem[$base + s as usize] ^ neg != 0 {
                        v = 1;
                        break;
                    }
                }
                $mem[$base + d as usize] = v;
            }
            Op::CondStore { c, neg, start, len } => {
                if ($mem[$base + c as usize] != 0) != neg {
                    for &(s, k) in &$code.stores[start as usize..(start + len) as usize] {
                        $mem[$base + s as usize] = k;
                    }
                }
            }
            Op::MovN { d, s, n } => {
                let (d, s, n) = ($base + d as usize, $base + s as usize, n as usize);
                if n <= 16 {
                    for k in 0..n {
                        $mem[d + k] = $mem[s + k];
                    }
                } else {
                    $mem.copy_within(s..s + n, d);
                }
            }
            Op::And { d, a, b } => {
                $mem[$base + d as usize] = $mem[$base + a as usize] & $mem[$base + b as usize]
            }
            Op::AndN { d, a, b } => {
                $mem[$base + d as usize] =
                    $mem[$base + a as usize] & ($mem[$base + b as usize] ^ 1)
            }
            Op::Or { d, a, b } => {
                $mem[$base + d as usize] = $mem[$base + a as usize] | $mem[$base + b as usize]
            }
            Op::OrN { d, a, b } => {
                $mem[$base + d as usize] =
                    $mem[$base + a as usize] | ($mem[$base + b as usize] ^ 1)
            }
            Op::Xor { d, a, b } => {
                $mem[$base + d as usize] = $mem[$base + a as usize] ^ $mem[$base + b as usize]
            }
            Op::Not { d, s } => $mem[$base + d as usize] = $mem[$base + s as usize] ^ 1,
            $($rest)*
        }
    };
}

/// Runs from `entry` until its `Halt` (or the final `Ret`).
pub fn run(
    code: &Code,
    natives: &[Box<dyn NativeFb>],
    mem: &mut [u64],
    entry: u32,
    now: i64,
    budget: &mut Budget<'_>,
    stack: &mut Vec<(u32, u32)>,
) -> Result<(), RawFault> {
    let ops = &code.ops[..];
    let mut pc = entry as usize;
    let mut base = 0usize;
    stack.clear();
    macro_rules! m {
        ($x:expr) => {
            mem[base + $x as usize]
        };
    }
    loop {
        let op = ops[pc];
        pc += 1;
        hot!(op, code, mem, base, {
            Op::JmpF { c, t } => {
                if m!(c) == 0 {
                    pc = t as usize
                }
            }
            Op::JmpT { c, t } => {
                if m!(c) != 0 {
                    pc = t as usize
                }
            }
            Op::Jmp { t } => pc = t as usize,
            Op::Loop { t } => {
                if let Err(k) = spend(budget, Control::Loop) {
                    return Err(control_fault((pc - 1) as u32, k));
                }
                pc = t as usize;
            }
            Op::ForNext { v, to, by, t, r, u } => {
                match for_next(mem, base, v, to, by, r, u, budget) {
                    Ok(true) => pc = t as usize,
                    Ok(false) => {}
                    Err(k) => return Err(control_fault((pc - 1) as u32, k)),
                }
            }
            Op::CallFb { entry, inst } => {
                if stack.len() >= MAX_DEPTH {
                    return Err(control_fault((pc - 1) as u32, Control::Depth));
                }
                stack.push((pc as u32, base as u32));
                base += inst as usize;
                pc = entry as usize;
            }
            Op::CallFbI { entry, p } => {
                if stack.len() >= MAX_DEPTH {
                    return Err(control_fault((pc - 1) as u32, Control::Depth));
                }
                let at = m!(p) as usize;
                stack.push((pc as u32, base as u32));
                base = at;
                pc = entry as usize;
            }
            Op::CallAbs { entry } => {
                if stack.len() >= MAX_DEPTH {
                    return Err(control_fault((pc - 1) as u32, Control::Depth));
                }
                stack.push((pc as u32, base as u32));
                base = 0;
                pc = entry as usize;
            }
            Op::Ret => match stack.pop() {
                Some((p, b)) => {
                    pc = p as usize;
                    base = b as usize;
                }
                None => return Ok(()),
            },
            Op::Halt => return Ok(()),
            op => data(op, code, natives, mem, base, now, pc - 1)?,
        });
    }
}

/// Whether an instruction changes the flow (jumps, loops, calls, returns): those the
/// instruction loop runs itself; every other one is a data instruction ([`exec_one`]).
pub fn is_control(op: &Op) -> bool {
    matches!(
        op,
        Op::Jmp { .. }
            | Op::JmpF { .. }
            | Op::JmpT { .. }
            | Op::Loop { .. }
            | Op::ForNext { .. }
            | Op::CallFb { .. }
            | Op::CallFbI { .. }
            | Op::CallAbs { .. }
            | Op::Ret
            | Op::Halt
    )
}

/// Runs the one data instruction at `pc` with `base`, exactly as the instruction loop does
/// (compiled code calls it for what it does not compile itself, and to report a fault with
/// the VM's own message). A control instruction is an internal fault.
pub fn exec_one(
    code: &Code,
    natives: &[Box<dyn NativeFb>],
    mem: &mut [u64],
    pc: u32,
    base: usize,
    now: i64,
) -> Result<(), RawFault> {
    match code.ops.get(pc as usize) {
        Some(op) => data(*op, code, natives, mem, base, now, pc as usize),
        None => Err(RawFault {
            pc,
            error: FaultKind::Internal,
            detail: "no instruction there".into(),
        }),
    }
}

/// What stopped a control instruction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    /// A backward jump (WHILE, REPEAT) past the iteration budget.
    Loop,
    /// A FOR loop past the iteration budget.
    For,
    /// The watchdog check said stop.
    Check,
    /// Calls nested deeper than the VM allows.
    Depth,
}

/// The fault of a control instruction at `pc`.
pub fn control_fault(pc: u32, what: Control) -> RawFault {
    let (error, detail) = match what {
        Control::Loop => (
            FaultKind::Watchdog,
            "a loop ran out of the scan's iteration budget",
        ),
        Control::For => (
            FaultKind::Watchdog,
            "a FOR loop ran out of the scan's iteration budget",
        ),
        Control::Check => (FaultKind::Watchdog, "a loop ran past the watchdog time"),
        Control::Depth => (FaultKind::Internal, "calls nested too deeply"),
    };
    RawFault {
        pc,
        error,
        detail: detail.into(),
    }
}

/// Spends one loop iteration (`what`: Loop or For, for the message).
#[inline(always)]
pub fn spend(budget: &mut Budget<'_>, what: Control) -> Result<(), Control> {
    budget.iterations = budget.iterations.saturating_sub(1);
    if budget.iterations == 0 {
        return Err(what);
    }
    if budget.iterations % CHECK_EVERY == 0 && !(budget.check)() {
        return Err(Control::Check);
    }
    Ok(())
}

/// The end of a FOR iteration ([`Op::ForNext`]): whether to go round again.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn for_next(
    mem: &mut [u64],
    base: usize,
    v: u32,
    to: u32,
    by: u32,
    r: u8,
    u: bool,
    budget: &mut Budget<'_>,
) -> Result<bool, Control> {
    macro_rules! m {
        ($x:expr) => {
            mem[base + $x as usize]
        };
    }
    let next_ok = if u {
        match m!(v).checked_add(m!(by)) {
            Some(n) => {
                m!(v) = n;
                n <= m!(to)
            }
            None => false,
        }
    } else {
        let step = m!(by) as i64 as i128;
        let n = m!(v) as i64 as i128 + step;
        let (lo, hi) = RANGES[r as usize];
        if n < lo as i128 || n > hi as i128 {
            false
        } else {
            m!(v) = n as i64 as u64;
            let lim = m!(to) as i64 as i128;
            if step > 0 {
                n <= lim
            } else {
                n >= lim
            }
        }
    };
    if next_ok {
        spend(budget, Control::For)?;
    }
    Ok(next_ok)
}

/// One data instruction (`op_pc`: its pc, for faults).
#[inline(always)]
fn data(
    op: Op,
    code: &Code,
    natives: &[Box<dyn NativeFb>],
    mem: &mut [u64],
    base: usize,
    now: i64,
    op_pc: usize,
) -> Result<(), RawFault> {
    macro_rules! m {
        ($x:expr) => {
            mem[base + $x as usize]
        };
    }
    macro_rules! fail {
        ($kind:expr, $detail:expr) => {
            return Err(RawFault {
                pc: op_pc as u32,
                error: $kind,
                detail: $detail,
            })
        };
    }
    hot!(op, code, mem, base, {
        Op::CmpI { op, d, a, b } => m!(d) = cmp_i(op, m!(a) as i64, m!(b) as i64) as u64,
        Op::CmpU { op, d, a, b } => m!(d) = cmp_u(op, m!(a), m!(b)) as u64,
        Op::CmpF { op, d, a, b } => {
            m!(d) = cmp_f(op, f64::from_bits(m!(a)), f64::from_bits(m!(b))) as u64
        }
        Op::CmpS { op, d, a, b, wide } => {
            let (x, y) = (m!(a) as usize, m!(b) as usize);
            // Equal bytes are equal units; the order of WSTRINGs is their units' order.
            let r = if wide && !matches!(op, Cmp::Eq | Cmp::Ne) {
                cmp_ord(op, ext::read_units(mem, x).cmp(&ext::read_units(mem, y)))
            } else {
                cmp_ord(op, read_str(mem, x).cmp(&read_str(mem, y)))
            };
            m!(d) = r as u64;
        }
        Op::ArN { op, d, a, b, r } => {
            let (x, y) = (m!(a) as i64, m!(b) as i64);
            let v = match op {
                Arith::Add => x + y,
                Arith::Sub => x - y,
                Arith::Mul => match x.checked_mul(y) {
                    Some(v) => v,
                    None => fail!(
                        FaultKind::Op(OpError::Overflow),
                        format!("{x} * {y} leaves {}", range_text(r))
                    ),
                },
                Arith::Div => {
                    if y == 0 {
                        fail!(FaultKind::Op(OpError::DivisionByZero), format!("{x} / 0"));
                    }
                    x / y
                }
                Arith::Mod => {
                    if y == 0 {
                        0
                    } else {
                        x % y
                    }
                }
            };
            let (lo, hi) = RANGES[r as usize];
            if v < lo || v > hi {
                fail!(
                    FaultKind::Op(OpError::Overflow),
                    format!("{x} {} {y} = {v} leaves {}", sym(op), range_text(r))
                );
            }
            m!(d) = v as u64;
        }
        Op::ArL { op, d, a, b } => {
            let (x, y) = (m!(a) as i64, m!(b) as i64);
            let v = match op {
                Arith::Add => x.checked_add(y),
                Arith::Sub => x.checked_sub(y),
                Arith::Mul => x.checked_mul(y),
                Arith::Div => {
                    if y == 0 {
                        fail!(FaultKind::Op(OpError::DivisionByZero), format!("{x} / 0"));
                    }
                    x.checked_div(y)
                }
                Arith::Mod => Some(if y == 0 { 0 } else { x.wrapping_rem(y) }),
            };
            match v {
                Some(v) => m!(d) = v as u64,
                None => fail!(
                    FaultKind::Op(OpError::Overflow),
                    format!("{x} {} {y} leaves the 64-bit range", sym(op))
                ),
            }
        }
        Op::ArU { op, d, a, b } => {
            let (x, y) = (m!(a), m!(b));
            let v = match op {
                Arith::Add => x.checked_add(y),
                Arith::Sub => x.checked_sub(y),
                Arith::Mul => x.checked_mul(y),
                Arith::Div => {
                    if y == 0 {
                        fail!(FaultKind::Op(OpError::DivisionByZero), format!("{x} / 0"));
                    }
                    Some(x / y)
                }
                Arith::Mod => Some(if y == 0 { 0 } else { x % y }),
            };
            match v {
                Some(v) => m!(d) = v,
                None => fail!(
                    FaultKind::Op(OpError::Overflow),
                    format!("{x} {} {y} leaves 0..18446744073709551615", sym(op))
                ),
            }
        }
        Op::ArF {
            op,
            d,
            a,
            b,
            single,
        } => {
            // IEC 60559 arithmetic: Inf and NaN are values like any other (docs/iec.md).
            let (x, y) = (f64::from_bits(m!(a)), f64::from_bits(m!(b)));
            let v = match op {
                Arith::Add => x + y,
                Arith::Sub => x - y,
                Arith::Mul => x * y,
                Arith::Div => x / y,
                Arith::Mod => 0.0,
            };
            let v = if single { v as f32 as f64 } else { v };
            m!(d) = v.to_bits();
        }
        Op::NegN { d, s, r } => {
            let v = -(m!(s) as i64);
            let (lo, hi) = RANGES[r as usize];
            if v < lo || v > hi {
                fail!(
                    FaultKind::Op(OpError::Overflow),
                    format!("-({}) leaves {}", -v, range_text(r))
                );
            }
            m!(d) = v as u64;
        }
        Op::NegL { d, s } => match (m!(s) as i64).checked_neg() {
            Some(v) => m!(d) = v as u64,
            None => fail!(
                FaultKind::Op(OpError::Overflow),
                format!("-({}) leaves the 64-bit range", m!(s) as i64)
            ),
        },
        Op::ArNW { op, d, a, b, r } => {
            let (x, y) = (m!(a) as i64, m!(b) as i64);
            let Some(v) = arith_wrapping_i64(op, x, y) else {
                fail!(FaultKind::Op(OpError::DivisionByZero), format!("{x} / 0"));
            };
            m!(d) = wrap_to(v, r) as u64;
        }
        Op::ArLW { op, d, a, b } => {
            let (x, y) = (m!(a) as i64, m!(b) as i64);
            let Some(v) = arith_wrapping_i64(op, x, y) else {
                fail!(FaultKind::Op(OpError::DivisionByZero), format!("{x} / 0"));
            };
            m!(d) = v as u64;
        }
        Op::ArUW { op, d, a, b } => {
            let (x, y) = (m!(a), m!(b));
            let Some(v) = arith_wrapping_u64(op, x, y) else {
                fail!(FaultKind::Op(OpError::DivisionByZero), format!("{x} / 0"));
            };
            m!(d) = v;
        }
        Op::NegNW { d, s, r } => m!(d) = wrap_to((m!(s) as i64).wrapping_neg(), r) as u64,
        Op::NegLW { d, s } => m!(d) = (m!(s) as i64).wrapping_neg() as u64,
        Op::NegF { d, s } => m!(d) = (-f64::from_bits(m!(s))).to_bits(),
        Op::BNot { d, s, bits } => {
            let mask = if bits >= 64 {
                u64::MAX
            } else {
                (1u64 << bits) - 1
            };
            m!(d) = !m!(s) & mask;
        }
        Op::GetBit { d, s, n, w: 1 } => m!(d) = (m!(s) >> n) & 1,
        Op::GetBit { d, s, n, w } => m!(d) = (m!(s) >> n) & part_mask(w),
        Op::SetBit { d, s, n, w: 1, v } => {
            let w = m!(s);
            m!(d) = if m!(v) != 0 {
                w | (1 << n)
            } else {
                w & !(1 << n)
            };
        }
        Op::SetBit { d, s, n, w, v } => {
            let mask = part_mask(w) << n;
            m!(d) = (m!(s) & !mask) | ((m!(v) << n) & mask);
        }
        Op::LdG { d, g } => m!(d) = mem[g as usize],
        Op::StG { g, s } => mem[g as usize] = m!(s),
        Op::Lea { d, s } => m!(d) = (base + s as usize) as u64,
        Op::LeaG { d, g } => m!(d) = g as u64,
        Op::LdI { d, p, off } => {
            let at = m!(p) as usize + off as usize;
            m!(d) = mem[at];
        }
        Op::StI { p, off, s } => {
            let at = m!(p) as usize + off as usize;
            mem[at] = m!(s);
        }
        Op::AddrK { d, p, off } => m!(d) = m!(p) + off as u64,
        Op::Index { d, p, i, a } => {
            let info = code.arrays[a as usize];
            let idx = m!(i) as i64;
            if idx < info.lo || idx > info.hi {
                fail!(
                    FaultKind::IndexOutOfRange,
                    format!(
                        "index {idx} is outside the array's bounds {}..{}",
                        info.lo, info.hi
                    )
                );
            }
            m!(d) = m!(p) + ((idx - info.lo) as u64) * info.stride as u64;
        }
        Op::IndexV { d, p, i, b } => {
            let (lo, hi, stride) = (m!(b) as i64, m!(b + 1) as i64, m!(b + 2));
            let idx = m!(i) as i64;
            if idx < lo || idx > hi {
                fail!(
                    FaultKind::IndexOutOfRange,
                    format!("index {idx} is outside the array's bounds {lo}..{hi}")
                );
            }
            m!(d) = m!(p).wrapping_add(((idx - lo) as u64).wrapping_mul(stride));
        }
        Op::CopyI { dp, sp, n } => {
            let (to, from) = (m!(dp) as usize, m!(sp) as usize);
            if to != from {
                mem.copy_within(from..from + n as usize, to);
            }
        }
        Op::StrCopyI { dp, sp, cap } => {
            let (to, from) = (m!(dp) as usize, m!(sp) as usize);
            let len = mem[from].min(cap as u64);
            let words = (len as usize).div_ceil(8);
            if to != from {
                mem.copy_within(from + 1..from + 1 + words, to + 1);
            }
            mem[to] = len;
        }
        Op::Init { s, n } => {
            let at = base + s as usize;
            mem[at..at + n as usize].copy_from_slice(&code.init[at..at + n as usize]);
        }
        Op::CallNative { k, inst } => {
            let at = base + inst as usize;
            let nat = &natives[k as usize];
            let n = code.native_sizes[k as usize] as usize;
            if let Err(msg) = nat.call(&mut mem[at..at + n], &NativeCtx { now }) {
                fail!(FaultKind::Native, msg);
            }
        }
        Op::CallNativeI { k, p } => {
            let at = m!(p) as usize;
            let nat = &natives[k as usize];
            let n = code.native_sizes[k as usize] as usize;
            if let Err(msg) = nat.call(&mut mem[at..at + n], &NativeCtx { now }) {
                fail!(FaultKind::Native, msg);
            }
        }
        Op::Ext { x } => {
            let op = &code.ext[x as usize];
            let r = crate::pointer::exec(op, &code.shapes, mem, base)
                .unwrap_or_else(|| ext::exec(op, mem, base, code.overflow, now));
            if let Err(OpFault { error, detail }) = r {
                fail!(FaultKind::Op(error), detail);
            }
        }
        _ => fail!(FaultKind::Internal, "a control instruction out of place".into()),
    });
    Ok(())
}

/// The mask of a part `w` bits wide (a partial access `.%B`, `.%W`, `.%D`).
#[inline]
fn part_mask(w: u8) -> u64 {
    if w >= 64 {
        u64::MAX
    } else {
        (1u64 << w) - 1
    }
}
