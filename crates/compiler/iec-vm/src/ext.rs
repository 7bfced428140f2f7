//! The VM's slower operations, out of the main instruction loop: conversions, standard
//! functions, string functions, time arithmetic and range checks. Their meaning comes from
//! [`petriplc_iec_sema::ops`], the same code the checker folds constants with.

use petriplc_iec_sema::ir::Builtin;
use petriplc_iec_sema::ops::{self, OpError, Overflow};
use petriplc_iec_sema::types::{fits, wrap, Elem};
use petriplc_iec_sema::value::Value;
use petriplc_iec_syntax::ast::BinaryOp;
use petriplc_iec_syntax::lexer::NANOS_PER_DAY;

/// How values of a generic function's type compare.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Signed integers, BOOL, durations, dates, enumerations (as i64).
    I,
    /// 64-bit unsigned (ULINT, LWORD).
    U,
    F,
    /// Strings: operands are pointer slots.
    S,
    /// WSTRINGs (pointer slots): compared by UTF-16 code units.
    W,
}

pub fn kind_of(e: Elem) -> Kind {
    match e {
        Elem::Ulint | Elem::Lword => Kind::U,
        Elem::Real | Elem::Lreal => Kind::F,
        _ => Kind::I,
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum ExtOp {
    Conv {
        d: u32,
        s: u32,
        from: Elem,
        to: Elem,
    },
    /// An elementary value (or enumeration, as DINT) written as text into the buffer at
    /// pointer `dp` (capacity `cap`).
    ToStr {
        dp: u32,
        s: u32,
        from: Elem,
        cap: u32,
        wide: bool,
    },
    FromStr {
        d: u32,
        sp: u32,
        to: Elem,
        wide: bool,
    },
    /// STRING_TO_WSTRING (`wide`: to WSTRING) or WSTRING_TO_STRING: the string at pointer
    /// `sp` recoded into the buffer at pointer `dp` (capacity `cap` bytes).
    Recode {
        dp: u32,
        sp: u32,
        wide: bool,
        cap: u32,
    },
    Trunc {
        d: u32,
        s: u32,
        to: Elem,
    },
    /// `d` = the handle of the variable whose address is in `s`, of type id `ty`
    /// ([`crate::pointer`]).
    MakeRef {
        d: u32,
        s: u32,
        ty: u32,
    },
    /// `d` = the address the handle in `p` designates, checked against type id `ty` and its
    /// `n` slots; `what` is the reference type, for the fault.
    Deref {
        d: u32,
        p: u32,
        ty: u32,
        n: u32,
        what: String,
    },
    /// `__NEW`: `d` = the handle of a new object of `mem[base + n]` values of type id `ty`
    /// (`slots` each), each a copy of the prototype at absolute slot `proto`; NULL when the
    /// dynamic memory ([`crate::heap`]) is full. `n` is `None` for one value.
    New {
        d: u32,
        n: Option<u32>,
        ty: u32,
        slots: u32,
        proto: u32,
    },
    /// `__DELETE`: the object the handle in `p` designates is freed; with `by_addr`, `p`
    /// holds the address of the pointer variable, which is set to NULL.
    Free {
        p: u32,
        by_addr: bool,
    },
    /// TwinCAT's `F_CheckMemoryArea(p, n)`: `d` = 0 (Unknown: NULL, stale), 1 (Static), 2
    /// (Dynamic: a `__NEW` object).
    Area {
        d: u32,
        p: u32,
    },
    /// `d` = the pointer in `p` moved by `n` (a LINT slot) bytes, back when `sub`.
    PtrAdd {
        d: u32,
        p: u32,
        n: u32,
        sub: bool,
    },
    /// `d` = the elementary value of type `e` the pointer in `p` designates (moved by
    /// `(i - lo)` elements with `idx`), through the variable's byte image when its type
    /// differs.
    ViewLoad {
        d: u32,
        p: u32,
        idx: Option<(u32, i64)>,
        e: Elem,
        what: String,
    },
    /// MEMCPY, MEMSET, MEMCMP (`f`) over pointers `a`, `b` (MEMSET: the fill byte) and a
    /// LINT count `n`; `d` gets the result.
    Mem {
        f: Builtin,
        d: u32,
        a: u32,
        b: u32,
        n: u32,
    },
    /// The same, stored from `s`.
    ViewStore {
        s: u32,
        p: u32,
        idx: Option<(u32, i64)>,
        e: Elem,
        what: String,
    },
    /// A STRING or WSTRING of capacity `cap` read from (`load`) or written to the byte image
    /// the pointer in `p` designates (a union's string member): `s` holds the address of the
    /// string's slots. Its `cap + 1` characters must lie inside the variable.
    ViewStr {
        s: u32,
        p: u32,
        cap: u32,
        wide: bool,
        load: bool,
        what: String,
    },
    /// `d` = the interface handle in `s`, a fault when it is NULL (a method or property
    /// used through an interface: the fault's line is the call's).
    ItfCheck {
        d: u32,
        s: u32,
    },
    /// The entry of a POU that a call through an interface may enter again (W050): a fault
    /// when its busy flag `s` (a slot of its static frame) is set, else it is set.
    Enter {
        s: u32,
        pou: String,
    },
    /// The exit of such a POU: its busy flag `s` cleared.
    Leave {
        s: u32,
    },
    /// `d` = the type id of the instance the interface handle in `s` designates, -1 for NULL
    /// ([`crate::pointer::type_of`]).
    ItfType {
        d: u32,
        s: u32,
    },
    /// A value stored into a subrange: `lo <= s <= hi`.
    Check {
        d: u32,
        s: u32,
        lo: i64,
        hi: i64,
    },
    /// `a ** b`; `int_exp`: b is an integer.
    Pow {
        d: u32,
        a: u32,
        b: u32,
        e: Elem,
        int_exp: bool,
    },
    /// TIME * or / a number (`real`: the number is a real).
    TimeScale {
        d: u32,
        a: u32,
        b: u32,
        div: bool,
        real: bool,
    },
    /// Durations and dates added or subtracted (TIME + TIME, DT - DT): 64-bit nanoseconds
    /// as LINT would be, with an overflow told in the operands' own literals.
    TimeAdd {
        d: u32,
        a: u32,
        b: u32,
        sub: bool,
        of: Elem,
        to: Elem,
    },
    /// TOD ± TIME, wrapping around midnight.
    TodAdd {
        d: u32,
        a: u32,
        b: u32,
        sub: bool,
    },
    Math {
        f: Builtin,
        d: u32,
        s: u32,
        e: Elem,
    },
    AbsI {
        d: u32,
        s: u32,
        e: Elem,
    },
    Atan2 {
        d: u32,
        y: u32,
        x: u32,
        e: Elem,
    },
    /// MAX/MIN over `args` (pointers when `kind` is S; then `d` is the result buffer pointer).
    MinMax {
        max: bool,
        d: u32,
        args: Vec<u32>,
        kind: Kind,
        cap: u32,
    },
    Limit {
        d: u32,
        mn: u32,
        x: u32,
        mx: u32,
        kind: Kind,
        cap: u32,
    },
    /// SEL and MUX over scalars or (kind S) strings; `k` is G or K.
    Select {
        mux: bool,
        d: u32,
        k: u32,
        args: Vec<u32>,
        kind: Kind,
        cap: u32,
    },
    Shift {
        f: Builtin,
        d: u32,
        s: u32,
        n: u32,
        e: Elem,
    },
    /// String functions: `args` are pointers (strings) and integer slots in the standard's
    /// order; the result goes to the buffer at pointer `d` (or slot `d` for LEN and FIND).
    Str {
        f: Builtin,
        d: u32,
        args: Vec<u32>,
        cap: u32,
        wide: bool,
    },
    ConcatDateTod {
        d: u32,
        a: u32,
        b: u32,
    },
    /// BCD digits of the bit string `from` to the integer type `to` (`decode`), or an
    /// integer of type `from` to BCD digits in the bit string `to`.
    Bcd {
        d: u32,
        s: u32,
        from: Elem,
        to: Elem,
        decode: bool,
    },
    /// CODESYS `TIME()`: the scan's time, in whole milliseconds as CODESYS counts it.
    Now {
        d: u32,
    },
    /// PCWorx `GET_CHAR`: the code of the character at position `p` (1-based) of the string
    /// at pointer `s`, 0 outside it.
    GetChar {
        d: u32,
        s: u32,
        p: u32,
    },
    /// PCWorx `X_TO_STRING(value, format)`: slot `s` (of type `from`) by the C format at
    /// pointer `fmt`, into the buffer at pointer `d`.
    Format {
        d: u32,
        s: u32,
        fmt: u32,
        from: Elem,
        cap: u32,
    },
    /// TwinCAT `F_ToCHR`: the character of code `s` as a string at pointer `d` ('' for 0,
    /// as a C string ends at NUL).
    Chr {
        d: u32,
        s: u32,
        cap: u32,
    },
    /// A FOR loop's step must not be 0.
    NonZeroStep {
        s: u32,
    },
}

/// Why an operation stopped the program, with the values involved.
#[derive(Clone, Debug, PartialEq)]
pub struct OpFault {
    pub error: OpError,
    pub detail: String,
}

impl OpFault {
    pub fn new(error: OpError, detail: impl Into<String>) -> Self {
        OpFault {
            error,
            detail: detail.into(),
        }
    }
}

#[inline]
pub fn slot(mem: &[u64], base: usize, s: u32) -> u64 {
    mem[base + s as usize]
}

/// A slot's value as the checker's [`Value`] for an elementary type.
pub fn get_value(raw: u64, e: Elem) -> Value {
    if e.is_real() {
        Value::Real(f64::from_bits(raw))
    } else if matches!(e, Elem::Ulint | Elem::Lword) {
        Value::Int(raw as i128)
    } else {
        Value::Int(raw as i64 as i128)
    }
}

/// The slot holding a [`Value`] of an elementary type (integers already in range).
pub fn put_value(v: &Value, e: Elem) -> u64 {
    match v {
        Value::Real(f) => {
            if e.is_real() {
                f.to_bits()
            } else {
                *f as i64 as u64
            }
        }
        Value::Int(i) => {
            if e.is_real() {
                (*i as f64).to_bits()
            } else {
                *i as i64 as u64
            }
        }
        _ => 0,
    }
}

/// Reads the string stored at absolute address `at`.
pub fn read_str(mem: &[u64], at: usize) -> Vec<u8> {
    let len = mem.get(at).copied().unwrap_or(0) as usize;
    let mut out = Vec::with_capacity(len);
    for i in 0..len {
        let w = mem.get(at + 1 + i / 8).copied().unwrap_or(0);
        out.push((w >> ((i % 8) * 8)) as u8);
    }
    out
}

/// Writes a string at absolute address `at`, truncated to `cap` bytes.
pub fn write_str(mem: &mut [u64], at: usize, bytes: &[u8], cap: u32) {
    let n = bytes.len().min(cap as usize);
    if at >= mem.len() {
        return;
    }
    mem[at] = n as u64;
    for (i, chunk) in bytes[..n].chunks(8).enumerate() {
        let mut w = 0u64;
        for (j, b) in chunk.iter().enumerate() {
            w |= (*b as u64) << (j * 8);
        }
        if let Some(x) = mem.get_mut(at + 1 + i) {
            *x = w;
        }
    }
}

/// Reads the WSTRING stored at absolute address `at`: its bytes are the UTF-16LE code
/// units (the length slot counts bytes, as a STRING's does).
pub fn read_units(mem: &[u64], at: usize) -> Vec<u16> {
    read_str(mem, at)
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect()
}

/// Writes a WSTRING at absolute address `at`, truncated to `cap` bytes (whole units).
pub fn write_units(mem: &mut [u64], at: usize, units: &[u16], cap: u32) {
    let bytes: Vec<u8> = units.iter().flat_map(|u| u.to_le_bytes()).collect();
    write_str(mem, at, &bytes, cap & !1);
}

/// A string's characters: bytes (STRING) or UTF-16 code units (WSTRING), with how they
/// are read and written; the string functions are written once over both.
trait Unit: Copy + Ord {
    fn read(mem: &[u64], at: usize) -> Vec<Self>;
    fn write(mem: &mut [u64], at: usize, s: &[Self], cap: u32);
}

impl Unit for u8 {
    fn read(mem: &[u64], at: usize) -> Vec<u8> {
        read_str(mem, at)
    }
    fn write(mem: &mut [u64], at: usize, s: &[u8], cap: u32) {
        write_str(mem, at, s, cap)
    }
}

impl Unit for u16 {
    fn read(mem: &[u64], at: usize) -> Vec<u16> {
        read_units(mem, at)
    }
    fn write(mem: &mut [u64], at: usize, s: &[u16], cap: u32) {
        write_units(mem, at, s, cap)
    }
}

fn ptr(mem: &[u64], base: usize, s: u32) -> usize {
    slot(mem, base, s) as usize
}

fn int(mem: &[u64], base: usize, s: u32) -> i128 {
    slot(mem, base, s) as i64 as i128
}

fn real(mem: &[u64], base: usize, s: u32) -> f64 {
    f64::from_bits(slot(mem, base, s))
}

fn fault(e: OpError, detail: String) -> OpFault {
    OpFault::new(e, detail)
}

fn show(raw: u64, e: Elem) -> String {
    let v = get_value(raw, e);
    String::from_utf8_lossy(&ops::to_text(&v, e)).into_owned()
}

/// Compares two values of `kind` (strings through pointers).
fn less(mem: &[u64], base: usize, a: u32, b: u32, kind: Kind) -> bool {
    match kind {
        Kind::I => (slot(mem, base, a) as i64) < (slot(mem, base, b) as i64),
        Kind::U => slot(mem, base, a) < slot(mem, base, b),
        Kind::F => real(mem, base, a) < real(mem, base, b),
        Kind::S => read_str(mem, ptr(mem, base, a)) < read_str(mem, ptr(mem, base, b)),
        Kind::W => read_units(mem, ptr(mem, base, a)) < read_units(mem, ptr(mem, base, b)),
    }
}

/// Stores the value of slot `src` (or the string it points to) as the result `d`.
fn set_from(mem: &mut [u64], base: usize, d: u32, src: u32, kind: Kind, cap: u32) {
    if matches!(kind, Kind::S | Kind::W) {
        let s = read_str(mem, ptr(mem, base, src));
        let at = ptr(mem, base, d);
        write_str(mem, at, &s, cap);
    } else {
        mem[base + d as usize] = slot(mem, base, src);
    }
}

/// Runs `x` on the frame at `base`; `mode` is what an integer result outside its type does,
/// `now` the scan's time (nanoseconds).
pub fn exec(
    x: &ExtOp,
    mem: &mut [u64],
    base: usize,
    mode: Overflow,
    now: i64,
) -> Result<(), OpFault> {
    match x {
        ExtOp::Conv { d, s, from, to } => {
            let raw = slot(mem, base, *s);
            let v = get_value(raw, *from);
            let r = ops::convert_elem(&v, *from, *to, mode).map_err(|e| {
                let call = format!("{}_TO_{}({})", from.name(), to.name(), show(raw, *from));
                match ops::non_finite(v.as_real().unwrap_or(0.0)) {
                    Some(what) => fault(e, format!("{call}: {what} has no {} value", to.name())),
                    None => fault(e, call),
                }
            })?;
            mem[base + *d as usize] = put_value(&r, *to);
        }
        ExtOp::ToStr {
            dp,
            s,
            from,
            cap,
            wide,
        } => {
            let raw = slot(mem, base, *s);
            let text = ops::to_text(&get_value(raw, *from), *from);
            let at = ptr(mem, base, *dp);
            if *wide {
                let v = get_value(raw, *from);
                write_units(mem, at, &ops::to_wide_text(&v, *from), *cap);
            } else {
                write_str(mem, at, &text, *cap);
            }
        }
        ExtOp::FromStr { d, sp, to, wide } => {
            let at = ptr(mem, base, *sp);
            let r = if *wide {
                let w = read_units(mem, at);
                ops::from_wide_text(&w, *to).map_err(|e| {
                    fault(
                        e,
                        format!("WSTRING_TO_{}(\"{}\")", to.name(), ops::wide_text(&w)),
                    )
                })?
            } else {
                let s = read_str(mem, at);
                ops::from_text(&s, *to).map_err(|e| {
                    fault(
                        e,
                        format!("STRING_TO_{}('{}')", to.name(), String::from_utf8_lossy(&s)),
                    )
                })?
            };
            mem[base + *d as usize] = put_value(&r, *to);
        }
        ExtOp::Recode { dp, sp, wide, cap } => {
            let from = ptr(mem, base, *sp);
            let at = ptr(mem, base, *dp);
            if *wide {
                let w = ops::widen(&read_str(mem, from));
                write_units(mem, at, &w, *cap);
            } else {
                let s = ops::narrow(&read_units(mem, from));
                write_str(mem, at, &s, *cap);
            }
        }
        ExtOp::Trunc { d, s, to } => {
            let v = real(mem, base, *s);
            let r = ops::trunc_to_int(v, *to, mode).map_err(|e| {
                let call = format!(
                    "TRUNC({}) to {}",
                    ops::format_real(v, Elem::Lreal),
                    to.name()
                );
                match ops::non_finite(v) {
                    Some(what) => fault(e, format!("{call}: {what} has no {} value", to.name())),
                    None => fault(e, call),
                }
            })?;
            mem[base + *d as usize] = r as i64 as u64;
        }
        ExtOp::MakeRef { .. }
        | ExtOp::New { .. }
        | ExtOp::Free { .. }
        | ExtOp::Area { .. }
        | ExtOp::Deref { .. }
        | ExtOp::PtrAdd { .. }
        | ExtOp::ViewLoad { .. }
        | ExtOp::Mem { .. }
        | ExtOp::ViewStore { .. }
        | ExtOp::ViewStr { .. }
        | ExtOp::ItfType { .. } => {
            // Run by crate::pointer::exec, which has the shapes (and the handles' format).
            return Err(fault(
                OpError::Domain("internal error"),
                "a pointer instruction without its shapes".into(),
            ));
        }
        ExtOp::Check { d, s, lo, hi } => {
            let v = slot(mem, base, *s) as i64;
            if v < *lo || v > *hi {
                return Err(fault(
                    OpError::Conversion,
                    format!("{v} is outside the subrange {lo}..{hi}"),
                ));
            }
            mem[base + *d as usize] = v as u64;
        }
        ExtOp::Pow {
            d,
            a,
            b,
            e,
            int_exp,
        } => {
            let x = real(mem, base, *a);
            let r = if *int_exp {
                let n = int(mem, base, *b);
                ops::real_power_int(x, n, *e)
            } else {
                let y = real(mem, base, *b);
                ops::real_binary(BinaryOp::Power, x, y, *e)
                    .map_err(|er| fault(er, format!("{x} ** {y}")))?
            };
            mem[base + *d as usize] = r.to_bits();
        }
        ExtOp::TimeScale {
            d,
            a,
            b,
            div,
            real: is_real,
        } => {
            let t = int(mem, base, *a);
            let r = if *is_real {
                let f = real(mem, base, *b);
                if *div && f == 0.0 {
                    return Err(fault(
                        OpError::DivisionByZero,
                        format!("T#{} / 0.0", ops::format_duration(t)),
                    ));
                }
                let r = ops::round_even(if *div { t as f64 / f } else { t as f64 * f });
                // NaN and ±Inf have no duration in either mode; a finite value out of range
                // wraps like LINT, or is a fault in fault mode.
                ops::real_to_int(r, Elem::Lint, mode).map_err(|_| {
                    fault(
                        OpError::Overflow,
                        format!(
                            "T#{} {} {} leaves the range of TIME",
                            ops::format_duration(t),
                            if *div { "/" } else { "*" },
                            ops::format_real(f, Elem::Lreal)
                        ),
                    )
                })?
            } else {
                let n = int(mem, base, *b);
                let op = if *div { BinaryOp::Div } else { BinaryOp::Mul };
                ops::int_binary_in(op, t, n, Elem::Lint, mode).map_err(|e| {
                    fault(
                        e,
                        format!(
                            "T#{} {} {n} leaves the range of TIME",
                            ops::format_duration(t),
                            if *div { "/" } else { "*" }
                        ),
                    )
                })?
            };
            mem[base + *d as usize] = r as i64 as u64;
        }
        ExtOp::TimeAdd {
            d,
            a,
            b,
            sub,
            of,
            to,
        } => {
            let (x, y) = (int(mem, base, *a), int(mem, base, *b));
            let r = if *sub { x - y } else { x + y };
            let r = if mode == Overflow::Wrap {
                wrap(r, Elem::Lint)
            } else {
                r
            };
            if !fits(r, Elem::Lint) {
                return Err(fault(
                    OpError::Overflow,
                    format!(
                        "{} {} {} leaves the range of {}",
                        show(slot(mem, base, *a), *of),
                        if *sub { "-" } else { "+" },
                        show(slot(mem, base, *b), *of),
                        to.name()
                    ),
                ));
            }
            mem[base + *d as usize] = r as i64 as u64;
        }
        ExtOp::TodAdd { d, a, b, sub } => {
            let (t, dt) = (int(mem, base, *a), int(mem, base, *b));
            let r = if *sub { t - dt } else { t + dt };
            mem[base + *d as usize] = r.rem_euclid(NANOS_PER_DAY) as i64 as u64;
        }
        ExtOp::Math { f, d, s, e } => {
            let v = real(mem, base, *s);
            let r = ops::real_fn(*f, v, *e);
            mem[base + *d as usize] = r.to_bits();
        }
        ExtOp::AbsI { d, s, e } => {
            let raw = slot(mem, base, *s);
            let v = get_value(raw, *e).as_int().unwrap_or(0);
            let r = ops::int_binary_in(BinaryOp::Sub, 0, -v.abs(), *e, mode)
                .map_err(|er| fault(er, format!("ABS({v}) in {}", e.name())))?;
            mem[base + *d as usize] = r as i64 as u64;
        }
        ExtOp::Atan2 { d, y, x, e } => {
            let r = ops::real_result(real(mem, base, *y).atan2(real(mem, base, *x)), *e);
            mem[base + *d as usize] = r.to_bits();
        }
        ExtOp::MinMax {
            max,
            d,
            args,
            kind,
            cap,
        } => {
            let mut best = args[0];
            for &a in &args[1..] {
                let better = if *max {
                    less(mem, base, best, a, *kind)
                } else {
                    less(mem, base, a, best, *kind)
                };
                if better {
                    best = a;
                }
            }
            set_from(mem, base, *d, best, *kind, *cap);
        }
        ExtOp::Limit {
            d,
            mn,
            x,
            mx,
            kind,
            cap,
        } => {
            let pick = if less(mem, base, *x, *mn, *kind) {
                *mn
            } else if less(mem, base, *mx, *x, *kind) {
                *mx
            } else {
                *x
            };
            set_from(mem, base, *d, pick, *kind, *cap);
        }
        ExtOp::Select {
            mux,
            d,
            k,
            args,
            kind,
            cap,
        } => {
            let i = if *mux {
                let k = int(mem, base, *k);
                match usize::try_from(k).ok().filter(|&i| i < args.len()) {
                    Some(i) => i,
                    None => {
                        return Err(fault(
                            OpError::Domain("MUX selector out of range"),
                            format!(
                                "MUX with K = {k} and {} inputs (K is 0..{})",
                                args.len(),
                                args.len() - 1
                            ),
                        ))
                    }
                }
            } else {
                (slot(mem, base, *k) != 0) as usize
            };
            set_from(mem, base, *d, args[i], *kind, *cap);
        }
        ExtOp::Shift { f, d, s, n, e } => {
            let v = get_value(slot(mem, base, *s), *e).as_int().unwrap_or(0);
            let k = int(mem, base, *n);
            let r = ops::shift(*f, v, k, *e, mode)
                .map_err(|er| fault(er, format!("{}(…, {k})", f.name())))?;
            mem[base + *d as usize] = r as i64 as u64;
        }
        ExtOp::Str {
            f,
            d,
            args,
            cap,
            wide,
        } => {
            if *wide {
                string_fn::<u16>(*f, *d, args, *cap, mem, base)?
            } else {
                string_fn::<u8>(*f, *d, args, *cap, mem, base)?
            }
        }
        ExtOp::NonZeroStep { s } => {
            if slot(mem, base, *s) == 0 {
                return Err(fault(
                    OpError::Domain("a FOR loop with BY 0 never ends"),
                    "the step (BY) is 0".to_string(),
                ));
            }
        }
        ExtOp::ItfCheck { d, s } => {
            let h = mem[base + *s as usize];
            if h == 0 {
                return Err(fault(
                    OpError::Domain("call through a NULL interface"),
                    "a method or property is used through an interface that designates no instance (0); assign an instance to it first, or test `<> 0`".to_string(),
                ));
            }
            mem[base + *d as usize] = h;
        }
        ExtOp::Enter { s, pou } => {
            let flag = &mut mem[base + *s as usize];
            if *flag != 0 {
                return Err(fault(
                    OpError::Domain("recursion"),
                    format!("{pou} is called again while it runs (through an interface, W050); its frame is static: end the chain of instances, or walk it in a loop"),
                ));
            }
            *flag = 1;
        }
        ExtOp::Leave { s } => mem[base + *s as usize] = 0,
        ExtOp::Now { d } => {
            mem[base + *d as usize] = (now - now.rem_euclid(1_000_000)) as u64;
        }
        ExtOp::GetChar { d, s, p } => {
            let text = read_str(mem, ptr(mem, base, *s));
            let at = int(mem, base, *p);
            let c = usize::try_from(at - 1)
                .ok()
                .and_then(|i| text.get(i))
                .copied()
                .unwrap_or(0);
            mem[base + *d as usize] = u64::from(c);
        }
        ExtOp::Format {
            d,
            s,
            fmt,
            from,
            cap,
        } => {
            let v = get_value(slot(mem, base, *s), *from);
            let f = read_str(mem, ptr(mem, base, *fmt));
            let text = petriplc_iec_sema::vendor::printf(&f, &v, *from);
            let at = ptr(mem, base, *d);
            write_str(mem, at, &text, *cap);
        }
        ExtOp::Chr { d, s, cap } => {
            let c = slot(mem, base, *s) as u8;
            let text: &[u8] = if c == 0 { &[] } else { &[c] };
            let at = ptr(mem, base, *d);
            write_str(mem, at, text, *cap);
        }
        ExtOp::ConcatDateTod { d, a, b } => {
            let date = int(mem, base, *a).div_euclid(NANOS_PER_DAY) * NANOS_PER_DAY;
            let r = date + int(mem, base, *b).rem_euclid(NANOS_PER_DAY);
            mem[base + *d as usize] = r as i64 as u64;
        }
        ExtOp::Bcd {
            d,
            s,
            from,
            to,
            decode,
        } => {
            let v = get_value(slot(mem, base, *s), *from).as_int().unwrap_or(0);
            let r = if *decode {
                ops::from_bcd(v, *to).map_err(|e| {
                    let (f, t) = (from.name(), to.name());
                    fault(
                        e,
                        format!("{f}_BCD_TO_{t}(16#{v:X}): not BCD digits, or more than {t} holds"),
                    )
                })?
            } else {
                ops::to_bcd(v, *to).map_err(|e| {
                    let (f, t) = (from.name(), to.name());
                    fault(
                        e,
                        format!("{f}_TO_BCD_{t}({v}): negative, or more digits than {t} holds"),
                    )
                })?
            };
            mem[base + *d as usize] = put_value(&Value::Int(r), *to);
        }
    }
    Ok(())
}

fn string_fn<U: Unit>(
    f: Builtin,
    d: u32,
    args: &[u32],
    cap: u32,
    mem: &mut [u64],
    base: usize,
) -> Result<(), OpFault> {
    let s = |k: usize, mem: &[u64]| U::read(mem, ptr(mem, base, args[k]));
    let n = |k: usize, mem: &[u64]| int(mem, base, args[k]);
    let describe = |e: OpError, what: String| fault(e, what);
    let out: Vec<U> = match f {
        Builtin::Len => {
            mem[base + d as usize] = s(0, mem).len() as u64;
            return Ok(());
        }
        Builtin::Find => {
            mem[base + d as usize] = ops::find(&s(0, mem), &s(1, mem)) as u64;
            return Ok(());
        }
        Builtin::Left => ops::left(&s(0, mem), n(1, mem))
            .map_err(|e| describe(e, format!("LEFT with L = {}", n(1, mem))))?,
        Builtin::Right => ops::right(&s(0, mem), n(1, mem))
            .map_err(|e| describe(e, format!("RIGHT with L = {}", n(1, mem))))?,
        Builtin::Mid => {
            let x = s(0, mem);
            ops::mid(&x, n(1, mem), n(2, mem)).map_err(|e| {
                describe(
                    e,
                    format!(
                        "MID with L = {}, P = {} on a string of {} characters",
                        n(1, mem),
                        n(2, mem),
                        x.len()
                    ),
                )
            })?
        }
        Builtin::Concat => {
            let mut out = Vec::new();
            for k in 0..args.len() {
                out.extend(s(k, mem));
            }
            out
        }
        Builtin::Insert => {
            let x = s(0, mem);
            ops::insert(&x, &s(1, mem), n(2, mem)).map_err(|e| {
                describe(
                    e,
                    format!(
                        "INSERT with P = {} into a string of {} characters",
                        n(2, mem),
                        x.len()
                    ),
                )
            })?
        }
        Builtin::Delete => {
            let x = s(0, mem);
            ops::delete(&x, n(1, mem), n(2, mem)).map_err(|e| {
                describe(
                    e,
                    format!(
                        "DELETE with L = {}, P = {} on a string of {} characters",
                        n(1, mem),
                        n(2, mem),
                        x.len()
                    ),
                )
            })?
        }
        Builtin::Replace => {
            let x = s(0, mem);
            ops::replace(&x, &s(1, mem), n(2, mem), n(3, mem)).map_err(|e| {
                describe(
                    e,
                    format!(
                        "REPLACE with L = {}, P = {} on a string of {} characters",
                        n(2, mem),
                        n(3, mem),
                        x.len()
                    ),
                )
            })?
        }
        _ => Vec::new(),
    };
    let at = ptr(mem, base, d);
    U::write(mem, at, &out, cap);
    Ok(())
}

/// Integer arithmetic of the main loop's slow cases (checked 64-bit), shared for messages.
pub fn describe_arith(op: crate::op::Arith, a: i128, b: i128, e: Elem) -> String {
    let sym = match op {
        crate::op::Arith::Add => "+",
        crate::op::Arith::Sub => "-",
        crate::op::Arith::Mul => "*",
        crate::op::Arith::Div => "/",
        crate::op::Arith::Mod => "MOD",
    };
    let _ = wrap;
    format!("{a} {sym} {b} in {}", e.name())
}
