//! The register bytecode. Operands are slot numbers relative to the running code's base
//! (a function block instance's first slot; 0 for programs, functions and configuration
//! code, whose slots are absolute); `g` operands are absolute. Every value is one 64-bit slot:
//! BOOL 0/1, integers sign- or zero-extended, reals as f64 bits (REAL rounded to single
//! precision), durations and dates as i64 nanoseconds; a STRING[n] is a length slot followed
//! by its bytes, eight to a slot; a WSTRING[n] the same with its UTF-16LE bytes (2n at
//! most, the length slot counting bytes).
//!
//! Operations that can fail (overflow, division by zero, index, conversion) return a fault
//! the VM reports with the POU and line of the instruction.

/// Ranges of the narrow integer types, indexed by `r` operands (see [`range_of`]).
pub const RANGES: [(i64, i64); 9] = [
    (0, 1),
    (i8::MIN as i64, i8::MAX as i64),
    (i16::MIN as i64, i16::MAX as i64),
    (i32::MIN as i64, i32::MAX as i64),
    (0, u8::MAX as i64),
    (0, u16::MAX as i64),
    (0, u32::MAX as i64),
    (i64::MIN, i64::MAX),
    (0, i64::MAX),
];

use petriplc_iec_sema::types::Elem;

/// The `RANGES` index of an integer type narrower than 64 bits.
pub fn range_of(e: Elem) -> u8 {
    match e {
        Elem::Bool => 0,
        Elem::Sint => 1,
        Elem::Int => 2,
        Elem::Dint => 3,
        Elem::Usint | Elem::Byte | Elem::Char => 4,
        Elem::Uint | Elem::Word | Elem::Wchar => 5,
        Elem::Udint | Elem::Dword => 6,
        _ => 7,
    }
}

/// Width in bits and signedness of each `RANGES` entry: what a wrapped result keeps.
pub const WIDTHS: [(u8, bool); 9] = [
    (1, false),
    (8, true),
    (16, true),
    (32, true),
    (8, false),
    (16, false),
    (32, false),
    (64, true),
    (64, false),
];

/// `v` reduced to the low bits of range `r`'s type, sign- or zero-extended as slots hold it.
#[inline(always)]
pub fn wrap_to(v: i64, r: u8) -> i64 {
    let (bits, signed) = WIDTHS[r as usize];
    if bits >= 64 {
        v
    } else if signed {
        let sh = 64 - bits as u32;
        (v << sh) >> sh
    } else {
        v & ((1i64 << bits) - 1)
    }
}

/// `x op y` in 64-bit two's complement, or `None` for a division by zero; MOD by zero is 0,
/// as the standard defines it. The wrapping mode's signed arithmetic, narrow types included:
/// their operands are far inside i64, so only the caller's [`wrap_to`] cuts the result.
#[inline(always)]
pub fn arith_wrapping_i64(op: Arith, x: i64, y: i64) -> Option<i64> {
    Some(match op {
        Arith::Add => x.wrapping_add(y),
        Arith::Sub => x.wrapping_sub(y),
        Arith::Mul => x.wrapping_mul(y),
        Arith::Div if y == 0 => return None,
        Arith::Div => x.wrapping_div(y),
        Arith::Mod if y == 0 => 0,
        Arith::Mod => x.wrapping_rem(y),
    })
}

/// [`arith_wrapping_i64`] for 64-bit unsigned values.
#[inline(always)]
pub fn arith_wrapping_u64(op: Arith, x: u64, y: u64) -> Option<u64> {
    Some(match op {
        Arith::Add => x.wrapping_add(y),
        Arith::Sub => x.wrapping_sub(y),
        Arith::Mul => x.wrapping_mul(y),
        Arith::Div if y == 0 => return None,
        Arith::Div => x / y,
        Arith::Mod if y == 0 => 0,
        Arith::Mod => x % y,
    })
}

/// How integers of a type compute: narrow types in i64 with a range check, 64-bit signed
/// checked, 64-bit unsigned checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IntClass {
    Narrow(u8),
    Long,
    ULong,
}

pub fn int_class(e: Elem) -> IntClass {
    match e {
        Elem::Ulint | Elem::Lword => IntClass::ULong,
        Elem::Lint | Elem::Time | Elem::Ltime | Elem::Date | Elem::Tod | Elem::Dt => IntClass::Long,
        e => IntClass::Narrow(range_of(e)),
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arith {
    Add,
    Sub,
    Mul,
    Div,
    Mod,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cmp {
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Op {
    /// Stop: the end of a configuration-level code block.
    Halt,
    Mov {
        d: u32,
        s: u32,
    },
    MovK {
        d: u32,
        k: u64,
    },
    /// `if c != 0 { d = k }`: `IF c THEN x := constant; END_IF`.
    CondMovK {
        c: u32,
        d: u32,
        k: u64,
    },
    /// `if c == 0 { d = k }`.
    CondNotMovK {
        c: u32,
        d: u32,
        k: u64,
    },
    /// Absolute load and store.
    LdG {
        d: u32,
        g: u32,
    },
    StG {
        g: u32,
        s: u32,
    },
    /// `d = base + s`: the absolute address of a slot.
    Lea {
        d: u32,
        s: u32,
    },
    /// `d = g`: an absolute address.
    LeaG {
        d: u32,
        g: u32,
    },
    /// Load and store through a pointer slot `p` (plus an offset).
    LdI {
        d: u32,
        p: u32,
        off: u32,
    },
    StI {
        p: u32,
        off: u32,
        s: u32,
    },
    /// `d = p + off` (pointer arithmetic on absolute addresses).
    AddrK {
        d: u32,
        p: u32,
        off: u32,
    },
    /// `d = p + (i - lo) * stride` with `lo <= i <= hi` checked (array info `a`).
    Index {
        d: u32,
        p: u32,
        i: u32,
        a: u32,
    },
    /// `Index` over bounds known when the program runs (an ARRAY[*] in-out's dimension):
    /// slots `b`, `b + 1`, `b + 2` hold the lower bound, the upper bound and the stride.
    IndexV {
        d: u32,
        p: u32,
        i: u32,
        b: u32,
    },
    /// Copies `n` slots from address `sp` to address `dp` (pointer slots).
    CopyI {
        dp: u32,
        sp: u32,
        n: u32,
    },
    /// Copies a string from `sp` to `dp`, truncated to `cap` characters.
    StrCopyI {
        dp: u32,
        sp: u32,
        cap: u32,
    },
    /// Re-initialises `n` slots at `s` from the initial image (VAR_TEMP, a function's
    /// variables).
    Init {
        s: u32,
        n: u32,
    },

    /// `d` = AND of the literals `lits[start..start + len]` (a slot, and 1 to negate it),
    /// stopping at the first FALSE: an enabling condition in one instruction.
    AndLits {
        d: u32,
        start: u32,
        len: u32,
    },
    /// `d` = OR of the literals, stopping at the first TRUE.
    OrLits {
        d: u32,
        start: u32,
        len: u32,
    },
    /// If slot `c` (negated when `neg`) is TRUE, stores `stores[start..start + len]`
    /// (slot, constant): consecutive `IF c THEN x := constant; END_IF`.
    CondStore {
        c: u32,
        neg: bool,
        start: u32,
        len: u32,
    },
    /// Copies `n` slots from `s` to `d` (consecutive assignments of consecutive variables).
    MovN {
        d: u32,
        s: u32,
        n: u32,
    },
    Not {
        d: u32,
        s: u32,
    },
    /// Bitwise NOT within `bits` bits.
    BNot {
        d: u32,
        s: u32,
        bits: u8,
    },
    And {
        d: u32,
        a: u32,
        b: u32,
    },
    /// `a AND NOT b` on BOOL.
    AndN {
        d: u32,
        a: u32,
        b: u32,
    },
    Or {
        d: u32,
        a: u32,
        b: u32,
    },
    /// `a OR NOT b` on BOOL.
    OrN {
        d: u32,
        a: u32,
        b: u32,
    },
    Xor {
        d: u32,
        a: u32,
        b: u32,
    },
    /// `d` = the `w` bits of `s` from bit `n` (a bit: `w` 1; `.%B1`: `n` 8, `w` 8).
    GetBit {
        d: u32,
        s: u32,
        n: u8,
        w: u8,
    },
    /// `d = s` with bit `n` set to `v` (`w` 1), or its `w` bits from bit `n` set to `v`'s
    /// low `w` bits.
    SetBit {
        d: u32,
        s: u32,
        n: u8,
        w: u8,
        v: u32,
    },

    /// Integer comparisons (signed i64, unsigned u64).
    CmpI {
        op: Cmp,
        d: u32,
        a: u32,
        b: u32,
    },
    CmpU {
        op: Cmp,
        d: u32,
        a: u32,
        b: u32,
    },
    CmpF {
        op: Cmp,
        d: u32,
        a: u32,
        b: u32,
    },
    /// String comparison through pointer slots (`wide`: WSTRINGs, by UTF-16 code units).
    CmpS {
        op: Cmp,
        d: u32,
        a: u32,
        b: u32,
        wide: bool,
    },

    /// Integer arithmetic of a narrow type (range `r`), of LINT-like and ULINT-like types.
    ArN {
        op: Arith,
        d: u32,
        a: u32,
        b: u32,
        r: u8,
    },
    ArL {
        op: Arith,
        d: u32,
        a: u32,
        b: u32,
    },
    ArU {
        op: Arith,
        d: u32,
        a: u32,
        b: u32,
    },
    NegN {
        d: u32,
        s: u32,
        r: u8,
    },
    NegL {
        d: u32,
        s: u32,
    },
    /// The same operations when overflow wraps ([`petriplc_iec_sema::Overflow::Wrap`]): the
    /// result keeps the type's low bits; division by zero is still a fault.
    ArNW {
        op: Arith,
        d: u32,
        a: u32,
        b: u32,
        r: u8,
    },
    ArLW {
        op: Arith,
        d: u32,
        a: u32,
        b: u32,
    },
    ArUW {
        op: Arith,
        d: u32,
        a: u32,
        b: u32,
    },
    NegNW {
        d: u32,
        s: u32,
        r: u8,
    },
    NegLW {
        d: u32,
        s: u32,
    },
    /// Real arithmetic; `single`: REAL (rounded to f32).
    ArF {
        op: Arith,
        d: u32,
        a: u32,
        b: u32,
        single: bool,
    },
    NegF {
        d: u32,
        s: u32,
    },

    Jmp {
        t: u32,
    },
    JmpF {
        c: u32,
        t: u32,
    },
    JmpT {
        c: u32,
        t: u32,
    },
    /// A backward jump: spends one unit of the iteration budget.
    Loop {
        t: u32,
    },
    /// The end of a FOR iteration: `v += by` and back to `t` unless the next value passes
    /// `to` or leaves the range `r` of the variable's type (`u`: ULINT); spends one unit of
    /// the iteration budget.
    ForNext {
        v: u32,
        to: u32,
        by: u32,
        t: u32,
        r: u8,
        u: bool,
    },

    /// Calls user code at `entry` with base `base + inst` (a function block instance).
    CallFb {
        entry: u32,
        inst: u32,
    },
    /// Same with the instance's absolute address in slot `p`.
    CallFbI {
        entry: u32,
        p: u32,
    },
    /// Calls absolute code (a function, a program) with base 0.
    CallAbs {
        entry: u32,
    },
    /// Calls native function block `k` on the instance at `base + inst` / at address `p`.
    CallNative {
        k: u32,
        inst: u32,
    },
    CallNativeI {
        k: u32,
        p: u32,
    },
    Ret,

    /// Conversions and standard functions, described in a side table (`x` indexes
    /// [`crate::compile::Code::ext`]).
    Ext {
        x: u32,
    },
}

/// An array's bounds for [`Op::Index`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ArrayInfo {
    pub lo: i64,
    pub hi: i64,
    pub stride: u32,
}
