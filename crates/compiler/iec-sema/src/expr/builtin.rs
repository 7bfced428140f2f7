//! Built-in functions: arithmetic, selection, bit-string and string functions with their
//! argument rules.

use petriplc_iec_syntax::ast;
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{Builtin, Expr, ExprKind};
use crate::types::{ids, Type, TypeId, MAX_STRING_LEN};
use crate::value::Value;

use super::{err, konst, StdArg};

impl<'a> Checker<'a> {
    pub(super) fn builtin(
        &mut self,
        b: Builtin,
        f: &str,
        call: &ast::Call,
        cx: &mut Cx,
        expected: Option<TypeId>,
    ) -> Expr {
        let span = call.span;
        use Builtin::*;
        let (params, min, ext): (&[&str], usize, bool) = match b {
            Abs | Sqrt | Ln | Log | Exp | Sin | Cos | Tan | Asin | Acos | Atan | Len => {
                (&["IN"], 1, false)
            }
            Atan2 => (&["Y", "X"], 2, false),
            Sel => (&["G", "IN0", "IN1"], 3, false),
            Max | Min => (&["IN1", "IN2"], 2, true),
            Limit => (&["MN", "IN", "MX"], 3, false),
            Mux => (&["K", "IN0"], 2, true),
            Shl | Shr | Rol | Ror => (&["IN", "N"], 2, false),
            Left | Right => (&["IN", "L"], 2, false),
            Mid => (&["IN", "L", "P"], 3, false),
            Concat => (&["IN1", "IN2"], 2, true),
            Insert => (&["IN1", "IN2", "P"], 3, false),
            Delete => (&["IN", "L", "P"], 3, false),
            Replace => (&["IN1", "IN2", "L", "P"], 4, false),
            Find => (&["IN1", "IN2"], 2, false),
            ConcatDateTod => (&["IN1", "IN2"], 2, false),
            // Built elsewhere (conversions, operators, BCD in `expr/bcd.rs`, vendor functions in
            // `vendor.rs`).
            DtToTod | DtToDate | Expt | BcdToInt | IntToBcd | Time | GetChar | Format | Chr => {
                (&["IN"], 1, false)
            }
            // Checked by mem_call (expr/reference.rs), never by name here.
            MemCpy | MemSet | MemCmp => (&["DEST", "SRC", "N"], 3, false),
            // Made by interface calls (oop/itf.rs), and by expr/heap.rs, never by name.
            ItfCheck | ItfType | New | Free | MemArea | Address => (&["IN"], 1, false),
            // Made by array_bound (expr/bounds.rs), never by name here.
            Bound => (&["IN", "DIM"], 2, false),
        };
        let Some(args) = self.std_args(f, call, params, min, ext) else {
            return err(span);
        };
        let mk = |args: Vec<Expr>, ty: TypeId| Expr {
            kind: ExprKind::Builtin(b, args),
            ty,
            span,
        };
        match b {
            Abs | Sqrt | Ln | Log | Exp | Sin | Cos | Tan | Asin | Acos | Atan | Atan2 | Shl
            | Shr | Rol | Ror => self.numeric_builtin(b, f, &args, span, cx, expected),
            Sel | Max | Min | Limit | Mux => {
                self.selection_builtin(b, f, &args, span, cx, expected)
            }
            Len | Left | Right | Mid | Concat | Insert | Replace | Delete | Find => {
                self.string_builtin(b, f, &args, span, cx)
            }
            ConcatDateTod => {
                let d = self.std_arg(&args[0], cx, Some(ids::DATE));
                let t = self.std_arg(&args[1], cx, Some(ids::TOD));
                let d = self.coerce(d, ids::DATE, "CONCAT_DATE_TOD's first argument");
                let t = self.coerce(t, ids::TOD, "CONCAT_DATE_TOD's second argument");
                if d.ty == ids::ERROR || t.ty == ids::ERROR {
                    return err(span);
                }
                self.fold(mk(vec![d, t], ids::DT))
            }
            DtToTod | DtToDate | Expt | BcdToInt | IntToBcd | Time | GetChar | Format | Chr
            | MemCpy | MemSet | MemCmp | ItfCheck | ItfType | Bound | New | Free | MemArea
            | Address => err(span),
        }
    }

    /// ABS, the REAL functions (SQRT … ATAN2) and the shifts and rotations.
    fn numeric_builtin(
        &mut self,
        b: Builtin,
        f: &str,
        args: &[StdArg<'_>],
        span: Span,
        cx: &mut Cx,
        expected: Option<TypeId>,
    ) -> Expr {
        use Builtin::*;
        let mk = |args: Vec<Expr>, ty: TypeId| Expr {
            kind: ExprKind::Builtin(b, args),
            ty,
            span,
        };
        match b {
            Abs => {
                let x = self.std_arg(&args[0], cx, expected);
                if x.ty == ids::ERROR {
                    return x;
                }
                if !self.numeric_or_lit(x.ty) {
                    self.arg_error(f, "a number", x.ty, args[0].span);
                    return err(span);
                }
                let ty = self.base_type(x.ty);
                self.fold(mk(vec![x], ty))
            }
            Sqrt | Ln | Log | Exp | Sin | Cos | Tan | Asin | Acos | Atan => {
                let x = self.real_arg(f, &args[0], cx, expected);
                if x.ty == ids::ERROR {
                    return x;
                }
                let ty = x.ty;
                self.fold(mk(vec![x], ty))
            }
            Atan2 => {
                let y = self.real_arg(f, &args[0], cx, expected);
                let x = self.real_arg(f, &args[1], cx, expected);
                let Some((y, x, t)) = self.unify(y, x, f, span) else {
                    return err(span);
                };
                self.fold(mk(vec![y, x], t))
            }
            Shl | Shr | Rol | Ror => {
                let hint =
                    expected.filter(|t| self.types.elem(*t).is_some_and(|e| e.is_bitstring()));
                let x = self.std_arg(&args[0], cx, hint);
                let x = match (self.types.get(x.ty), hint) {
                    (Type::IntLit, Some(h)) => self.coerce(x, h, f),
                    (Type::IntLit, None) => self.coerce(x, ids::DWORD, f),
                    _ => x,
                };
                let n = self.std_arg(&args[1], cx, Some(ids::DINT));
                if x.ty == ids::ERROR || n.ty == ids::ERROR {
                    return err(span);
                }
                if !self
                    .types
                    .elem(x.ty)
                    .is_some_and(|e| e.is_bitstring() || e.is_int())
                {
                    self.arg_error(
                        f,
                        "a bit string (BYTE, WORD, DWORD, LWORD)",
                        x.ty,
                        args[0].span,
                    );
                    return err(span);
                }
                if !self.is_integral(n.ty) {
                    self.arg_error(f, "an integer N", n.ty, args[1].span);
                    return err(span);
                }
                let n = self.widen_to_lint(n);
                let ty = self.base_type(x.ty);
                self.fold(mk(vec![x, n], ty))
            }
            _ => err(span),
        }
    }

    /// SEL, MAX, MIN, LIMIT and MUX: their inputs unified to one type.
    fn selection_builtin(
        &mut self,
        b: Builtin,
        f: &str,
        args: &[StdArg<'_>],
        span: Span,
        cx: &mut Cx,
        expected: Option<TypeId>,
    ) -> Expr {
        use Builtin::*;
        let mk = |args: Vec<Expr>, ty: TypeId| Expr {
            kind: ExprKind::Builtin(b, args),
            ty,
            span,
        };
        match b {
            Sel => {
                let g = self.std_arg(&args[0], cx, Some(ids::BOOL));
                let g = self.coerce(g, ids::BOOL, "SEL's G");
                let a = self.std_arg(&args[1], cx, expected);
                let c = self.std_arg(&args[2], cx, expected);
                if g.ty == ids::ERROR {
                    return err(span);
                }
                let Some((a, c, t)) = self.unify(a, c, f, span) else {
                    return err(span);
                };
                let (a, c, t) = self.settle(a, c, t, expected);
                self.fold(mk(vec![g, a, c], t))
            }
            Max | Min | Limit => {
                let mut xs: Vec<Expr> =
                    args.iter().map(|a| self.std_arg(a, cx, expected)).collect();
                if xs.iter().any(|x| x.ty == ids::ERROR) {
                    return err(span);
                }
                let mut t = xs[0].ty;
                for x in &xs[1..] {
                    let acc = konst(Value::Int(0), t, span);
                    let Some((_, _, nt)) = self.unify_types(acc, x.clone(), f, span) else {
                        return err(span);
                    };
                    t = nt;
                }
                let t = self.settle_type(t, expected);
                for x in xs.iter_mut() {
                    *x = self.coerce(x.clone(), t, f);
                }
                if xs.iter().any(|x| x.ty == ids::ERROR) {
                    return err(span);
                }
                let tt = self.types.get(t).clone();
                if matches!(tt, Type::Struct { .. } | Type::Array { .. } | Type::Fb(_)) {
                    self.arg_error(f, "elementary values", t, span);
                    return err(span);
                }
                self.fold(mk(xs, t))
            }
            Mux => {
                let k = self.std_arg(&args[0], cx, Some(ids::DINT));
                if k.ty == ids::ERROR {
                    return err(span);
                }
                if !self.is_integral(k.ty) {
                    self.arg_error(f, "an integer selector K", k.ty, args[0].span);
                    return err(span);
                }
                let k = self.widen_to_lint(k);
                let mut xs: Vec<Expr> = args[1..]
                    .iter()
                    .map(|a| self.std_arg(a, cx, expected))
                    .collect();
                if xs.iter().any(|x| x.ty == ids::ERROR) {
                    return err(span);
                }
                let mut t = xs[0].ty;
                for x in &xs[1..] {
                    let acc = konst(Value::Int(0), t, span);
                    let Some((_, _, nt)) = self.unify_types(acc, x.clone(), f, span) else {
                        return err(span);
                    };
                    t = nt;
                }
                let t = self.settle_type(t, expected);
                for x in xs.iter_mut() {
                    *x = self.coerce(x.clone(), t, f);
                }
                let mut all = vec![k];
                all.extend(xs);
                self.fold(mk(all, t))
            }
            _ => err(span),
        }
    }

    /// The string functions: LEN, LEFT, RIGHT, MID, CONCAT, INSERT, DELETE, REPLACE, FIND.
    fn string_builtin(
        &mut self,
        b: Builtin,
        f: &str,
        args: &[StdArg<'_>],
        span: Span,
        cx: &mut Cx,
    ) -> Expr {
        use Builtin::*;
        let mk = |args: Vec<Expr>, ty: TypeId| Expr {
            kind: ExprKind::Builtin(b, args),
            ty,
            span,
        };
        match b {
            Len => {
                let Some(s) = self.string_arg(f, &args[0], cx) else {
                    return err(span);
                };
                self.fold(mk(vec![s], ids::INT))
            }
            Left | Right => {
                let Some(s) = self.string_arg(f, &args[0], cx) else {
                    return err(span);
                };
                let Some(l) = self.int_arg(f, &args[1], cx) else {
                    return err(span);
                };
                let ty = s.ty;
                self.fold(mk(vec![s, l], ty))
            }
            Mid => {
                let Some(s) = self.string_arg(f, &args[0], cx) else {
                    return err(span);
                };
                let (Some(l), Some(p)) =
                    (self.int_arg(f, &args[1], cx), self.int_arg(f, &args[2], cx))
                else {
                    return err(span);
                };
                let ty = s.ty;
                self.fold(mk(vec![s, l, p], ty))
            }
            Concat => {
                let mut xs: Vec<Expr> = Vec::new();
                let mut len: u32 = 0;
                for a in args {
                    let Some(s) = self.string_arg(f, a, cx) else {
                        return err(span);
                    };
                    if let Some(first) = xs.first() {
                        if !self.same_width(f, first.ty, &s) {
                            return err(span);
                        }
                    }
                    len = len.saturating_add(self.str_len(s.ty));
                    xs.push(s);
                }
                let wide = self.types.is_wstring(xs[0].ty);
                let ty = self.types.string_of(len.clamp(1, MAX_STRING_LEN), wide);
                self.fold(mk(xs, ty))
            }
            Insert | Replace => {
                let Some(a) = self.string_arg(f, &args[0], cx) else {
                    return err(span);
                };
                let Some(c) = self.string_arg(f, &args[1], cx) else {
                    return err(span);
                };
                if !self.same_width(f, a.ty, &c) {
                    return err(span);
                }
                let mut xs = vec![a.clone(), c.clone()];
                for arg in &args[2..] {
                    let Some(n) = self.int_arg(f, arg, cx) else {
                        return err(span);
                    };
                    xs.push(n);
                }
                let len = self.str_len(a.ty).saturating_add(self.str_len(c.ty));
                let wide = self.types.is_wstring(a.ty);
                let ty = self.types.string_of(len.clamp(1, MAX_STRING_LEN), wide);
                self.fold(mk(xs, ty))
            }
            Delete => {
                let Some(s) = self.string_arg(f, &args[0], cx) else {
                    return err(span);
                };
                let (Some(l), Some(p)) =
                    (self.int_arg(f, &args[1], cx), self.int_arg(f, &args[2], cx))
                else {
                    return err(span);
                };
                let ty = s.ty;
                self.fold(mk(vec![s, l, p], ty))
            }
            Find => {
                let Some(a) = self.string_arg(f, &args[0], cx) else {
                    return err(span);
                };
                let Some(c) = self.string_arg(f, &args[1], cx) else {
                    return err(span);
                };
                if !self.same_width(f, a.ty, &c) {
                    return err(span);
                }
                self.fold(mk(vec![a, c], ids::INT))
            }
            _ => err(span),
        }
    }

    fn arg_error(&mut self, f: &str, want: &str, got: TypeId, span: Span) {
        let g = self.types.name(got);
        self.error(
            diag::TYPE_MISMATCH,
            span,
            format!("{f} takes {want}, not {g}"),
        );
    }

    fn real_arg(&mut self, f: &str, a: &StdArg<'_>, cx: &mut Cx, expected: Option<TypeId>) -> Expr {
        let real_hint = expected.filter(|t| self.types.elem(*t).is_some_and(|e| e.is_real()));
        let x = self.std_arg(a, cx, real_hint);
        if x.ty == ids::ERROR {
            return x;
        }
        match self.types.get(x.ty) {
            Type::IntLit | Type::RealLit => self.coerce(x, real_hint.unwrap_or(ids::LREAL), f),
            _ if self.types.elem(x.ty).is_some_and(|e| e.is_real()) => x,
            _ => {
                let t = self.types.name(x.ty);
                self.error(
                    diag::TYPE_MISMATCH,
                    a.span,
                    format!("{f} takes REAL or LREAL, not {t}; convert it (e.g. {t}_TO_REAL(x))"),
                );
                err(a.span)
            }
        }
    }

    fn string_arg(&mut self, f: &str, a: &StdArg<'_>, cx: &mut Cx) -> Option<Expr> {
        let x = self.std_arg(a, cx, Some(ids::STRING));
        if x.ty == ids::ERROR {
            return None;
        }
        if !self.types.is_string(x.ty) {
            self.arg_error(f, "a STRING or WSTRING", x.ty, a.span);
            return None;
        }
        Some(x)
    }

    /// Whether the string `x` is as wide as the first string argument (of type `first`):
    /// STRING and WSTRING do not mix in one call (the standard converts neither implicitly).
    fn same_width(&mut self, f: &str, first: TypeId, x: &Expr) -> bool {
        let (a, b) = (self.types.is_wstring(first), self.types.is_wstring(x.ty));
        if a == b {
            return true;
        }
        let (an, bn) = (self.types.name(first), self.types.name(x.ty));
        let conv = if a {
            "STRING_TO_WSTRING"
        } else {
            "WSTRING_TO_STRING"
        };
        self.error(
            diag::TYPE_MISMATCH,
            x.span,
            format!("{f} takes strings of one kind: this is {bn}, its first string {an}; convert it with {conv}(…)"),
        );
        false
    }

    fn int_arg(&mut self, f: &str, a: &StdArg<'_>, cx: &mut Cx) -> Option<Expr> {
        let x = self.std_arg(a, cx, Some(ids::INT));
        if x.ty == ids::ERROR {
            return None;
        }
        if !self.is_integral(x.ty) {
            self.arg_error(f, "an integer", x.ty, a.span);
            return None;
        }
        Some(self.widen_to_lint(x))
    }

    pub fn str_len(&self, ty: TypeId) -> u32 {
        match self.types.get(ty) {
            Type::Str { len, .. } => *len,
            _ => 0,
        }
    }

    /// Like `unify`, for finding a common type only.
    fn unify_types(
        &mut self,
        x: Expr,
        y: Expr,
        op: &str,
        span: Span,
    ) -> Option<(Expr, Expr, TypeId)> {
        self.unify(x, y, op, span)
    }

    /// A literal-typed generic result gets the expected type when it fits, else DINT/LREAL.
    pub(crate) fn settle_type(&self, t: TypeId, expected: Option<TypeId>) -> TypeId {
        match self.types.get(t) {
            Type::IntLit => expected
                .filter(|e| {
                    self.types
                        .elem(*e)
                        .is_some_and(|x| x.is_num() || x.is_bitstring())
                })
                .unwrap_or(ids::DINT),
            Type::RealLit => expected
                .filter(|e| self.types.elem(*e).is_some_and(|x| x.is_real()))
                .unwrap_or(ids::LREAL),
            _ => t,
        }
    }

    fn settle(
        &mut self,
        a: Expr,
        c: Expr,
        t: TypeId,
        expected: Option<TypeId>,
    ) -> (Expr, Expr, TypeId) {
        let t2 = self.settle_type(t, expected);
        if t2 == t {
            return (a, c, t);
        }
        let a = self.coerce(a, t2, "SEL's input");
        let c = self.coerce(c, t2, "SEL's input");
        (a, c, t2)
    }
}
