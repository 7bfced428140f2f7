//! Expressions: literals, places, unary and binary operators, conversions, string buffers.

use petriplc_iec_sema::ir::{BinaryOp, Expr, ExprKind, UnaryOp};
use petriplc_iec_sema::types::{Elem, Type, TypeId};
use petriplc_iec_sema::value::Value;
use petriplc_iec_sema::Overflow;
use petriplc_iec_syntax::source::Span;

use crate::ext::{self, ExtOp, Kind};
use crate::layout;
use crate::op::{int_class, Arith, Cmp, IntClass, Op};

use super::{
    elem_or_dint, is_string, kind, raw_const, scalar, str_cap, CompileError, Fx, Loc, R, SYM,
};

impl<'c, 'p> Fx<'c, 'p> {
    /// Computes `e`; returns the slot holding its value (a pointer for strings and other
    /// aggregates). With `want`, the last instruction writes there when it can.
    pub(super) fn expr(&mut self, e: &Expr, want: Option<u32>) -> R<u32> {
        let span = e.span;
        let p = self.p();
        match &e.kind {
            ExprKind::Const(v) => {
                if let Value::WStr(w) = v {
                    let n = (w.len().max(1) * 2) as u32;
                    let mut slots = vec![0u64; layout::string_slots(n) as usize];
                    ext::write_units(&mut slots, 0, w, n);
                    let c = self.const_block(&slots);
                    let d = self.temp(1);
                    self.emit(Op::Lea { d, s: c }, span);
                    return Ok(d);
                }
                if let Value::Str(s) = v {
                    let mut slots =
                        vec![0u64; layout::string_slots(s.len().max(1) as u32) as usize];
                    ext::write_str(&mut slots, 0, s, s.len() as u32);
                    let c = self.const_block(&slots);
                    let d = self.temp(1);
                    self.emit(Op::Lea { d, s: c }, span);
                    return Ok(d);
                }
                if !scalar(p, e.ty) {
                    // An aggregate constant (never produced by the checker for expressions).
                    return Err(CompileError::Unsupported("aggregate constant".into()));
                }
                let raw = raw_const(p, v, e.ty);
                match want {
                    Some(d) => {
                        self.emit(Op::MovK { d, k: raw }, span);
                        Ok(d)
                    }
                    None => Ok(self.konst(raw)),
                }
            }
            ExprKind::Load(place) => {
                if let Some(view) = self.view_of(place)? {
                    let d = want.unwrap_or_else(|| self.temp(1));
                    self.view_load(view, d, span);
                    return Ok(d);
                }
                let pl = self.place_loc(place)?;
                if scalar(p, place.ty) {
                    if let (Some(d), None, Loc::Abs(..) | Loc::Ind(..)) = (want, pl.bit, pl.loc) {
                        // Load straight into the destination.
                        match pl.loc {
                            Loc::Abs(r, off) => {
                                let s = self.c.sym(r, off);
                                self.emit(Op::LdG { d, g: SYM | s }, span);
                            }
                            Loc::Ind(pp, off) => {
                                self.emit(Op::LdI { d, p: pp, off }, span);
                            }
                            Loc::Slot(_) => {}
                        }
                        return Ok(d);
                    }
                    if let (Some(d), Some((n, width))) = (want, pl.bit) {
                        let w = self.load_loc(pl.loc, span)?;
                        self.emit(
                            Op::GetBit {
                                d,
                                s: w,
                                n,
                                w: width,
                            },
                            span,
                        );
                        return Ok(d);
                    }
                    self.load_place(&pl, span)
                } else {
                    self.addr_of(pl.loc, span)
                }
            }
            ExprKind::Ref(place) => {
                // ADR(u.m): a handle of the union `u` itself, whose bytes `m` starts (the
                // pointer's accesses go through them).
                let stripped;
                let place = match place.path.last() {
                    Some(petriplc_iec_sema::ir::Step::Overlay { union, .. }) => {
                        stripped = petriplc_iec_sema::ir::Place {
                            root: place.root,
                            path: place.path[..place.path.len() - 1].to_vec(),
                            ty: *union,
                            span: place.span,
                        };
                        &stripped
                    }
                    _ => place,
                };
                if place.ty > crate::pointer::MAX_TAGGED_TYPE {
                    return Err(CompileError::Unsupported(format!(
                        "a reference to a type beyond the first {} types of a project",
                        crate::pointer::MAX_TAGGED_TYPE
                    )));
                }
                let pl = self.place_loc(place)?;
                let a = self.addr_of(pl.loc, span)?;
                let d = want.unwrap_or_else(|| self.temp(1));
                self.ext(
                    ExtOp::MakeRef {
                        d,
                        s: a,
                        ty: place.ty,
                    },
                    span,
                );
                Ok(d)
            }
            ExprKind::Unary(op, x) => {
                let a = self.expr(x, None)?;
                let d = want.unwrap_or_else(|| self.temp(1));
                let el = elem_or_dint(p, x.ty);
                match op {
                    UnaryOp::Plus => {
                        if d != a {
                            self.emit(Op::Mov { d, s: a }, span);
                        }
                    }
                    UnaryOp::Not => {
                        if el == Elem::Bool {
                            self.emit(Op::Not { d, s: a }, span);
                        } else {
                            self.emit(
                                Op::BNot {
                                    d,
                                    s: a,
                                    bits: el.bits() as u8,
                                },
                                span,
                            );
                        }
                    }
                    UnaryOp::Neg => {
                        if el.is_real() {
                            self.emit(Op::NegF { d, s: a }, span);
                        } else {
                            let wrap = p.overflow == Overflow::Wrap;
                            match (int_class(el), wrap) {
                                (IntClass::Narrow(r), false) => {
                                    self.emit(Op::NegN { d, s: a, r }, span)
                                }
                                (IntClass::Narrow(r), true) => {
                                    self.emit(Op::NegNW { d, s: a, r }, span)
                                }
                                (_, false) => self.emit(Op::NegL { d, s: a }, span),
                                (_, true) => self.emit(Op::NegLW { d, s: a }, span),
                            };
                        }
                    }
                }
                Ok(d)
            }
            ExprKind::Binary(op, a, b) if matches!(p.types.get(e.ty), Type::Ref { .. }) => {
                // Pointer arithmetic: the checker puts the pointer first, the bytes (LINT)
                // second.
                let pv = self.expr(a, None)?;
                let n = self.expr(b, None)?;
                let d = want.unwrap_or_else(|| self.temp(1));
                self.ext(
                    ExtOp::PtrAdd {
                        d,
                        p: pv,
                        n,
                        sub: *op == BinaryOp::Sub,
                    },
                    span,
                );
                Ok(d)
            }
            ExprKind::Binary(op, a, b) => self.binary(*op, a, b, e.ty, want, span),
            ExprKind::Convert(x) => self.convert(x, e.ty, want, span),
            ExprKind::Trunc(x) => {
                let s = self.expr(x, None)?;
                let d = want.unwrap_or_else(|| self.temp(1));
                let to = elem_or_dint(p, e.ty);
                self.ext(ExtOp::Trunc { d, s, to }, span);
                Ok(d)
            }
            ExprKind::Call(call) => self.call_fn(call, e.ty, want, span),
            ExprKind::Builtin(b, args) => self.builtin(*b, args, e.ty, want, span),
        }
    }

    /// The operands of a chain `a op b op c …` (left-nested).
    fn chain<'e>(e: &'e Expr, op: BinaryOp, out: &mut Vec<&'e Expr>) {
        match &e.kind {
            ExprKind::Binary(o, a, b)
                if *o == op && e.ty == petriplc_iec_sema::types::ids::BOOL =>
            {
                Self::chain(a, op, out);
                Self::chain(b, op, out);
            }
            _ => out.push(e),
        }
    }

    fn binary(
        &mut self,
        op: BinaryOp,
        a: &Expr,
        b: &Expr,
        ty: TypeId,
        want: Option<u32>,
        span: Span,
    ) -> R<u32> {
        if matches!(op, BinaryOp::AndThen | BinaryOp::OrElse) {
            return self.short_circuit(op == BinaryOp::AndThen, a, b, want, span);
        }
        let p = self.p();
        let (ae, be) = (elem_or_dint(p, a.ty), elem_or_dint(p, b.ty));
        if matches!(op, BinaryOp::And | BinaryOp::Or) && ae == Elem::Bool {
            if let Some(d) = self.bool_chain(op, a, b, want, span)? {
                return Ok(d);
            }
            if let Some(d) = self.and_or_not(op, a, b, want, span)? {
                return Ok(d);
            }
        }
        let x = self.expr(a, None)?;
        let y = self.expr(b, None)?;
        let d = want.unwrap_or_else(|| self.temp(1));
        let re = elem_or_dint(p, ty);
        if self.time_arith(op, (ae, be, re), d, x, y, span) {
            return Ok(d);
        }
        if let Some(c) = Self::comparison(op) {
            let o = match kind(p, a.ty) {
                k @ (Kind::S | Kind::W) => Op::CmpS {
                    op: c,
                    d,
                    a: x,
                    b: y,
                    wide: k == Kind::W,
                },
                Kind::F => Op::CmpF {
                    op: c,
                    d,
                    a: x,
                    b: y,
                },
                Kind::U => Op::CmpU {
                    op: c,
                    d,
                    a: x,
                    b: y,
                },
                Kind::I => Op::CmpI {
                    op: c,
                    d,
                    a: x,
                    b: y,
                },
            };
            self.emit(o, span);
            return Ok(d);
        }
        let wrap = p.overflow == Overflow::Wrap;
        self.emit(Self::logic_or_arith(op, re, wrap, d, x, y), span);
        Ok(d)
    }

    /// `a AND_THEN b`, `a OR_ELSE b`: the left operand into a fresh temporary, a jump over
    /// the right one when the left decides. The temporary, not `want`, holds the value while
    /// `b` runs: `want` may be a variable `b` reads (`x := y AND_THEN x`).
    fn short_circuit(
        &mut self,
        and: bool,
        a: &Expr,
        b: &Expr,
        want: Option<u32>,
        span: Span,
    ) -> R<u32> {
        let t = self.temp(1);
        let x = self.expr(a, Some(t))?;
        if x != t {
            self.emit(Op::Mov { d: t, s: x }, span);
        }
        let skip = if and {
            self.emit(Op::JmpF { c: t, t: 0 }, span)
        } else {
            self.emit(Op::JmpT { c: t, t: 0 }, span)
        };
        let y = self.expr(b, Some(t))?;
        if y != t {
            self.emit(Op::Mov { d: t, s: y }, span);
        }
        let here = self.pc();
        self.patch(skip, here);
        match want {
            Some(d) if d != t => {
                self.emit(Op::Mov { d, s: t }, span);
                Ok(d)
            }
            _ => Ok(t),
        }
    }

    /// Chains of three or more BOOL terms: one instruction over their literals.
    fn bool_chain(
        &mut self,
        op: BinaryOp,
        a: &Expr,
        b: &Expr,
        want: Option<u32>,
        span: Span,
    ) -> R<Option<u32>> {
        let mut terms = Vec::new();
        Self::chain(a, op, &mut terms);
        Self::chain(b, op, &mut terms);
        if terms.len() < 3 {
            return Ok(None);
        }
        let mut lits = Vec::with_capacity(terms.len());
        for t in terms {
            let lit = match self.bool_literal(t)? {
                Some(l) => l,
                None => {
                    // Computed first (all terms are evaluated, as IEC does).
                    let x = self.expr(t, None)?;
                    (x, false)
                }
            };
            lits.push((lit.0, lit.1 as u64));
        }
        let d = want.unwrap_or_else(|| self.temp(1));
        let u = &mut self.c.units[self.unit];
        let start = u.lits.len() as u32;
        let len = lits.len() as u32;
        u.lits.extend(lits);
        let o = if op == BinaryOp::And {
            Op::AndLits { d, start, len }
        } else {
            Op::OrLits { d, start, len }
        };
        self.emit(o, span);
        Ok(Some(d))
    }

    /// `a AND NOT b`, `a OR NOT b` (either side negated) on BOOL: one instruction.
    fn and_or_not(
        &mut self,
        op: BinaryOp,
        a: &Expr,
        b: &Expr,
        want: Option<u32>,
        span: Span,
    ) -> R<Option<u32>> {
        let (x, y) = if let ExprKind::Unary(UnaryOp::Not, inner) = &b.kind {
            let x = self.expr(a, None)?;
            let y = self.expr(inner, None)?;
            (x, y)
        } else if let ExprKind::Unary(UnaryOp::Not, inner) = &a.kind {
            let y = self.expr(inner, None)?;
            let x = self.expr(b, None)?;
            (x, y)
        } else {
            return Ok(None);
        };
        let d = want.unwrap_or_else(|| self.temp(1));
        let o = if op == BinaryOp::And {
            Op::AndN { d, a: x, b: y }
        } else {
            Op::OrN { d, a: x, b: y }
        };
        self.emit(o, span);
        Ok(Some(d))
    }

    /// Durations, dates and times of day, and `**`: emitted if `op` on these operand and
    /// result types (`ae`, `be`, `re`) is one of them.
    fn time_arith(
        &mut self,
        op: BinaryOp,
        (ae, be, re): (Elem, Elem, Elem),
        d: u32,
        x: u32,
        y: u32,
        span: Span,
    ) -> bool {
        // Durations and dates of one type: LINT arithmetic, but an overflow is told in T#…
        if ae == be
            && (ae.is_duration() || ae.is_date())
            && matches!(op, BinaryOp::Add | BinaryOp::Sub)
        {
            self.ext(
                ExtOp::TimeAdd {
                    d,
                    a: x,
                    b: y,
                    sub: op == BinaryOp::Sub,
                    of: ae,
                    to: re,
                },
                span,
            );
            return true;
        }
        // Time arithmetic with mixed types.
        if ae != be && (ae.is_duration() || ae.is_date()) {
            match (op, ae, be) {
                (BinaryOp::Mul | BinaryOp::Div, _, _) => {
                    self.ext(
                        ExtOp::TimeScale {
                            d,
                            a: x,
                            b: y,
                            div: op == BinaryOp::Div,
                            real: be.is_real(),
                        },
                        span,
                    );
                }
                (_, Elem::Tod, Elem::Time | Elem::Ltime) if re == Elem::Tod => {
                    self.ext(
                        ExtOp::TodAdd {
                            d,
                            a: x,
                            b: y,
                            sub: op == BinaryOp::Sub,
                        },
                        span,
                    );
                }
                _ => {
                    let ar = if op == BinaryOp::Add {
                        Arith::Add
                    } else {
                        Arith::Sub
                    };
                    let o = if self.p().overflow == Overflow::Wrap {
                        Op::ArLW {
                            op: ar,
                            d,
                            a: x,
                            b: y,
                        }
                    } else {
                        Op::ArL {
                            op: ar,
                            d,
                            a: x,
                            b: y,
                        }
                    };
                    self.emit(o, span);
                }
            }
            return true;
        }
        if op == BinaryOp::Power {
            self.ext(
                ExtOp::Pow {
                    d,
                    a: x,
                    b: y,
                    e: re,
                    int_exp: !be.is_real(),
                },
                span,
            );
            return true;
        }
        if ae == Elem::Tod && re == Elem::Tod {
            self.ext(
                ExtOp::TodAdd {
                    d,
                    a: x,
                    b: y,
                    sub: op == BinaryOp::Sub,
                },
                span,
            );
            return true;
        }
        false
    }

    fn comparison(op: BinaryOp) -> Option<Cmp> {
        match op {
            BinaryOp::Eq => Some(Cmp::Eq),
            BinaryOp::Ne => Some(Cmp::Ne),
            BinaryOp::Lt => Some(Cmp::Lt),
            BinaryOp::Le => Some(Cmp::Le),
            BinaryOp::Gt => Some(Cmp::Gt),
            BinaryOp::Ge => Some(Cmp::Ge),
            _ => None,
        }
    }

    /// The instruction of a logic or arithmetic operator with a result of type `re`
    /// (`wrap`: an integer result outside the type keeps its low bits).
    fn logic_or_arith(op: BinaryOp, re: Elem, wrap: bool, d: u32, x: u32, y: u32) -> Op {
        match op {
            BinaryOp::And => Op::And { d, a: x, b: y },
            BinaryOp::Or => Op::Or { d, a: x, b: y },
            BinaryOp::Xor => Op::Xor { d, a: x, b: y },
            _ => {
                let ar = match op {
                    BinaryOp::Add => Arith::Add,
                    BinaryOp::Sub => Arith::Sub,
                    BinaryOp::Mul => Arith::Mul,
                    BinaryOp::Div => Arith::Div,
                    _ => Arith::Mod,
                };
                if re.is_real() {
                    Op::ArF {
                        op: ar,
                        d,
                        a: x,
                        b: y,
                        single: re == Elem::Real,
                    }
                } else {
                    match (int_class(re), wrap) {
                        (IntClass::Narrow(r), false) => Op::ArN {
                            op: ar,
                            d,
                            a: x,
                            b: y,
                            r,
                        },
                        (IntClass::Narrow(r), true) => Op::ArNW {
                            op: ar,
                            d,
                            a: x,
                            b: y,
                            r,
                        },
                        (IntClass::Long, false) => Op::ArL {
                            op: ar,
                            d,
                            a: x,
                            b: y,
                        },
                        (IntClass::Long, true) => Op::ArLW {
                            op: ar,
                            d,
                            a: x,
                            b: y,
                        },
                        (IntClass::ULong, false) => Op::ArU {
                            op: ar,
                            d,
                            a: x,
                            b: y,
                        },
                        (IntClass::ULong, true) => Op::ArUW {
                            op: ar,
                            d,
                            a: x,
                            b: y,
                        },
                    }
                }
            }
        }
    }

    fn convert(&mut self, x: &Expr, to: TypeId, want: Option<u32>, span: Span) -> R<u32> {
        let p = self.p();
        let from = x.ty;
        if is_string(p, to) {
            let wide = p.types.is_wstring(to);
            if is_string(p, from) && p.types.is_wstring(from) == wide {
                // Truncation happens where the string is stored.
                return self.expr(x, None);
            }
            let s = self.expr(x, None)?;
            let cap = str_cap(p, to);
            let buf = self.temp(layout::string_slots(cap));
            let dp = self.temp(1);
            self.emit(Op::Lea { d: dp, s: buf }, span);
            if is_string(p, from) {
                // STRING_TO_WSTRING, WSTRING_TO_STRING.
                self.ext(
                    ExtOp::Recode {
                        dp,
                        sp: s,
                        wide,
                        cap,
                    },
                    span,
                );
                return Ok(dp);
            }
            let fe = elem_or_dint(p, from);
            self.ext(
                ExtOp::ToStr {
                    dp,
                    s,
                    from: fe,
                    cap,
                    wide,
                },
                span,
            );
            return Ok(dp);
        }
        if is_string(p, from) {
            let sp = self.expr(x, None)?;
            let d = want.unwrap_or_else(|| self.temp(1));
            self.ext(
                ExtOp::FromStr {
                    d,
                    sp,
                    to: elem_or_dint(p, to),
                    wide: p.types.is_wstring(from),
                },
                span,
            );
            return Ok(d);
        }
        let s = self.expr(x, None)?;
        let (fe, te) = (elem_or_dint(p, from), elem_or_dint(p, to));
        if let Type::Subrange { lo, hi, base } = *p.types.get(to) {
            let d = want.unwrap_or_else(|| self.temp(1));
            let v = if fe == base || (fe.is_int() && fe.widens_to(base)) {
                s
            } else {
                let t = self.temp(1);
                self.ext(
                    ExtOp::Conv {
                        d: t,
                        s,
                        from: fe,
                        to: base,
                    },
                    span,
                );
                t
            };
            self.ext(
                ExtOp::Check {
                    d,
                    s: v,
                    lo: lo as i64,
                    hi: hi as i64,
                },
                span,
            );
            return Ok(d);
        }
        // A bit string's slot holds its unsigned value: it is already the value of an integer
        // type that holds them all (BYTE as INT, DWORD as LINT), and of LWORD for any integer.
        let holds = |a: Elem, b: Elem| {
            let ((alo, ahi), (blo, bhi)) = (a.range(), b.range());
            blo <= alo && ahi <= bhi
        };
        if fe == te
            || (fe.is_int() && te.is_int() && fe.widens_to(te))
            || (fe.is_bitstring() && te.is_bitstring() && fe.widens_to(te))
            || (fe.is_bitstring() && te.is_int() && holds(fe, te))
            || (fe.is_int() && te == Elem::Lword)
            || (fe == Elem::Time && te == Elem::Ltime)
        {
            if let Some(d) = want {
                if d != s {
                    self.emit(Op::Mov { d, s }, span);
                }
                return Ok(d);
            }
            return Ok(s);
        }
        if fe.is_int() && te.is_bitstring() {
            // An integer to a narrower bit string keeps the low bits: a mask, not a call.
            let d = want.unwrap_or_else(|| self.temp(1));
            let k = self.temp(1);
            self.emit(
                Op::MovK {
                    d: k,
                    k: (1u64 << te.bits()) - 1,
                },
                span,
            );
            self.emit(Op::And { d, a: s, b: k }, span);
            return Ok(d);
        }
        let d = want.unwrap_or_else(|| self.temp(1));
        self.ext(
            ExtOp::Conv {
                d,
                s,
                from: fe,
                to: te,
            },
            span,
        );
        Ok(d)
    }

    /// A string buffer for a result of `ty`; returns the pointer slot.
    pub(super) fn string_buffer(&mut self, ty: TypeId, span: Span) -> u32 {
        let cap = str_cap(self.p(), ty);
        let buf = self.temp(layout::string_slots(cap));
        let dp = self.temp(1);
        self.emit(Op::Lea { d: dp, s: buf }, span);
        dp
    }
}
