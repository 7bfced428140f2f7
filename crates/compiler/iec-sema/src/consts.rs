//! Constant folding: expressions of literals and constants are computed at compile time with
//! the same rules as the VM ([`crate::ops`]); an error there (a constant division by zero, an
//! overflow) is reported where it is written. Arithmetic that overflows is an error here even
//! where the run time wraps (as matiec refuses it): written out, it is a mistake; conversions
//! and shift counts follow the project's [`crate::ops::Overflow`].

use petriplc_iec_syntax::ast::{BinaryOp, UnaryOp};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::lexer::NANOS_PER_DAY;

use crate::check::Checker;
use crate::ir::{Builtin, Expr, ExprKind};
use crate::ops::{self, OpError};
use crate::types::{fits, ids, Elem, Type, TypeId};
use crate::value::Value;

/// How a value of a type is computed with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Class {
    IntLit,
    RealLit,
    Elem(Elem),
    Str,
    Enum,
    Other,
}

impl Checker<'_> {
    pub(crate) fn class(&self, ty: TypeId) -> Class {
        match self.types.get(ty) {
            Type::IntLit => Class::IntLit,
            Type::RealLit => Class::RealLit,
            Type::Elem(e) | Type::Subrange { base: e, .. } => Class::Elem(*e),
            Type::Str { .. } => Class::Str,
            Type::Enum { .. } => Class::Enum,
            _ => Class::Other,
        }
    }

    /// Computes an expression whose operands are constants; leaves others as they are.
    /// Reports errors of constant operations.
    pub fn fold(&mut self, e: Expr) -> Expr {
        let all_const = match &e.kind {
            ExprKind::Unary(_, x) | ExprKind::Convert(x) | ExprKind::Trunc(x) => x.is_const(),
            ExprKind::Binary(_, a, b) => a.is_const() && b.is_const(),
            ExprKind::Builtin(_, args) => args.iter().all(Expr::is_const),
            _ => false,
        };
        if !all_const {
            return e;
        }
        match self.eval(&e) {
            Ok(Some(v)) => Expr {
                kind: ExprKind::Const(v),
                ty: e.ty,
                span: e.span,
            },
            Ok(None) => e,
            Err(why) => {
                let msg = match why {
                    OpError::Overflow => format!(
                        "this constant expression overflows {}",
                        self.types.name(e.ty)
                    ),
                    OpError::DivisionByZero => {
                        "this constant expression divides by zero".to_string()
                    }
                    OpError::Conversion => format!(
                        "this constant does not convert to {}",
                        self.types.name(e.ty)
                    ),
                    OpError::Domain(w) => format!("this constant expression has no value: {w}"),
                };
                self.error(diag::OUT_OF_RANGE, e.span, msg);
                Expr {
                    kind: ExprKind::Const(Value::Int(0)),
                    ty: ids::ERROR,
                    span: e.span,
                }
            }
        }
    }

    /// The value of a constant expression, `None` when it is not constant or has an error.
    pub fn eval_const(&self, e: &Expr) -> Option<Value> {
        self.eval(e).ok().flatten()
    }

    /// Converts a constant between types (`None` when it cannot).
    pub fn convert_const(&self, v: &Value, from: TypeId, to: TypeId) -> Option<Value> {
        self.convert_value(v, from, to).ok()
    }

    fn convert_value(&self, v: &Value, from: TypeId, to: TypeId) -> Result<Value, OpError> {
        let (fc, tc) = (self.class(from), self.class(to));
        match (fc, tc) {
            (_, Class::Str) => {
                if let (Class::Elem(e), Type::Str { len, wide: true }) = (fc, self.types.get(to)) {
                    let mut w = ops::to_wide_text(v, e);
                    w.truncate(*len as usize);
                    return Ok(Value::WStr(w));
                }
                let bytes = match fc {
                    Class::Elem(e) => ops::to_text(v, e),
                    Class::Enum => match v {
                        Value::Int(i) => i.to_string().into_bytes(),
                        _ => Vec::new(),
                    },
                    Class::IntLit => ops::to_text(v, Elem::Lint),
                    Class::RealLit => ops::to_text(v, Elem::Lreal),
                    _ => match v {
                        Value::Str(s) => s.clone(),
                        Value::WStr(w) => {
                            // WSTRING to WSTRING keeps every unit; to STRING narrows.
                            if let Type::Str { len, wide: true } = self.types.get(to) {
                                return Ok(Value::WStr(
                                    w.iter().copied().take(*len as usize).collect(),
                                ));
                            }
                            ops::narrow(w)
                        }
                        _ => return Err(OpError::Conversion),
                    },
                };
                match self.types.get(to) {
                    Type::Str { len, wide: false } => {
                        Ok(Value::Str(bytes.into_iter().take(*len as usize).collect()))
                    }
                    Type::Str { len, wide: true } => Ok(Value::WStr(
                        ops::widen(&bytes).into_iter().take(*len as usize).collect(),
                    )),
                    _ => Err(OpError::Conversion),
                }
            }
            (Class::Str, Class::Elem(e)) => match v {
                Value::Str(s) => ops::from_text(s, e),
                Value::WStr(w) => ops::from_wide_text(w, e),
                _ => Err(OpError::Conversion),
            },
            (Class::IntLit | Class::Enum, Class::Elem(e)) => {
                ops::convert_elem(v, Elem::Lint, e, self.overflow)
            }
            (Class::RealLit, Class::Elem(e)) => ops::convert_elem(v, Elem::Lreal, e, self.overflow),
            (Class::Elem(a), Class::Elem(b)) => {
                let r = ops::convert_elem(v, a, b, self.overflow)?;
                if let (Type::Subrange { lo, hi, .. }, Value::Int(i)) = (self.types.get(to), &r) {
                    if i < lo || i > hi {
                        return Err(OpError::Conversion);
                    }
                }
                Ok(r)
            }
            (Class::IntLit, Class::RealLit) => Ok(Value::Real(v.as_real().unwrap_or(0.0))),
            (a, b) if a == b => Ok(v.clone()),
            _ => Err(OpError::Conversion),
        }
    }

    fn eval(&self, e: &Expr) -> Result<Option<Value>, OpError> {
        let v = match &e.kind {
            ExprKind::Const(v) => return Ok(Some(v.clone())),
            // An address is known when the program runs.
            ExprKind::Ref(_) => return Ok(None),
            ExprKind::Unary(op, x) => {
                let Some(v) = self.eval(x)? else {
                    return Ok(None);
                };
                self.eval_unary(*op, v, x.ty)?
            }
            ExprKind::Binary(op, a, b) => {
                let (Some(x), Some(y)) = (self.eval(a)?, self.eval(b)?) else {
                    return Ok(None);
                };
                self.eval_binary(*op, x, a.ty, y, b.ty, e.ty)?
            }
            ExprKind::Convert(x) => {
                let Some(v) = self.eval(x)? else {
                    return Ok(None);
                };
                self.convert_value(&v, x.ty, e.ty)?
            }
            ExprKind::Trunc(x) => {
                let Some(v) = self.eval(x)? else {
                    return Ok(None);
                };
                let Class::Elem(to) = self.class(e.ty) else {
                    return Ok(None);
                };
                Value::Int(ops::trunc_to_int(
                    v.as_real().unwrap_or(0.0),
                    to,
                    self.overflow,
                )?)
            }
            ExprKind::Builtin(b, args) => {
                let mut vals = Vec::new();
                for a in args {
                    let Some(v) = self.eval(a)? else {
                        return Ok(None);
                    };
                    vals.push(v);
                }
                match self.eval_builtin(*b, &vals, args, e.ty)? {
                    Some(v) => v,
                    None => return Ok(None),
                }
            }
            ExprKind::Load(_) | ExprKind::Call(_) => return Ok(None),
        };
        // At run time REAL arithmetic gives Inf and NaN (IEC 60559); written as a constant
        // expression, either is a mistake the author can see and fix, so it is refused here.
        if let Value::Real(f) = &v {
            if f.is_nan() {
                return Err(OpError::Domain("the result is not a number (NaN)"));
            }
            if f.is_infinite() {
                return Err(OpError::Overflow);
            }
        }
        Ok(Some(v))
    }

    fn eval_unary(&self, op: UnaryOp, v: Value, ty: TypeId) -> Result<Value, OpError> {
        Ok(match (op, self.class(ty), v) {
            (UnaryOp::Plus, _, v) => v,
            (UnaryOp::Neg, Class::IntLit, Value::Int(i)) => Value::Int(-i),
            (UnaryOp::Neg, Class::Elem(e), Value::Int(i)) => {
                Value::Int(ops::int_binary(BinaryOp::Sub, 0, i, e)?)
            }
            (UnaryOp::Neg, _, Value::Real(f)) => Value::Real(-f),
            (UnaryOp::Not, Class::Elem(Elem::Bool), Value::Int(i)) => Value::Int((i == 0) as i128),
            (UnaryOp::Not, Class::Elem(e), Value::Int(i)) => {
                Value::Int((!(i as u64) & ops::mask(e)) as i128)
            }
            _ => return Err(OpError::Conversion),
        })
    }

    fn eval_binary(
        &self,
        op: BinaryOp,
        x: Value,
        xt: TypeId,
        y: Value,
        yt: TypeId,
        rt: TypeId,
    ) -> Result<Value, OpError> {
        let (xc, yc, rc) = (self.class(xt), self.class(yt), self.class(rt));
        // Time arithmetic with mixed types.
        if let (Class::Elem(a), Class::Elem(b)) = (xc, yc) {
            if a != b && (a.is_duration() || a.is_date()) {
                let (Value::Int(i), yv) = (&x, &y) else {
                    return Err(OpError::Conversion);
                };
                let r = match (op, yv) {
                    (BinaryOp::Mul | BinaryOp::Div, Value::Real(f)) => {
                        if op == BinaryOp::Div && *f == 0.0 {
                            return Err(OpError::DivisionByZero);
                        }
                        let r = if op == BinaryOp::Mul {
                            *i as f64 * f
                        } else {
                            *i as f64 / f
                        };
                        let r = ops::round_even(r);
                        if !r.is_finite() || r.abs() > 9.2e18 {
                            return Err(OpError::Overflow);
                        }
                        r as i128
                    }
                    (_, Value::Int(j)) => ops::int_binary(op, *i, *j, Elem::Lint)?,
                    _ => return Err(OpError::Conversion),
                };
                let r = if rc == Class::Elem(Elem::Tod) {
                    r.rem_euclid(NANOS_PER_DAY)
                } else {
                    r
                };
                return Ok(Value::Int(r));
            }
        }
        let cmp = op.is_comparison();
        match (x, y) {
            (Value::Str(a), Value::Str(b)) => {
                Ok(Value::Int(compare(op, a.as_slice(), b.as_slice())? as i128))
            }
            (Value::WStr(a), Value::WStr(b)) => {
                Ok(Value::Int(compare(op, a.as_slice(), b.as_slice())? as i128))
            }
            (Value::Real(a), Value::Real(b)) => {
                let e = match xc {
                    Class::Elem(e) => e,
                    _ => Elem::Lreal,
                };
                if op == BinaryOp::Div && b == 0.0 {
                    return Err(OpError::DivisionByZero);
                }
                let r = ops::real_binary(op, a, b, e)?;
                Ok(if cmp {
                    Value::Int((r != 0.0) as i128)
                } else {
                    Value::Real(r)
                })
            }
            (Value::Real(a), Value::Int(n)) if op == BinaryOp::Power => {
                let e = match xc {
                    Class::Elem(e) => e,
                    _ => Elem::Lreal,
                };
                Ok(Value::Real(ops::real_power_int(a, n, e)))
            }
            (Value::Int(a), Value::Int(b)) => {
                let e = match (xc, yc) {
                    (Class::Elem(e), _) | (_, Class::Elem(e)) => e,
                    (Class::IntLit, Class::IntLit) => {
                        // Literals compute in 128 bits; the context checks the range later.
                        let r = match op {
                            BinaryOp::Add => a.checked_add(b),
                            BinaryOp::Sub => a.checked_sub(b),
                            BinaryOp::Mul => a.checked_mul(b),
                            _ => None,
                        };
                        if let Some(r) = r {
                            if fits(r, Elem::Lint) || fits(r, Elem::Ulint) {
                                return Ok(Value::Int(r));
                            }
                            return Err(OpError::Overflow);
                        }
                        Elem::Lint
                    }
                    _ => Elem::Lint,
                };
                Ok(Value::Int(ops::int_binary(op, a, b, e)?))
            }
            _ => Err(OpError::Conversion),
        }
    }

    fn eval_builtin(
        &self,
        b: Builtin,
        v: &[Value],
        args: &[Expr],
        rt: TypeId,
    ) -> Result<Option<Value>, OpError> {
        let elem = |t: TypeId| match self.class(t) {
            Class::Elem(e) => Some(e),
            Class::RealLit => Some(Elem::Lreal),
            Class::IntLit => Some(Elem::Lint),
            _ => None,
        };
        Ok(Some(match b {
            Builtin::Abs => match &v[0] {
                Value::Int(i) => Value::Int(ops::int_binary(
                    BinaryOp::Sub,
                    0,
                    -i.abs(),
                    elem(rt).unwrap_or(Elem::Lint),
                )?),
                Value::Real(f) => Value::Real(f.abs()),
                _ => return Ok(None),
            },
            Builtin::Sqrt
            | Builtin::Ln
            | Builtin::Log
            | Builtin::Exp
            | Builtin::Sin
            | Builtin::Cos
            | Builtin::Tan
            | Builtin::Asin
            | Builtin::Acos
            | Builtin::Atan => {
                let x = v[0].as_real().unwrap_or(0.0);
                Value::Real(ops::real_fn(b, x, elem(rt).unwrap_or(Elem::Lreal)))
            }
            Builtin::Atan2 => {
                let (y, x) = (v[0].as_real().unwrap_or(0.0), v[1].as_real().unwrap_or(0.0));
                Value::Real(ops::real_result(
                    y.atan2(x),
                    elem(rt).unwrap_or(Elem::Lreal),
                ))
            }
            Builtin::Max | Builtin::Min => {
                let mut best = v[0].clone();
                for x in &v[1..] {
                    let better = match (x, &best) {
                        (Value::Int(a), Value::Int(c)) => {
                            if b == Builtin::Max {
                                a > c
                            } else {
                                a < c
                            }
                        }
                        (Value::Real(a), Value::Real(c)) => {
                            if b == Builtin::Max {
                                a > c
                            } else {
                                a < c
                            }
                        }
                        (Value::Str(a), Value::Str(c)) => {
                            if b == Builtin::Max {
                                a > c
                            } else {
                                a < c
                            }
                        }
                        (Value::WStr(a), Value::WStr(c)) => {
                            if b == Builtin::Max {
                                a > c
                            } else {
                                a < c
                            }
                        }
                        _ => return Ok(None),
                    };
                    if better {
                        best = x.clone();
                    }
                }
                best
            }
            Builtin::Limit => match (&v[0], &v[1], &v[2]) {
                (Value::Int(mn), Value::Int(x), Value::Int(mx)) => Value::Int(*x.max(mn).min(mx)),
                (Value::Real(mn), Value::Real(x), Value::Real(mx)) => {
                    Value::Real(x.max(*mn).min(*mx))
                }
                _ => return Ok(None),
            },
            Builtin::Sel => {
                if v[0].as_int() == Some(0) {
                    v[1].clone()
                } else {
                    v[2].clone()
                }
            }
            Builtin::Mux => {
                let k = v[0].as_int().unwrap_or(-1);
                match usize::try_from(k).ok().and_then(|k| v.get(k + 1)) {
                    Some(x) => x.clone(),
                    None => return Err(OpError::Domain("MUX selector K out of range")),
                }
            }
            Builtin::Shl | Builtin::Shr | Builtin::Rol | Builtin::Ror => {
                let (Some(x), Some(n)) = (v[0].as_int(), v[1].as_int()) else {
                    return Ok(None);
                };
                let Some(e) = elem(args[0].ty) else {
                    return Ok(None);
                };
                Value::Int(ops::shift(b, x, n, e, self.overflow)?)
            }
            Builtin::BcdToInt | Builtin::IntToBcd => {
                let (Some(x), Some(to)) = (v[0].as_int(), elem(rt)) else {
                    return Ok(None);
                };
                Value::Int(if b == Builtin::BcdToInt {
                    ops::from_bcd(x, to)?
                } else {
                    ops::to_bcd(x, to)?
                })
            }
            Builtin::Len => match &v[0] {
                Value::Str(s) => Value::Int(s.len() as i128),
                Value::WStr(s) => Value::Int(s.len() as i128),
                _ => return Ok(None),
            },
            _ => return Ok(None),
        }))
    }
}

/// A comparison of two strings (bytes or UTF-16 units, in their order).
fn compare<T: Ord>(op: BinaryOp, a: &[T], b: &[T]) -> Result<bool, OpError> {
    Ok(match op {
        BinaryOp::Eq => a == b,
        BinaryOp::Ne => a != b,
        BinaryOp::Lt => a < b,
        BinaryOp::Le => a <= b,
        BinaryOp::Gt => a > b,
        BinaryOp::Ge => a >= b,
        _ => return Err(OpError::Conversion),
    })
}

impl Expr {
    pub fn is_const(&self) -> bool {
        matches!(self.kind, ExprKind::Const(_))
    }
}
