//! Small builders of the syntax tree, for the lowerings that write statements themselves
//! (LD, FBD and SFC, graphical or textual).

use crate::ast::*;
use crate::lexer::TimeKind;
use crate::source::Span;

pub(crate) fn name(n: &str, span: Span) -> Expr {
    Expr {
        kind: ExprKind::Name(Ident::new(n, span)),
        span,
    }
}
pub(crate) fn field(e: Expr, f: &str) -> Expr {
    let span = e.span;
    Expr {
        kind: ExprKind::Field(Box::new(e), Ident::new(f, span)),
        span,
    }
}
pub(crate) fn boolean(v: bool, span: Span) -> Expr {
    Expr {
        kind: ExprKind::Literal(Literal::Bool { value: v, ty: None }),
        span,
    }
}
pub(crate) fn time(nanos: i128, span: Span) -> Expr {
    Expr {
        kind: ExprKind::Literal(Literal::Time {
            kind: TimeKind::Time,
            nanos,
        }),
        span,
    }
}
pub(crate) fn not(e: Expr) -> Expr {
    let span = e.span;
    Expr {
        kind: ExprKind::Unary(UnaryOp::Not, Box::new(e)),
        span,
    }
}
pub(crate) fn bin(op: BinaryOp, a: Expr, b: Expr) -> Expr {
    let span = b.span;
    Expr {
        kind: ExprKind::Binary(op, Box::new(a), Box::new(b)),
        span,
    }
}
pub(crate) fn is_true(e: &Expr) -> bool {
    matches!(e.kind, ExprKind::Literal(Literal::Bool { value: true, .. }))
}
/// `a AND b`, dropping a TRUE operand (a contact right after the rail).
pub(crate) fn and(a: Expr, b: Expr) -> Expr {
    if is_true(&a) {
        b
    } else if is_true(&b) {
        a
    } else {
        bin(BinaryOp::And, a, b)
    }
}
/// `op` over terms: from left to right as written for a few, as a balanced tree for many, so
/// that an input wired to thousands of branches (or a step with thousands of transitions)
/// gives a tree a dozen levels deep rather than thousands.
pub(crate) fn fold_terms(op: BinaryOp, mut es: Vec<Expr>) -> Option<Expr> {
    const IN_A_ROW: usize = 8;
    if es.len() <= IN_A_ROW {
        let mut es = es.into_iter();
        let first = es.next()?;
        return Some(es.fold(first, |a, b| bin(op, a, b)));
    }
    let right = es.split_off(es.len() / 2);
    Some(bin(op, fold_terms(op, es)?, fold_terms(op, right)?))
}
pub(crate) fn any(es: Vec<Expr>, span: Span) -> Expr {
    fold_terms(BinaryOp::Or, es).unwrap_or_else(|| boolean(false, span))
}
/// The AND of the terms, TRUE ones dropped.
pub(crate) fn all(es: Vec<Expr>, span: Span) -> Expr {
    let es = es.into_iter().filter(|e| !is_true(e)).collect();
    fold_terms(BinaryOp::And, es).unwrap_or_else(|| boolean(true, span))
}
pub(crate) fn assign(target: Expr, value: Expr) -> Stmt {
    let span = target.span;
    Stmt {
        kind: StmtKind::Assign { target, value },
        span,
    }
}
pub(crate) fn when(cond: Expr, body: Vec<Stmt>) -> Stmt {
    let span = cond.span;
    Stmt {
        kind: StmtKind::If {
            branches: vec![(cond, body)],
            else_body: None,
        },
        span,
    }
}
pub(crate) fn arg(n: &str, value: Expr) -> Arg {
    let span = value.span;
    Arg {
        name: Some(Ident::new(n, span)),
        output: false,
        negated: false,
        value: Some(value),
        span,
    }
}
pub(crate) fn call(callee: Expr, args: Vec<Arg>) -> Call {
    let span = callee.span;
    Call {
        callee: Box::new(callee),
        args,
        span,
    }
}
pub(crate) fn decl(n: &str, ty: &str, init: Option<Init>, span: Span) -> VarDecl {
    VarDecl {
        names: vec![Ident::new(n, span)],
        location: None,
        ty: TypeSpec::Named(Ident::new(ty, span)),
        init,
        edge: None,
        fb_init: None,
        span,
    }
}
