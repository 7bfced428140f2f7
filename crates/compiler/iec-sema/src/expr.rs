//! Expressions: names, literals typed by their context, operators with the standard's type
//! rules, places (what can be written), and calls of functions (user and standard).

use petriplc_iec_syntax::ast::{self, ExprKind as A, RefKind};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{Expr, ExprKind, Place, Root, Step, VarId};
use crate::types::{ids, Type, TypeId, TypeTable};
use crate::value::Value;

mod bcd;
mod bounds;
mod builtin;
mod call;
mod heap;
mod name;
mod operator;
mod place;
mod reference;
mod stdcall;
mod vendor;

pub(crate) fn err(span: Span) -> Expr {
    Expr {
        kind: ExprKind::Const(Value::Int(0)),
        ty: ids::ERROR,
        span,
    }
}

fn konst(v: Value, ty: TypeId, span: Span) -> Expr {
    Expr {
        kind: ExprKind::Const(v),
        ty,
        span,
    }
}

/// An argument of a standard function, bound to its position.
struct StdArg<'e> {
    expr: &'e ast::Expr,
    span: Span,
    /// In a typed form (`LIMIT_INT`): the type the argument must convert to implicitly, and
    /// what to call it in a message.
    typed: Option<(TypeId, String)>,
}

impl<'a> Checker<'a> {
    /// Checks an expression; `expected` is the type the context wants, when known (it
    /// resolves bare enumeration values and generic results, and types literals).
    pub fn expr(&mut self, e: &ast::Expr, cx: &mut Cx, expected: Option<TypeId>) -> Expr {
        let x = self.expr_inner(e, cx, expected);
        if self.types.is_var_array(x.ty) {
            return self.var_array_whole(x.span);
        }
        x
    }

    fn expr_inner(&mut self, e: &ast::Expr, cx: &mut Cx, expected: Option<TypeId>) -> Expr {
        let span = e.span;
        if matches!(e.kind, A::Name(_) | A::Field(..)) {
            if let Some(x) = self.property_read(e, cx) {
                return x;
            }
        }
        match &e.kind {
            A::Error => err(span),
            A::Literal(l) => self.literal(l, span),
            A::Paren(inner) => {
                let mut x = self.expr(inner, cx, expected);
                x.span = span;
                x
            }
            A::Name(id) => self.name(id, cx, expected),
            A::Field(base, var) if self.is_global_list(base, cx) => {
                match self.list_member(base, var) {
                    true => self.name(var, cx, expected),
                    false => err(span),
                }
            }
            A::Field(base, value) if self.is_enum_type_name(base, cx) => {
                // CODESYS's and TwinCAT's `E.Value` (the standard writes `E#Value`).
                let A::Name(ty) = &base.kind else {
                    return err(span);
                };
                let lit = ast::Literal::Enum {
                    ty: ty.clone(),
                    value: value.clone(),
                };
                self.literal(&lit, span)
            }
            A::Field(..) | A::Index(..) | A::Bit(..) | A::Part(..) | A::Deref(_) => {
                match self.value_place(e, cx, false) {
                    Some(p) => Expr {
                        ty: p.ty,
                        kind: ExprKind::Load(p),
                        span,
                    },
                    None => err(span),
                }
            }
            A::Direct(text) => {
                // `%IX1.1` names the variable declared on it without a name (`AT %IX1.1 :
                // BOOL;`, which the parser names `%IX1.1`).
                let id = ast::Ident::new(format!("%{text}"), span);
                if let Some(p) = self.var_place(&id, cx) {
                    return Expr {
                        ty: p.ty,
                        kind: ExprKind::Load(p),
                        span,
                    };
                }
                self.error(
                    diag::UNSUPPORTED,
                    span,
                    format!("direct variable %{text} in code: declare a variable located on it (`name AT %{text} : TYPE;`, or without a name: `AT %{text} : TYPE;`)"),
                );
                err(span)
            }
            A::Unary(op, inner) => self.unary(*op, inner, cx, expected, span),
            A::Binary(op, a, b) => self.binary(*op, a, b, cx, expected, span),
            A::Call(call) => {
                let x = self.call_expr(call, cx, expected);
                // A REFERENCE TO result is the variable it designates.
                match self.types.get(x.ty) {
                    Type::Ref {
                        kind: RefKind::ReferenceTo,
                        ..
                    } => {
                        let p = Place {
                            root: Root::Value,
                            ty: x.ty,
                            span,
                            path: vec![Step::Value(Box::new(x))],
                        };
                        let p = self.through_reference(p);
                        Expr {
                            ty: p.ty,
                            kind: ExprKind::Load(p),
                            span,
                        }
                    }
                    _ => x,
                }
            }
        }
    }

    /// Whether `base` of `base.x` names an enumeration type (or an alias of one) and no
    /// variable: then `base.x` is one of its values, as CODESYS and TwinCAT write them.
    fn is_enum_type_name(&mut self, base: &ast::Expr, cx: &mut Cx) -> bool {
        let A::Name(id) = &base.kind else {
            return false;
        };
        if !self.type_decls.contains_key(&id.key()) || self.var_place(id, cx).is_some() {
            return false;
        }
        let mark = self.diags.items.len();
        let (t, _) = self.type_by_name(id);
        self.diags.items.truncate(mark);
        matches!(self.types.get(t), Type::Enum { .. })
    }

    /// Whether `base` of `base.x` names a global variable list (a TwinCAT GVL) and no
    /// variable: then `base.x` is the list's global `x` ([`Checker::list_member`]).
    pub(crate) fn is_global_list(&mut self, base: &ast::Expr, cx: &mut Cx) -> bool {
        let A::Name(list) = &base.kind else {
            return false;
        };
        self.global_lists.contains_key(&list.key()) && self.var_place(list, cx).is_none()
    }

    /// Whether the global variable list `base` holds `x`; reported when it does not.
    pub(crate) fn list_member(&mut self, base: &ast::Expr, x: &ast::Ident) -> bool {
        let A::Name(list) = &base.kind else {
            return false;
        };
        let holds = self
            .global_lists
            .get(&list.key())
            .is_some_and(|vars| vars.contains(&x.key()));
        if !holds {
            let msg = format!(
                "the global variable list {} has no variable `{}`",
                list.name, x.name
            );
            self.error(diag::UNDECLARED, x.span, msg);
        }
        holds
    }

    /// A BOOL condition.
    pub fn cond(&mut self, e: &ast::Expr, cx: &mut Cx) -> Expr {
        let x = self.expr(e, cx, Some(ids::BOOL));
        if x.ty == ids::ERROR {
            return x;
        }
        if x.ty != ids::BOOL {
            let t = self.types.name(x.ty);
            self.error(
                diag::NOT_BOOL,
                e.span,
                format!("a condition must be BOOL, not {t}; compare it (e.g. `x <> 0`)"),
            );
            return err(e.span);
        }
        x
    }
}

/// `; write REAL_TO_INT(…)`-style advice for a mismatch between two types.
pub fn conversion_hint(types: &TypeTable, from: TypeId, to: TypeId) -> String {
    match (types.elem(from), types.elem(to)) {
        (Some(a), Some(b)) if a != b => {
            if a.is_real() && b.is_int() {
                format!(
                    "; convert explicitly: {}_TO_{}(…) rounds, TRUNC(…) truncates",
                    a.name(),
                    b.name()
                )
            } else {
                format!("; convert explicitly: {}_TO_{}(…)", a.name(), b.name())
            }
        }
        _ => match (types.get(from), types.elem(to)) {
            (Type::RealLit, Some(b)) if b.is_int() => {
                format!("; write an integer, or REAL_TO_{}(…)", b.name())
            }
            (Type::Str { .. }, Some(b)) if b.is_char() => {
                "; a CHAR literal is one character in single quotes ('a'), a WCHAR's in double quotes (\"a\")".into()
            }
            (Type::Str { wide: a, .. }, None) if matches!(types.get(to), Type::Str { wide, .. } if wide != a) => {
                if *a {
                    "; STRING and WSTRING do not mix implicitly: convert with WSTRING_TO_STRING(…)"
                        .into()
                } else {
                    "; STRING and WSTRING do not mix implicitly: convert with STRING_TO_WSTRING(…), or write the literal in double quotes".into()
                }
            }
            _ => String::new(),
        },
    }
}

impl Expr {
    pub fn const_int(&self) -> Option<i128> {
        match &self.kind {
            ExprKind::Const(Value::Int(v)) => Some(*v),
            _ => None,
        }
    }

    pub fn const_real(&self) -> Option<f64> {
        match &self.kind {
            ExprKind::Const(v) => v.as_real(),
            _ => None,
        }
    }
}

/// A call's arguments bound to parameter indices.
#[derive(Default)]
pub struct Bound {
    pub inputs: Vec<(VarId, Expr)>,
    pub in_outs: Vec<(VarId, Place)>,
    pub outputs: Vec<(VarId, Place, bool)>,
}
