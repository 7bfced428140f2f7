//! Expressions: names, literals typed by their context, operators with the standard's type
//! rules, places (what can be written), and calls of functions (user and standard).

use petriplc_iec_syntax::ast::{self, ExprKind as A};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{Expr, ExprKind, Place, VarId};
use crate::types::{ids, Type, TypeId, TypeTable};
use crate::value::Value;

mod bcd;
mod builtin;
mod call;
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
            A::Field(..) | A::Index(..) | A::Bit(..) | A::Deref(_) => {
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
                self.error(
                    diag::UNSUPPORTED,
                    span,
                    format!("direct variable %{text} in code: declare a variable located on it (name AT %{text} : TYPE;) and use the name"),
                );
                err(span)
            }
            A::Unary(op, inner) => self.unary(*op, inner, cx, expected, span),
            A::Binary(op, a, b) => self.binary(*op, a, b, cx, expected, span),
            A::Call(call) => self.call_expr(call, cx, expected),
        }
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
