//! Standard functions: arguments bound by name, typed conversions (`X_TO_Y`, `TRUNC`).

use petriplc_iec_syntax::ast::{self, BinaryOp, UnaryOp};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{Builtin, Expr, ExprKind};
use crate::stdlib;
use crate::types::{ids, Elem, Type, TypeId, TypeTable};

use super::{err, StdArg};

/// The standard's string functions (CODESYS and TwinCAT also name their parameters their own
/// way, and have a WSTRING form of each, `W` + the name).
const STRING_FUNCTIONS: [&str; 9] = [
    "LEN", "LEFT", "RIGHT", "MID", "CONCAT", "INSERT", "DELETE", "REPLACE", "FIND",
];

impl<'a> Checker<'a> {
    /// Binds a standard function's arguments to its parameter names; `extensible`: the
    /// last name repeats with increasing numbers.
    pub(super) fn std_args<'e>(
        &mut self,
        fname: &str,
        call: &'e ast::Call,
        params: &[&str],
        min: usize,
        extensible: bool,
    ) -> Option<Vec<StdArg<'e>>> {
        let formal = call.args.iter().any(|a| a.name.is_some());
        let typed = stdlib::typed_form(fname).and_then(|(g, t)| Some((g, self.conv_type(&t)?)));
        let mut out: Vec<Option<StdArg<'e>>> = Vec::new();
        for (k, a) in call.args.iter().enumerate() {
            if a.output {
                self.error(
                    diag::BAD_ARGUMENTS,
                    a.span,
                    format!("{fname} has no outputs to connect"),
                );
                return None;
            }
            let idx = match &a.name {
                // CODESYS and TwinCAT: argument k without a name is parameter k (TcUnit's
                // `FIND(STR1 := TestSuiteName, '.')`).
                None if formal && !self.dialect.is_codesys_family() => {
                    self.error(
                        diag::BAD_ARGUMENTS,
                        call.span,
                        format!("the call of {fname} mixes named and positional arguments; name them all (CODESYS and TwinCAT take argument k without a name as parameter k: --dialect codesys or twincat)"),
                    );
                    return None;
                }
                None => k,
                Some(n) => {
                    let key = self.vendor_param(fname, n.key());
                    match params.iter().position(|p| *p == key) {
                        Some(i) => i,
                        None if extensible => {
                            // IN1, IN2, … beyond the listed names.
                            let last = params.last().copied().unwrap_or("IN");
                            let stem = last.trim_end_matches(|c: char| c.is_ascii_digit());
                            let first_num: usize = last[stem.len()..].parse().unwrap_or(0);
                            match key.strip_prefix(stem).and_then(|d| d.parse::<usize>().ok()) {
                                Some(d) if d >= first_num => params.len() - 1 + (d - first_num),
                                _ => {
                                    self.error(
                                        diag::BAD_ARGUMENTS,
                                        n.span,
                                        format!("{fname} has no parameter `{}`; its parameters are {}, …", n.name, params.join(", ")),
                                    );
                                    return None;
                                }
                            }
                        }
                        None => {
                            self.error(
                                diag::BAD_ARGUMENTS,
                                n.span,
                                format!(
                                    "{fname} has no parameter `{}`; its parameters are {}",
                                    n.name,
                                    params.join(", ")
                                ),
                            );
                            return None;
                        }
                    }
                }
            };
            if !extensible && idx >= params.len() {
                self.error(
                    diag::BAD_ARGUMENTS,
                    a.span,
                    format!(
                        "{fname} takes {} argument(s) ({})",
                        params.len(),
                        params.join(", ")
                    ),
                );
                return None;
            }
            if out.len() <= idx {
                out.resize_with(idx + 1, || None);
            }
            if out[idx].is_some() {
                self.error(diag::BAD_ARGUMENTS, a.span, "this parameter is given twice");
                return None;
            }
            let Some(v) = a.value.as_ref() else {
                self.error(diag::BAD_ARGUMENTS, a.span, "give this parameter a value");
                return None;
            };
            out[idx] = Some(StdArg {
                expr: v,
                span: a.span,
                typed: typed
                    .filter(|(g, _)| stdlib::typed_param(g, idx))
                    .map(|(_, t)| (t, format!("argument {} of {fname}", idx + 1))),
            });
        }
        let n = out.len();
        if n < min || out.iter().any(|a| a.is_none()) {
            self.error(
                diag::BAD_ARGUMENTS,
                call.span,
                format!(
                    "{fname} takes {}{} argument(s) ({}{})",
                    if extensible { "at least " } else { "" },
                    min,
                    params.join(", "),
                    if extensible { ", …" } else { "" }
                ),
            );
            return None;
        }
        Some(out.into_iter().flatten().collect())
    }

    /// A standard function's argument, checked; in a typed form, converted to its type
    /// (implicitly only: anything else is an error naming the conversion to write).
    pub(super) fn std_arg(&mut self, a: &StdArg<'_>, cx: &mut Cx, hint: Option<TypeId>) -> Expr {
        match &a.typed {
            None => self.expr(a.expr, cx, hint),
            Some((t, what)) => {
                let x = self.expr(a.expr, cx, Some(*t));
                self.coerce(x, *t, what)
            }
        }
    }

    /// A standard function call, or `None` when `name` is not one.
    pub(super) fn std_call(
        &mut self,
        name: &ast::Ident,
        call: &ast::Call,
        cx: &mut Cx,
        expected: Option<TypeId>,
    ) -> Option<Expr> {
        let key = name.key();
        let span = call.span;
        if let Some(bcd) = stdlib::bcd_conversion(&key) {
            return Some(self.bcd(name, call, cx, bcd, expected));
        }
        // A typed form (`SHR_DWORD`) is its generic function (`SHR`) with the arguments
        // `std_args` types; messages name the form.
        let typed = stdlib::typed_form(&key);
        let shown = key.as_str();
        let f = typed.as_ref().map_or(shown, |(g, _)| *g);
        // CODESYS's and TwinCAT's WSTRING forms (`WLEN`, `WCONCAT`…) are the standard's
        // string functions, which take WSTRING as well.
        let f = match f.strip_prefix('W') {
            Some(g) if self.dialect.is_codesys_family() && STRING_FUNCTIONS.contains(&g) => g,
            _ => f,
        };
        use BinaryOp::*;
        // Operators as functions.
        let op = match f {
            "ADD" | "ADD_TIME" | "ADD_LTIME" | "ADD_TOD_TIME" | "ADD_DT_TIME" => Some((Add, true)),
            // MULTIME and DIVTIME: the standard's second edition's names, which matiec keeps
            // (OSCAT as OpenPLC builds it calls them).
            "MUL" | "MUL_TIME" | "MUL_LTIME" | "MULTIME" => Some((Mul, true)),
            "SUB" | "SUB_TIME" | "SUB_LTIME" | "SUB_TOD_TIME" | "SUB_DT_TIME" | "SUB_DATE_DATE"
            | "SUB_TOD_TOD" | "SUB_DT_DT" => Some((Sub, false)),
            "DIV" | "DIV_TIME" | "DIV_LTIME" | "DIVTIME" => Some((Div, false)),
            "MOD" => Some((Mod, false)),
            "AND" => Some((And, true)),
            "OR" => Some((Or, true)),
            "XOR" => Some((Xor, true)),
            "EXPT" => Some((Power, false)),
            _ => None,
        };
        if let Some((op, ext)) = op {
            let args = self.std_args(shown, call, &["IN1", "IN2"], 2, ext)?;
            let mut acc = self.std_arg(&args[0], cx, expected);
            for a in &args[1..] {
                let y = self.std_arg(a, cx, expected);
                acc = self.binary_checked(op, acc, y, span);
            }
            acc.span = span;
            return Some(acc);
        }
        let cmp = match f {
            "GT" => Some(Gt),
            "GE" => Some(Ge),
            "EQ" => Some(Eq),
            "LE" => Some(Le),
            "LT" => Some(Lt),
            "NE" => Some(Ne),
            _ => None,
        };
        if let Some(op) = cmp {
            let ext = op != Ne;
            let args = self.std_args(shown, call, &["IN1", "IN2"], 2, ext)?;
            let xs: Vec<Expr> = args.iter().map(|a| self.std_arg(a, cx, None)).collect();
            let mut acc: Option<Expr> = None;
            for w in xs.windows(2) {
                let c = self.binary_checked(op, w[0].clone(), w[1].clone(), span);
                acc = Some(match acc {
                    None => c,
                    Some(a) => self.binary_checked(And, a, c, span),
                });
            }
            return acc;
        }
        match f {
            "NOT" => {
                let args = self.std_args(shown, call, &["IN"], 1, false)?;
                if args[0].typed.is_some() {
                    let x = self.std_arg(&args[0], cx, expected);
                    return Some(self.not_checked(x, expected, span));
                }
                return Some(self.unary(UnaryOp::Not, args[0].expr, cx, expected, span));
            }
            "MOVE" => {
                let args = self.std_args(shown, call, &["IN"], 1, false)?;
                return Some(self.std_arg(&args[0], cx, expected));
            }
            _ => {}
        }
        if let Some((from, to, trunc)) = stdlib::conversion_of(f) {
            if f == "TRUNC" {
                // handled below
            } else if let Some(x) = self.vendor_format(name, call, cx, from.as_deref(), &to) {
                return Some(x);
            } else {
                return Some(self.conversion(name, call, cx, from, &to, trunc));
            }
        }
        let b = match f {
            "ABS" => Builtin::Abs,
            "SQRT" => Builtin::Sqrt,
            "LN" => Builtin::Ln,
            "LOG" => Builtin::Log,
            "EXP" => Builtin::Exp,
            "SIN" => Builtin::Sin,
            "COS" => Builtin::Cos,
            "TAN" => Builtin::Tan,
            "ASIN" => Builtin::Asin,
            "ACOS" => Builtin::Acos,
            "ATAN" => Builtin::Atan,
            "ATAN2" => Builtin::Atan2,
            "SEL" => Builtin::Sel,
            "MAX" => Builtin::Max,
            "MIN" => Builtin::Min,
            "LIMIT" => Builtin::Limit,
            "MUX" => Builtin::Mux,
            "SHL" => Builtin::Shl,
            "SHR" => Builtin::Shr,
            "ROL" => Builtin::Rol,
            "ROR" => Builtin::Ror,
            "LEN" => Builtin::Len,
            "LEFT" => Builtin::Left,
            "RIGHT" => Builtin::Right,
            "MID" => Builtin::Mid,
            "CONCAT" => Builtin::Concat,
            "INSERT" => Builtin::Insert,
            "DELETE" => Builtin::Delete,
            "REPLACE" => Builtin::Replace,
            "FIND" => Builtin::Find,
            "CONCAT_DATE_TOD" => Builtin::ConcatDateTod,
            "TRUNC" => {
                let args = self.std_args(shown, call, &["IN"], 1, false)?;
                let x = self.expr(args[0].expr, cx, None);
                let to = expected
                    .filter(|t| self.types.elem(*t).is_some_and(|e| e.is_int()))
                    .unwrap_or(ids::DINT);
                return Some(self.trunc(x, to, span));
            }
            _ => return None,
        };
        Some(self.builtin(b, shown, call, cx, expected))
    }

    fn trunc(&mut self, x: Expr, to: TypeId, span: Span) -> Expr {
        if x.ty == ids::ERROR {
            return x;
        }
        let x = if x.ty == ids::REAL_LIT || x.ty == ids::INT_LIT {
            self.coerce(x, ids::LREAL, "TRUNC's input")
        } else {
            x
        };
        if !self.types.elem(x.ty).is_some_and(|e| e.is_real()) {
            let t = self.types.name(x.ty);
            self.error(
                diag::TYPE_MISMATCH,
                span,
                format!("TRUNC takes REAL or LREAL, not {t}"),
            );
            return err(span);
        }
        self.fold(Expr {
            kind: ExprKind::Trunc(Box::new(x)),
            ty: to,
            span,
        })
    }

    fn conversion(
        &mut self,
        name: &ast::Ident,
        call: &ast::Call,
        cx: &mut Cx,
        from: Option<String>,
        to: &str,
        trunc: bool,
    ) -> Expr {
        let span = call.span;
        let f = name.key();
        let Some(args) = self.std_args(&f, call, &["IN"], 1, false) else {
            return err(span);
        };
        let to_ty = match self.conv_type(to) {
            Some(t) => t,
            None => {
                self.error(
                    diag::UNKNOWN_POU,
                    name.span,
                    format!(
                        "unknown function `{}`: {to} is not an elementary type",
                        name.name
                    ),
                );
                return err(span);
            }
        };
        let from_ty = match &from {
            Some(fr) => match self.conv_type(fr) {
                Some(t) => Some(t),
                None => {
                    self.error(
                        diag::UNKNOWN_POU,
                        name.span,
                        format!(
                            "unknown function `{}`: {fr} is not an elementary type",
                            name.name
                        ),
                    );
                    return err(span);
                }
            },
            None => None,
        };
        let x = self.expr(args[0].expr, cx, from_ty);
        if x.ty == ids::ERROR {
            return x;
        }
        let x = match from_ty {
            Some(ft) => {
                // The argument must be of the named type (or widen to it).
                let from_elem = self.types.elem(ft);
                let ok_same = self.base_type(x.ty) == ft
                    || matches!(
                        (self.types.get(x.ty), self.types.get(ft)),
                        (Type::Str { wide: a, .. }, Type::Str { wide: b, .. }) if a == b
                    );
                // CODESYS and TwinCAT take an enumeration for an integer (TcUnit's
                // `UDINT_TO_INT(AnyTypeClass)`): its value's number.
                let enum_as_int = self.dialect.is_codesys_family()
                    && matches!(self.types.get(x.ty), Type::Enum { .. })
                    && from_elem.is_some_and(|e| e.is_int() || e.is_bitstring())
                    && self.convertible(x.ty, ft);
                if enum_as_int {
                    Expr {
                        kind: ExprKind::Convert(Box::new(x)),
                        ty: ft,
                        span: args[0].span,
                    }
                } else if ok_same
                    || matches!(self.types.get(x.ty), Type::IntLit | Type::RealLit)
                    || self.assignable(x.ty, ft)
                {
                    self.coerce(x, ft, &format!("the argument of {}", name.name))
                } else {
                    let (a, b) = (self.types.name(x.ty), self.types.name(ft));
                    let _ = from_elem;
                    // A string's conversions are named by its kind, not its length.
                    let an = match self.types.get(x.ty) {
                        Type::Str { wide: true, .. } => "WSTRING".to_string(),
                        Type::Str { wide: false, .. } => "STRING".to_string(),
                        _ => a.clone(),
                    };
                    let fix = if an == to {
                        format!("it is {to} already: leave the conversion out")
                    } else {
                        format!("use {an}_TO_{to} (or TO_{to})")
                    };
                    self.error(
                        diag::TYPE_MISMATCH,
                        args[0].span,
                        format!(
                            "{} converts {b}, and this argument is {a}; {fix}",
                            name.name
                        ),
                    );
                    return err(span);
                }
            }
            None => match self.types.get(x.ty) {
                Type::IntLit => self.coerce(x, ids::LINT, "the argument"),
                Type::RealLit => self.coerce(x, ids::LREAL, "the argument"),
                _ => x,
            },
        };
        if x.ty == ids::ERROR {
            return x;
        }
        if trunc {
            return self.trunc(x, to_ty, span);
        }
        let x = self.via_number(x, to_ty);
        if !self.convertible(x.ty, to_ty) {
            let (a, b) = (self.types.name(x.ty), self.types.name(to_ty));
            self.error(
                diag::TYPE_MISMATCH,
                span,
                format!("{a} cannot be converted to {b}"),
            );
            return err(span);
        }
        let x = if let Type::Enum { .. } = self.types.get(x.ty) {
            x
        } else {
            x
        };
        self.fold(Expr {
            kind: ExprKind::Convert(Box::new(x)),
            ty: to_ty,
            span,
        })
    }

    fn conv_type(&mut self, name: &str) -> Option<TypeId> {
        if let Some(e) = Elem::from_name(name) {
            return Some(TypeTable::elem_id(e));
        }
        match name {
            "STRING" => Some(ids::STRING),
            "WSTRING" => Some(ids::WSTRING),
            _ => None,
        }
    }

    /// Whether the explicit conversion functions convert `from` to `to`.
    /// CODESYS and TwinCAT convert among durations, dates and numbers through the number
    /// each stands for (`TO_DT(r)` of a REAL, `TO_LREAL(d)` of a DATE, `TO_DT(t)` of a TIME),
    /// where the standard has no conversion: `x` as that number (a LINT; a real rounded),
    /// which then converts to `to` as integers do. Else `x` as it is.
    fn via_number(&mut self, x: Expr, to: TypeId) -> Expr {
        if !self.dialect.is_codesys_family() || self.convertible(x.ty, to) {
            return x;
        }
        let timeish = |e: Elem| e.is_num() || e.is_duration() || e.is_date();
        // A pointer to a number or a string: its handle's number (`TO_STRING(p)`), never
        // the other way (STRING_TO_PVOID is NULL: vendor library).
        if matches!(
            self.types.get(x.ty),
            Type::Ref {
                kind: ast::RefKind::PointerTo,
                ..
            }
        ) && (matches!(self.types.get(to), Type::Str { .. })
            || self.types.elem(to).is_some_and(timeish))
        {
            let span = x.span;
            return Expr {
                kind: ExprKind::Builtin(Builtin::Address, vec![x]),
                ty: ids::ULINT,
                span,
            };
        }
        let (Some(a), Some(b)) = (self.types.elem(x.ty), self.types.elem(to)) else {
            return x;
        };
        if !timeish(a) || !timeish(b) {
            return x;
        }
        // Two reals always convert, so the number in between is an integer.
        if !self.convertible(x.ty, ids::LINT) || !self.convertible(ids::LINT, to) {
            return x;
        }
        self.convert(x, ids::LINT)
    }

    pub(super) fn convertible(&self, from: TypeId, to: TypeId) -> bool {
        let s = |t: TypeId| matches!(self.types.get(t), Type::Str { .. });
        if s(from) && s(to) {
            return true;
        }
        let fe = self.types.elem(from).or(match self.types.get(from) {
            Type::Enum { .. } => Some(Elem::Dint),
            _ => None,
        });
        // An enumeration's value is its DINT number, as the VM stores it.
        let te = self.types.elem(to).or(match self.types.get(to) {
            Type::Enum { .. } => Some(Elem::Dint),
            _ => None,
        });
        match (fe, te) {
            (Some(a), Some(b)) => {
                let date = |e: Elem| e.is_date();
                // Dates convert among themselves (DT → DATE, DT → TOD) and to/from integers.
                if date(a) && date(b) {
                    return a == b || a == Elem::Dt;
                }
                if (a.is_duration() || date(a)) && b.is_real()
                    || (b.is_duration() || date(b)) && a.is_real()
                {
                    return a.is_duration() || b.is_duration();
                }
                if a.is_duration() && date(b) || date(a) && b.is_duration() {
                    return false;
                }
                // A character converts to and from its code (CHAR_TO_BYTE, WORD_TO_WCHAR)
                // and to the other character type; not to a real, a duration or BOOL.
                if a.is_char() || b.is_char() {
                    let code = |e: Elem| e.is_char() || e.is_int() || e.is_bitstring();
                    return code(a) && code(b);
                }
                true
            }
            (Some(_), None) if s(to) => true,
            (None, Some(_)) if s(from) => true,
            _ => false,
        }
    }

    /// The standard's name of a string function's parameter written with CODESYS's and
    /// TwinCAT's (Tc2_Standard: `LEN(STR)`, `LEFT(STR, SIZE)`, `MID(STR, LEN, POS)`,
    /// `CONCAT(STR1, STR2)`, `INSERT(STR1, STR2, POS)`…), in those dialects.
    fn vendor_param(&self, fname: &str, key: String) -> String {
        let f = fname.to_ascii_uppercase();
        let f = f
            .strip_prefix('W')
            .filter(|g| STRING_FUNCTIONS.contains(g))
            .unwrap_or(&f);
        if !self.dialect.is_codesys_family() || !STRING_FUNCTIONS.contains(&f) {
            return key;
        }
        let standard = match key.as_str() {
            "STR" => "IN",
            "STR1" => "IN1",
            "STR2" => "IN2",
            "SIZE" | "LEN" => "L",
            "POS" => "P",
            _ => return key,
        };
        standard.to_string()
    }
}
