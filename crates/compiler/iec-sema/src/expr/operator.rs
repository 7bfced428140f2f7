//! Operators with the standard's type rules: unary, binary, unification and implicit conversions.

use petriplc_iec_syntax::ast::{self, BinaryOp, ExprKind as A, UnaryOp};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{Expr, ExprKind};
use crate::types::{ids, Elem, RefKind, Type, TypeId, TypeTable};
use crate::value::{self, Value};

use super::{conversion_hint, err, konst};

impl<'a> Checker<'a> {
    pub(super) fn unary(
        &mut self,
        op: UnaryOp,
        inner: &ast::Expr,
        cx: &mut Cx,
        expected: Option<TypeId>,
        span: Span,
    ) -> Expr {
        let x = self.expr(inner, cx, expected);
        if x.ty == ids::ERROR {
            return x;
        }
        match op {
            UnaryOp::Plus => {
                if self.numeric_or_lit(x.ty) || self.duration(x.ty) {
                    Expr { span, ..x }
                } else {
                    self.op_error("+", x.ty, None, span);
                    err(span)
                }
            }
            UnaryOp::Neg => {
                match (&x.kind, self.types.get(x.ty)) {
                    (ExprKind::Const(Value::Int(v)), Type::IntLit) => {
                        return konst(Value::Int(-v), ids::INT_LIT, span)
                    }
                    (ExprKind::Const(Value::Real(v)), Type::RealLit) => {
                        return konst(Value::Real(-v), ids::REAL_LIT, span)
                    }
                    _ => {}
                }
                // CODESYS and TwinCAT negate an unsigned integer or a bit string too (OSCAT's
                // `INC(cnt, -step, mx)` with a BYTE step): in the next wider signed type,
                // so the value is the negative number meant.
                let wider = match self.types.elem(x.ty) {
                    Some(Elem::Usint | Elem::Byte) => Some(ids::INT),
                    Some(Elem::Uint | Elem::Word) => Some(ids::DINT),
                    Some(Elem::Udint | Elem::Dword | Elem::Ulint | Elem::Lword) => Some(ids::LINT),
                    _ => None,
                };
                let x = match wider {
                    Some(t) => self.convert(x, t),
                    None => x,
                };
                let ok = match self.types.elem(x.ty) {
                    Some(e) => e.is_signed() || e.is_real() || e.is_duration(),
                    None => false,
                };
                if !ok {
                    let t = self.types.name(x.ty);
                    self.error(
                        diag::OPERAND_TYPE,
                        span,
                        format!("`-` negates integers, bit strings, reals and durations, not {t}"),
                    );
                    return err(span);
                }
                let ty = self.base_type(x.ty);
                self.fold(Expr {
                    kind: ExprKind::Unary(op, Box::new(x)),
                    ty,
                    span,
                })
            }
            UnaryOp::Not => self.not_checked(x, expected, span),
        }
    }

    /// NOT of a checked operand.
    pub(super) fn not_checked(&mut self, x: Expr, expected: Option<TypeId>, span: Span) -> Expr {
        if x.ty == ids::ERROR {
            return x;
        }
        let x = if self.types.get(x.ty) == &Type::IntLit {
            match expected.filter(|t| self.types.elem(*t).is_some_and(|e| e.is_bitstring())) {
                Some(t) => self.coerce(x, t, "the operand of NOT"),
                None => x,
            }
        } else {
            x
        };
        let ok = self.types.elem(x.ty).is_some_and(|e| e.is_bit());
        if !ok {
            let t = self.types.name(x.ty);
            self.error(
                diag::OPERAND_TYPE,
                span,
                format!("NOT applies to BOOL and bit strings (BYTE, WORD, DWORD, LWORD), not {t}"),
            );
            return err(span);
        }
        let ty = self.base_type(x.ty);
        self.fold(Expr {
            kind: ExprKind::Unary(UnaryOp::Not, Box::new(x)),
            ty,
            span,
        })
    }

    /// A subrange's base type (operations compute in the base type).
    pub fn base_type(&self, ty: TypeId) -> TypeId {
        match self.types.get(ty) {
            Type::Subrange { base, .. } => TypeTable::elem_id(*base),
            _ => ty,
        }
    }

    pub(super) fn numeric_or_lit(&self, ty: TypeId) -> bool {
        matches!(self.types.get(ty), Type::IntLit | Type::RealLit)
            || self.types.elem(ty).is_some_and(|e| e.is_num())
    }

    fn duration(&self, ty: TypeId) -> bool {
        self.types.elem(ty).is_some_and(|e| e.is_duration())
    }

    fn op_error(&mut self, op: &str, a: TypeId, b: Option<TypeId>, span: Span) {
        let an = self.types.name(a);
        let msg = match b {
            Some(b) => {
                let bn = self.types.name(b);
                let hint = conversion_hint(&self.types, a, b);
                format!("`{op}` cannot combine {an} and {bn}{hint}")
            }
            None => format!("`{op}` does not apply to {an}"),
        };
        self.error(diag::OPERAND_TYPE, span, msg);
    }

    pub fn binary(
        &mut self,
        op: BinaryOp,
        a: &ast::Expr,
        b: &ast::Expr,
        cx: &mut Cx,
        expected: Option<TypeId>,
        span: Span,
    ) -> Expr {
        if matches!(op, BinaryOp::AndThen | BinaryOp::OrElse) {
            return self.short_circuit(op, a, b, cx, span);
        }
        let hint = if op.is_comparison() { None } else { expected };
        let mut x = self.expr(a, cx, hint);
        let mut y = self.expr(
            b,
            cx,
            hint.or(Some(x.ty))
                .filter(|t| *t != ids::INT_LIT && *t != ids::REAL_LIT),
        );
        if x.ty == ids::INT_LIT
            && self.types.get(y.ty) != &Type::IntLit
            && matches!(self.types.get(y.ty), Type::Enum { .. })
        {
            // keep
        }
        if matches!(self.types.get(x.ty), Type::Enum { .. })
            || matches!(self.types.get(y.ty), Type::Enum { .. })
        {
            // Re-resolve a bare enumeration value against the other side's type.
            if matches!(a.kind, A::Name(_)) && !matches!(self.types.get(x.ty), Type::Enum { .. }) {
                x = self.expr(a, cx, Some(y.ty));
            }
            if matches!(b.kind, A::Name(_)) && !matches!(self.types.get(y.ty), Type::Enum { .. }) {
                y = self.expr(b, cx, Some(x.ty));
            }
        }
        self.binary_checked(op, x, y, span)
    }

    /// CODESYS's `AND_THEN` and `OR_ELSE`: BOOL operands only (as CODESYS types them; bit
    /// strings have no short-circuit meaning). A constant left operand decides at compile
    /// time: `FALSE AND_THEN f()` is FALSE and `f` is never called, as at run time.
    fn short_circuit(
        &mut self,
        op: BinaryOp,
        a: &ast::Expr,
        b: &ast::Expr,
        cx: &mut Cx,
        span: Span,
    ) -> Expr {
        let x = self.expr(a, cx, Some(ids::BOOL));
        let y = self.expr(b, cx, Some(ids::BOOL));
        if x.ty == ids::ERROR || y.ty == ids::ERROR {
            return err(span);
        }
        for e in [&x, &y] {
            if e.ty != ids::BOOL && self.base_type(e.ty) != ids::BOOL {
                let tn = self.types.name(e.ty);
                self.error(
                    diag::OPERAND_TYPE,
                    e.span,
                    format!(
                        "`{}` applies to BOOL only, not {tn}; for bit strings use `{}`",
                        op.text(),
                        if op == BinaryOp::AndThen { "AND" } else { "OR" }
                    ),
                );
                return err(span);
            }
        }
        let decides = i128::from(op == BinaryOp::OrElse);
        match &x.kind {
            ExprKind::Const(Value::Int(v)) if *v == decides => {
                return konst(Value::Int(decides), ids::BOOL, span)
            }
            ExprKind::Const(Value::Int(_)) => return Expr { span, ..y },
            _ => {}
        }
        Expr {
            kind: ExprKind::Binary(op, Box::new(x), Box::new(y)),
            ty: ids::BOOL,
            span,
        }
    }

    fn enum_compared_as_int(&self, op: BinaryOp, x: Expr, y: Expr) -> (Expr, Expr) {
        let is_enum = |t| matches!(self.types.get(t), Type::Enum { .. });
        let int = |t| {
            self.types
                .elem(t)
                .is_some_and(|e| e.is_int() || e.is_bitstring())
        };
        if !op.is_comparison() || !self.dialect.is_codesys_family() {
            return (x, y);
        }
        let to = |e: Expr, ty| Expr {
            span: e.span,
            kind: ExprKind::Convert(Box::new(e)),
            ty,
        };
        if is_enum(x.ty) && int(y.ty) && self.convertible(x.ty, y.ty) {
            let ty = y.ty;
            (to(x, ty), y)
        } else if is_enum(y.ty) && int(x.ty) && self.convertible(y.ty, x.ty) {
            let ty = x.ty;
            (x, to(y, ty))
        } else {
            (x, y)
        }
    }

    /// Types an operator over checked operands.
    pub fn binary_checked(&mut self, op: BinaryOp, x: Expr, y: Expr, span: Span) -> Expr {
        if x.ty == ids::ERROR || y.ty == ids::ERROR {
            return err(span);
        }
        // CODESYS and TwinCAT compare an enumeration with an integer by its number (TcUnit's
        // `UDINT_TO_INT(Expected.TypeClass) = TypeClass.TYPE_STRING`), converted to the
        // integer's type as a conversion would.
        let (x, y) = self.enum_compared_as_int(op, x, y);
        let (xe, ye) = (self.types.elem(x.ty), self.types.elem(y.ty));
        // Time arithmetic with mixed types.
        use BinaryOp::*;
        use Elem::*;
        let mixed = match (op, xe, ye) {
            (Add, Some(Tod), Some(Time | Ltime)) => Some(ids::TOD),
            (Add, Some(Dt), Some(Time | Ltime)) => Some(ids::DT),
            (Sub, Some(Tod), Some(Time | Ltime)) => Some(ids::TOD),
            (Sub, Some(Dt), Some(Time | Ltime)) => Some(ids::DT),
            (Sub, Some(Date), Some(Date)) => Some(ids::TIME),
            (Sub, Some(Tod), Some(Tod)) => Some(ids::TIME),
            (Sub, Some(Dt), Some(Dt)) => Some(ids::TIME),
            _ => None,
        };
        if let Some(ty) = mixed {
            return self.fold(Expr {
                kind: ExprKind::Binary(op, Box::new(x), Box::new(y)),
                ty,
                span,
            });
        }
        if matches!(op, Mul | Div)
            && matches!((xe, ye), (Some(a), Some(b)) if a.is_duration() && a == b)
        {
            return self.duration_by_duration(op, x, y, span);
        }
        if matches!(op, Mul | Div) && xe.is_some_and(|e| e.is_duration()) {
            // TIME * ANY_NUM, TIME / ANY_NUM.
            let y = match self.types.get(y.ty) {
                Type::IntLit => self.coerce(y, ids::LINT, "the factor"),
                Type::RealLit => self.coerce(y, ids::LREAL, "the factor"),
                _ => y,
            };
            if !self.types.elem(y.ty).is_some_and(|e| e.is_num()) {
                self.op_error(op.text(), x.ty, Some(y.ty), span);
                return err(span);
            }
            let ty = x.ty;
            return self.fold(Expr {
                kind: ExprKind::Binary(op, Box::new(x), Box::new(y)),
                ty,
                span,
            });
        }
        if op == Power {
            let x = match self.types.get(x.ty) {
                Type::IntLit | Type::RealLit => self.coerce(x, ids::LREAL, "the base"),
                // An integer or bit-string base gives an LREAL, as in CODESYS and TwinCAT.
                _ if xe.is_some_and(|e| e.is_int() || e.is_bitstring()) => {
                    self.convert(x, ids::LREAL)
                }
                _ => x,
            };
            let y = match self.types.get(y.ty) {
                Type::IntLit => self.coerce(y, ids::DINT, "the exponent"),
                Type::RealLit => self.coerce(y, ids::LREAL, "the exponent"),
                _ => y,
            };
            let (xe, ye) = (self.types.elem(x.ty), self.types.elem(y.ty));
            if !xe.is_some_and(|e| e.is_real()) || !ye.is_some_and(|e| e.is_num()) {
                let (an, bn) = (self.types.name(x.ty), self.types.name(y.ty));
                self.error(
                    diag::OPERAND_TYPE,
                    span,
                    format!("`**` (EXPT) raises a number to a number; here {an} to {bn}"),
                );
                return err(span);
            }
            let ty = x.ty;
            return self.fold(Expr {
                kind: ExprKind::Binary(op, Box::new(x), Box::new(y)),
                ty,
                span,
            });
        }
        if self.is_pointer_arith(op, &x, &y) {
            return self.pointer_arith(op, x, y, span);
        }
        let (x, y) = self.widen_for_literal(x, y);
        self.binary_plain(op, x, y, span)
    }

    /// CODESYS's and PCWorx's `TIME * TIME` and `TIME / TIME` (OSCAT's `T / INT_TO_TIME(n)`):
    /// their TIME is a number of milliseconds, so the operands are taken as the numbers
    /// TIME_TO_LINT gives (LTIME's: nanoseconds) and the result, that number, is a TIME again.
    fn duration_by_duration(&mut self, op: BinaryOp, x: Expr, y: Expr, span: Span) -> Expr {
        let ty = x.ty;
        let (a, b) = (self.convert(x, ids::LINT), self.convert(y, ids::LINT));
        let n = self.fold(Expr {
            kind: ExprKind::Binary(op, Box::new(a), Box::new(b)),
            ty: ids::LINT,
            span,
        });
        let r = self.convert(n, ty);
        self.fold(r)
    }

    /// An integer literal that its partner's type cannot hold (OSCAT's `offset * 60000`
    /// with an INT offset): CODESYS and TwinCAT type the literal by its value and compute
    /// in the wider type, so the partner is widened to DINT (LINT if the literal needs it).
    fn widen_for_literal(&self, x: Expr, y: Expr) -> (Expr, Expr) {
        let lit = |e: &Expr| match (&e.kind, self.types.get(e.ty)) {
            (ExprKind::Const(Value::Int(v)), Type::IntLit) => Some(*v),
            _ => None,
        };
        let narrow = |e: &Expr, v: i128| {
            self.types
                .elem(e.ty)
                .filter(|el| el.is_int() && !crate::types::fits(v, *el))
                .map(|_| {
                    if crate::types::fits(v, Elem::Dint) {
                        ids::DINT
                    } else {
                        ids::LINT
                    }
                })
                .filter(|t| {
                    let w = self.types.elem(*t).unwrap_or(Elem::Lint);
                    crate::types::fits(v, w)
                })
        };
        if let (Some(v), None) = (lit(&y), lit(&x)) {
            if let Some(t) = narrow(&x, v) {
                return (self.convert(x, t), y);
            }
        }
        if let (Some(v), None) = (lit(&x), lit(&y)) {
            if let Some(t) = narrow(&y, v) {
                let y = self.convert(y, t);
                return (x, y);
            }
        }
        (x, y)
    }

    fn binary_plain(&mut self, op: BinaryOp, x: Expr, y: Expr, span: Span) -> Expr {
        use BinaryOp::*;
        let (x, y) = self.bits_with_int(op, x, y);
        let Some((x, y, t)) = self.unify(x, y, op.text(), span) else {
            return err(span);
        };
        let tt = self.types.get(t).clone();
        let elem = self.types.elem(t);
        // Arithmetic on bit strings, as CODESYS, TwinCAT and matiec allow it.
        let bits = elem.is_some_and(|e| e.is_bitstring());
        // CODESYS and TwinCAT take AND, OR, XOR on integers bit by bit, and order the
        // values of an enumeration (its integers).
        let codesys = self.dialect.is_codesys_family();
        let ok = match op {
            Or | Xor | And => {
                matches!(tt, Type::IntLit)
                    || elem.is_some_and(|e| e.is_bit() || (codesys && e.is_int()))
            }
            // Typed in `short_circuit`; an operator built elsewhere is BOOL only too.
            AndThen | OrElse => elem == Some(Elem::Bool),
            Eq | Ne => true,
            Lt | Le | Gt | Ge if codesys && matches!(tt, Type::Enum { .. }) => true,
            // CODESYS's pointers are addresses, ordered (OSCAT's `pto < ptm` walking a
            // buffer): two into one variable are ordered by their offsets.
            Lt | Le | Gt | Ge
                if codesys
                    && matches!(
                        tt,
                        Type::Ref {
                            kind: petriplc_iec_syntax::ast::RefKind::PointerTo,
                            ..
                        }
                    ) =>
            {
                true
            }
            Lt | Le | Gt | Ge => !matches!(
                tt,
                Type::Enum { .. }
                    | Type::Struct { .. }
                    | Type::Array { .. }
                    | Type::Fb(_)
                    | Type::Ref { .. }
                    | Type::Null
            ),
            Add | Sub => {
                matches!(tt, Type::IntLit | Type::RealLit)
                    || bits
                    || elem.is_some_and(|e| e.is_num() || e.is_duration())
            }
            Mul | Div => {
                matches!(tt, Type::IntLit | Type::RealLit)
                    || bits
                    || elem.is_some_and(|e| e.is_num())
            }
            Mod => matches!(tt, Type::IntLit) || bits || elem.is_some_and(|e| e.is_int()),
            Power => true,
        };
        let ok =
            ok && !matches!(
                tt,
                Type::Struct { .. } | Type::Array { .. } | Type::Fb(_) | Type::Void
            ) && (op.is_comparison() || !matches!(tt, Type::Ref { .. } | Type::Null));
        if !ok {
            let tn = self.types.name(t);
            let what = match op {
                Or | Xor | And => "BOOL and bit strings",
                Add | Sub => "numbers and durations",
                Mul | Div => "numbers",
                Mod => "integers",
                _ if matches!(tt, Type::Ref { .. } | Type::Null) => {
                    "elementary values and strings (references compare with = and <> only)"
                }
                _ => "elementary values and strings",
            };
            self.error(
                diag::OPERAND_TYPE,
                span,
                format!("`{}` applies to {what}, not {tn}", op.text()),
            );
            return err(span);
        }
        let ty = if op.is_comparison() { ids::BOOL } else { t };
        if let (Add | Sub | Mul, Some(e @ (Elem::Byte | Elem::Word | Elem::Dword))) = (op, elem) {
            // A bit string's `+ - *` wraps around in its width, whatever the overflow rule
            // of the integers: computed in 64 bits (where it cannot overflow), then cut to
            // the type's bits as conversions do.
            let wide = if op == Mul && e == Elem::Dword {
                ids::ULINT
            } else {
                ids::LINT
            };
            let (x, y) = (self.convert(x, wide), self.convert(y, wide));
            let inner = self.fold(Expr {
                kind: ExprKind::Binary(op, Box::new(x), Box::new(y)),
                ty: wide,
                span,
            });
            return self.fold(Expr {
                kind: ExprKind::Convert(Box::new(inner)),
                ty,
                span,
            });
        }
        self.fold(Expr {
            kind: ExprKind::Binary(op, Box::new(x), Box::new(y)),
            ty,
            span,
        })
    }

    /// A bit string and an integer of another type in one operation, as CODESYS and matiec
    /// type them: the narrower converts to the wider (a bit string's value is unsigned, so
    /// BYTE + INT is INT); at equal or smaller integer width, `+ - * / MOD` take the bit
    /// string's type (the integer's bits, as INT_TO_WORD keeps them). A comparison of a bit
    /// string with an integer no wider stays an error: its meaning for negative numbers
    /// differs between the compilers.
    fn bits_with_int(&mut self, op: BinaryOp, x: Expr, y: Expr) -> (Expr, Expr) {
        use BinaryOp::*;
        let elem = |c: &Self, t: TypeId| c.types.elem(c.base_type(t));
        let (Some(a), Some(b)) = (elem(self, x.ty), elem(self, y.ty)) else {
            return (x, y);
        };
        let arith = matches!(op, Add | Sub | Mul | Div | Mod);
        let to = |e: Elem| TypeTable::elem_id(e);
        // CODESYS and TwinCAT: `dw XOR ud` is bit by bit in the bit string (the wider
        // operand's width), as AND, OR, XOR on integers are (`binary_plain`).
        if matches!(op, And | Or | Xor) && self.dialect.is_codesys_family() {
            if a.is_bitstring() && b.is_int() && b.bits() <= a.bits() {
                return (x, self.convert(y, to(a)));
            }
            if a.is_int() && b.is_bitstring() && a.bits() <= b.bits() {
                return (self.convert(x, to(b)), y);
            }
        }
        let convertible = op.is_comparison() || arith;
        if !convertible {
            return (x, y);
        }
        if a.is_bitstring() && b.is_int() {
            if b.bits() > a.bits() {
                return (self.convert(x, to(b)), y);
            }
            if arith {
                return (x, self.convert(y, to(a)));
            }
        } else if a.is_int() && b.is_bitstring() {
            if a.bits() > b.bits() {
                return (x, self.convert(y, to(a)));
            }
            if arith {
                return (self.convert(x, to(b)), y);
            }
        }
        (x, y)
    }

    /// Brings two operands to one type (literals take the other side's type, elementary
    /// types widen); `None` after reporting a mismatch.
    pub fn unify(
        &mut self,
        x: Expr,
        y: Expr,
        op: &str,
        span: Span,
    ) -> Option<(Expr, Expr, TypeId)> {
        let (tx, ty) = (self.base_type(x.ty), self.base_type(y.ty));
        let lit = |t: TypeId| t == ids::INT_LIT || t == ids::REAL_LIT;
        if tx == ty {
            return Some((x, y, tx));
        }
        if lit(tx) && lit(ty) {
            let x = self.coerce(x, ids::REAL_LIT, op);
            let y = self.coerce(y, ids::REAL_LIT, op);
            return Some((x, y, ids::REAL_LIT));
        }
        if lit(tx) {
            let x = self.coerce_quiet(x, ty)?;
            return Some((x, y, ty));
        }
        if lit(ty) {
            let y = self.coerce_quiet(y, tx)?;
            return Some((x, y, tx));
        }
        // A one-character literal where a CHAR or WCHAR is compared: `c = 'a'`.
        let one_char = |e: &Expr| match &e.kind {
            ExprKind::Const(Value::Str(s)) => s.len() == 1,
            ExprKind::Const(Value::WStr(w)) => w.len() == 1,
            _ => false,
        };
        if self.types.elem(tx).is_some_and(Elem::is_char) && one_char(&y) {
            let y = self.coerce(y, tx, op);
            return (y.ty != ids::ERROR).then_some((x, y, tx));
        }
        if self.types.elem(ty).is_some_and(Elem::is_char) && one_char(&x) {
            let x = self.coerce(x, ty, op);
            return (x.ty != ids::ERROR).then_some((x, y, ty));
        }
        if let Some(r) = self.unify_refs(&x, &y) {
            return match r {
                Ok(t) => {
                    let x = self.coerce(x, t, op);
                    let y = self.coerce(y, t, op);
                    Some((x, y, t))
                }
                Err(()) => {
                    self.op_error(op, x.ty, Some(y.ty), span);
                    None
                }
            };
        }
        // Strings of any lengths compare and combine; STRING and WSTRING do not mix (the
        // standard has no implicit conversion between them).
        if let (Type::Str { len: a, wide: wa }, Type::Str { len: b, wide: wb }) =
            (self.types.get(tx), self.types.get(ty))
        {
            if wa == wb {
                let (n, w) = ((*a).max(*b), *wa);
                let t = self.types.string_of(n, w);
                return Some((x, y, t));
            }
        }
        match (self.types.elem(tx), self.types.elem(ty)) {
            (Some(a), Some(b)) if a.widens_to(b) => {
                let x = self.convert(x, ty);
                Some((x, y, ty))
            }
            (Some(a), Some(b)) if b.widens_to(a) => {
                let y = self.convert(y, tx);
                Some((x, y, tx))
            }
            // A bit string with a REAL or LREAL (bit strings with integers: `bits_with_int`).
            (Some(a), Some(b)) if b.is_real() && bits_fit(a, b) => {
                let x = self.bits_as_number(x, a, b, "this operand");
                Some((x, y, ty))
            }
            (Some(a), Some(b)) if a.is_real() && bits_fit(b, a) => {
                let y = self.bits_as_number(y, b, a, "this operand");
                Some((x, y, tx))
            }
            _ => {
                self.op_error(op, x.ty, Some(y.ty), span);
                None
            }
        }
    }

    /// `coerce` that reports a literal out of range but not other mismatches.
    fn coerce_quiet(&mut self, x: Expr, to: TypeId) -> Option<Expr> {
        let span = x.span;
        let r = self.coerce(x, to, "this operand");
        (r.ty != ids::ERROR).then_some(r).or_else(|| {
            let _ = span;
            None
        })
    }

    pub(super) fn convert(&self, x: Expr, to: TypeId) -> Expr {
        let span = x.span;
        if let ExprKind::Const(v) = &x.kind {
            if let Some(v) = self.convert_const(v, x.ty, to) {
                return konst(v, to, span);
            }
        }
        Expr {
            kind: ExprKind::Convert(Box::new(x)),
            ty: to,
            span,
        }
    }

    pub(super) fn widen_to_lint(&mut self, x: Expr) -> Expr {
        if x.ty == ids::LINT {
            return x;
        }
        if x.ty == ids::INT_LIT {
            return self.coerce(x, ids::LINT, "the subscript");
        }
        self.convert(x, ids::LINT)
    }

    /// Converts an expression to `to` where the standard converts implicitly; otherwise
    /// reports a mismatch naming the conversion to write.
    pub fn coerce(&mut self, x: Expr, to: TypeId, what: &str) -> Expr {
        let span = x.span;
        if x.ty == ids::ERROR || to == ids::ERROR {
            return err(span);
        }
        if x.ty == to {
            return x;
        }
        if let Some(x) = self.itf_coerce(&x, to, what) {
            return x;
        }
        // CODESYS and TwinCAT store an integer in an enumeration that is not
        // `{attribute 'strict'}` (petriplc does not tell them apart), by its number: TcUnit
        // passes `UDINT_TO_INT(Expected.TypeClass)` for a TypeClass.
        let int_to_enum = self.dialect.is_codesys_family()
            && matches!(self.types.get(to), Type::Enum { .. })
            && self
                .types
                .elem(x.ty)
                .is_some_and(|e| e.is_int() || e.is_bitstring())
            && self.convertible(x.ty, to);
        if int_to_enum {
            return Expr {
                span,
                kind: ExprKind::Convert(Box::new(x)),
                ty: to,
            };
        }
        let from_t = self.types.get(x.ty).clone();
        let to_t = self.types.get(to).clone();
        match (&from_t, &to_t) {
            (Type::IntLit, Type::IntLit) | (Type::RealLit, Type::RealLit) => return x,
            (Type::IntLit, Type::RealLit) => {
                let v = x.const_int().unwrap_or(0);
                return konst(Value::Real(v as f64), ids::REAL_LIT, span);
            }
            (Type::IntLit, _) => {
                let v = x.const_int().unwrap_or(0);
                // CODESYS and TwinCAT write NULL as the address 0 (`p := 0`, `p <> 0`); any
                // other number is no pointer here (addresses are checked handles).
                if v == 0
                    && matches!(
                        to_t,
                        Type::Ref {
                            kind: RefKind::PointerTo,
                            ..
                        }
                    )
                {
                    return konst(Value::Int(0), to, span);
                }
                let target = match &to_t {
                    Type::Elem(e) => Some((*e, None)),
                    Type::Subrange { base, lo, hi } => Some((*base, Some((*lo, *hi)))),
                    _ => None,
                };
                match target {
                    Some((e, sub)) if e.is_int() || e.is_bitstring() || e == Elem::Bool => {
                        let (lo, hi) = sub.unwrap_or(e.range());
                        if v < lo || v > hi {
                            self.error(
                                diag::OUT_OF_RANGE,
                                span,
                                format!(
                                    "{v} does not fit {} ({lo}..{hi}){}",
                                    self.types.name(to),
                                    if e == Elem::Bool {
                                        "; write TRUE or FALSE"
                                    } else {
                                        ""
                                    }
                                ),
                            );
                            return err(span);
                        }
                        return konst(Value::Int(v), to, span);
                    }
                    Some((e, _)) if e.is_real() => {
                        let f = v as f64;
                        let f = if e == Elem::Real {
                            value::to_real(f)
                        } else {
                            f
                        };
                        return konst(Value::Real(f), to, span);
                    }
                    _ => {}
                }
            }
            (Type::RealLit, Type::Elem(e)) if e.is_real() => {
                let f = x.const_real().unwrap_or(0.0);
                let f = if *e == Elem::Real {
                    value::to_real(f)
                } else {
                    f
                };
                if !f.is_finite() {
                    self.error(
                        diag::OUT_OF_RANGE,
                        span,
                        format!("this value does not fit {}", e.name()),
                    );
                    return err(span);
                }
                return konst(Value::Real(f), to, span);
            }
            // 'a' is a CHAR where one is needed, "a" a WCHAR (the standard's character
            // literals are one-character strings).
            (Type::Str { wide, .. }, Type::Elem(e))
                if e.is_char() && *wide == (*e == Elem::Wchar) =>
            {
                let code = match &x.kind {
                    ExprKind::Const(Value::Str(s)) if s.len() == 1 => Some(i128::from(s[0])),
                    ExprKind::Const(Value::WStr(w)) if w.len() == 1 => Some(i128::from(w[0])),
                    _ => None,
                };
                if let Some(c) = code {
                    return konst(Value::Int(c), to, span);
                }
            }
            (Type::Str { wide: wa, .. }, Type::Str { len, wide }) if wa == wide => {
                // A constant of either width: its characters (bytes or UTF-16 units) must fit.
                let chars = match &x.kind {
                    ExprKind::Const(Value::WStr(s)) => Some(s.len()),
                    ExprKind::Const(Value::Str(s)) => Some(s.len()),
                    _ => None,
                };
                if let (Some(n), ExprKind::Const(v)) = (chars, &x.kind) {
                    if n > *len as usize {
                        self.error(
                            diag::OUT_OF_RANGE,
                            span,
                            format!(
                                "this string has {n} characters; {} holds {len}",
                                self.types.name(to)
                            ),
                        );
                        return err(span);
                    }
                    return konst(v.clone(), to, span);
                }
                return Expr {
                    kind: ExprKind::Convert(Box::new(x)),
                    ty: to,
                    span,
                };
            }
            (Type::Null, Type::Ref { .. }) => return konst(Value::Int(0), to, span),
            (Type::Ref { target: a, kind: k }, Type::Ref { target: b, kind: l })
                if a == b || (*k == RefKind::PointerTo && *l == RefKind::PointerTo) =>
            {
                // One representation; a POINTER TO of another type is checked where it is
                // dereferenced (CODESYS pointers are untyped addresses).
                return Expr { ty: to, ..x };
            }
            (Type::Elem(a), Type::Elem(b)) if a.widens_to(*b) => return self.convert(x, to),
            // CODESYS and TwinCAT store an enumeration's value in an integer or bit string
            // implicitly (not for `{attribute 'strict'}` enumerations, which petriplc does not
            // tell apart); the standard wants it written (`TO_DINT(e)`).
            (Type::Enum { .. }, Type::Elem(b))
                if (b.is_int() || b.is_bitstring()) && self.dialect.is_codesys_family() =>
            {
                if let Some(v) = x.const_int() {
                    let (lo, hi) = b.range();
                    if v < lo || v > hi {
                        self.error(
                            diag::OUT_OF_RANGE,
                            span,
                            format!("{v} does not fit {} ({lo}..{hi})", b.name()),
                        );
                        return err(span);
                    }
                    return konst(Value::Int(v), to, span);
                }
                return Expr {
                    kind: ExprKind::Convert(Box::new(x)),
                    ty: to,
                    span,
                };
            }
            (Type::Subrange { base, .. }, Type::Elem(b)) if base.widens_to(*b) => {
                return self.convert(x, to)
            }
            (Type::Elem(a), Type::Subrange { base, lo, hi })
            | (Type::Subrange { base: a, .. }, Type::Subrange { base, lo, hi })
                if a.widens_to(*base) =>
            {
                if let Some(v) = x.const_int() {
                    if v < *lo || v > *hi {
                        self.error(
                            diag::OUT_OF_RANGE,
                            span,
                            format!("{v} is outside {}", self.types.name(to)),
                        );
                        return err(span);
                    }
                    return konst(Value::Int(v), to, span);
                }
                // Checked when the program runs.
                return Expr {
                    kind: ExprKind::Convert(Box::new(x)),
                    ty: to,
                    span,
                };
            }
            _ => {}
        }
        if let (Type::Elem(a), Type::Elem(b)) = (&from_t, &to_t) {
            if bits_fit(*a, *b) {
                return self.bits_as_number(x, *a, *b, what);
            }
            if self.dialect.is_codesys_family() && narrows(*a, *b) {
                return self.implicit_narrowing(x, *a, *b, what);
            }
        }
        let (a, b) = (self.types.name(x.ty), self.types.name(to));
        let hint = conversion_hint(&self.types, x.ty, to);
        self.error(
            diag::TYPE_MISMATCH,
            span,
            format!("{what} is {a} but {b} is needed{hint}"),
        );
        err(span)
    }

    /// A value where a type that does not hold all its values is needed, in the CODESYS
    /// family: converted as the `A_TO_B` function converts it (an integer keeps its low
    /// bits, LREAL to REAL rounds to nearest), with W051; the standard and matiec refuse it.
    fn implicit_narrowing(&mut self, x: Expr, a: Elem, b: Elem, what: &str) -> Expr {
        let (an, bn) = (a.name(), b.name());
        self.diags.warning(
            diag::IMPLICIT_NARROWING,
            x.span,
            format!("{what} is {an}, converted to {bn} implicitly as CODESYS and TwinCAT do (as {an}_TO_{bn}: a value outside {bn} changes); write {an}_TO_{bn}(…) to say so"),
        );
        self.convert(x, TypeTable::elem_id(b))
    }

    /// A bit string's value where a number that holds all its values is needed: CODESYS and
    /// TwinCAT convert it implicitly; the standard wants the conversion written (W022).
    fn bits_as_number(&mut self, x: Expr, a: Elem, b: Elem, what: &str) -> Expr {
        let (an, bn) = (a.name(), b.name());
        self.diags.warning(
            diag::IMPLICIT_BITS_TO_NUMBER,
            x.span,
            format!("{what} is {an}, converted to {bn} implicitly as CODESYS does; the standard wants {an}_TO_{bn}(…) written"),
        );
        self.convert(x, TypeTable::elem_id(b))
    }
}

/// Whether CODESYS and TwinCAT convert `a` to `b` implicitly though some values change (W051):
/// between integers and bit strings of any widths, an integer to a REAL or LREAL that cannot
/// hold all its values exactly, LREAL to REAL. (REAL to an integer, and BOOL, stay explicit.)
fn narrows(a: Elem, b: Elem) -> bool {
    let whole = |e: Elem| e.is_int() || e.is_bitstring();
    (whole(a) && whole(b) && a != Elem::Bool && b != Elem::Bool)
        || (a.is_int() && b.is_real())
        || (a == Elem::Lreal && b == Elem::Real)
}

/// Whether every value of the bit string `a` is a value of the number type `b` (BYTE in INT,
/// USINT, REAL; DWORD in LINT, LREAL), so the conversion loses nothing.
fn bits_fit(a: Elem, b: Elem) -> bool {
    if !a.is_bitstring() {
        return false;
    }
    let (lo, hi) = a.range();
    match b {
        Elem::Real => a.bits() <= 16,
        Elem::Lreal => a.bits() <= 32,
        _ if b.is_int() => {
            let (blo, bhi) = b.range();
            blo <= lo && hi <= bhi
        }
        _ => false,
    }
}
