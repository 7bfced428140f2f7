//! Built-in functions: the standard library's numeric, bit-string, selection and string
//! functions, and the vendor libraries' (`TIME()`, `GET_CHAR`, `X_TO_STRING(value, format)`).

use petriplc_iec_sema::ir::{Builtin, Expr, ExprKind};
use petriplc_iec_sema::types::{Elem, Type, TypeId};
use petriplc_iec_syntax::source::Span;

use crate::ext::{ExtOp, Kind};

use super::{elem_or_dint, kind, str_cap, CompileError, Fx, R};

impl<'c, 'p> Fx<'c, 'p> {
    pub(super) fn builtin(
        &mut self,
        b: Builtin,
        args: &[Expr],
        ty: TypeId,
        want: Option<u32>,
        span: Span,
    ) -> R<u32> {
        if b == Builtin::Bound {
            // Its array argument is not a value: the bound is read from its descriptor.
            return self.var_array_bound(args, want, span);
        }
        if b == Builtin::New {
            return self.heap_new(args, ty, want, span);
        }
        if b == Builtin::Free {
            return self.heap_free(&args[0], span);
        }
        if b == Builtin::Address {
            // The handle's bits are the number.
            let x = self.expr(&args[0], None)?;
            let d = want.unwrap_or_else(|| self.temp(1));
            if d != x {
                self.emit(crate::op::Op::Mov { d, s: x }, span);
            }
            return Ok(d);
        }
        let p = self.p();
        let mut xs = Vec::with_capacity(args.len());
        for a in args {
            xs.push(self.expr(a, None)?);
        }
        let k = kind(p, ty);
        let re = elem_or_dint(p, ty);
        let cap = str_cap(p, ty);
        let d = self.builtin_result(b, k, ty, want, span);
        if matches!(b, Builtin::BcdToInt | Builtin::IntToBcd) {
            let from = elem_or_dint(p, args[0].ty);
            self.ext(
                ExtOp::Bcd {
                    d,
                    s: xs[0],
                    from,
                    to: re,
                    decode: b == Builtin::BcdToInt,
                },
                span,
            );
            return Ok(d);
        }
        let op = match b {
            Builtin::ItfCheck => Some(ExtOp::ItfCheck { d, s: xs[0] }),
            Builtin::MemArea => Some(ExtOp::Area { d, p: xs[0] }),
            // PCWorx X_TO_STRING(value, format): the value's own type decides its text.
            Builtin::Format => Some(ExtOp::Format {
                d,
                s: xs[0],
                fmt: xs[1],
                from: elem_or_dint(p, args[0].ty),
                cap,
            }),
            _ => {
                // A string function's characters are its first argument's (LEN, FIND take
                // strings and give an integer).
                let wide = args.first().is_some_and(|a| p.types.is_wstring(a.ty));
                Self::builtin_op(b, d, xs, k, re, cap, wide)
            }
        };
        let Some(op) = op else {
            return Err(CompileError::Unsupported(format!(
                "{} as a builtin",
                b.name()
            )));
        };
        self.ext(op, span);
        Ok(d)
    }

    /// `__NEW`: a new object of the target type of the result `ty` (the POINTER TO T); the
    /// object's size and prototype are filled in when the program is linked.
    fn heap_new(&mut self, args: &[Expr], ty: TypeId, want: Option<u32>, span: Span) -> R<u32> {
        let p = self.p();
        let Type::Ref { target, .. } = p.types.get(ty) else {
            return Err(CompileError::Unsupported("__NEW of a non-pointer".into()));
        };
        let target = *target;
        if target > crate::pointer::MAX_TAGGED_TYPE {
            return Err(CompileError::Unsupported(format!(
                "__NEW of a type beyond the first {} types of a project",
                crate::pointer::MAX_TAGGED_TYPE
            )));
        }
        let n = match args.first() {
            Some(a) => Some(self.expr(a, None)?),
            None => None,
        };
        let d = want.unwrap_or_else(|| self.temp(1));
        self.ext(
            ExtOp::New {
                d,
                n,
                ty: target,
                slots: 0,
                proto: 0,
            },
            span,
        );
        Ok(d)
    }

    /// `__DELETE(p)`: through the variable's address when `p` is one, so it is set to NULL.
    fn heap_free(&mut self, arg: &Expr, span: Span) -> R<u32> {
        let op = match &arg.kind {
            ExprKind::Load(place) => {
                let pl = self.place_loc(place)?;
                let a = self.addr_of(pl.loc, span)?;
                ExtOp::Free {
                    p: a,
                    by_addr: true,
                }
            }
            _ => {
                let v = self.expr(arg, None)?;
                ExtOp::Free {
                    p: v,
                    by_addr: false,
                }
            }
        };
        self.ext(op, span);
        Ok(self.temp(1))
    }

    /// Where the result of `b` goes: a string buffer for string results, else `want` or a
    /// temporary.
    fn builtin_result(
        &mut self,
        b: Builtin,
        k: Kind,
        ty: TypeId,
        want: Option<u32>,
        span: Span,
    ) -> u32 {
        match b {
            Builtin::Len | Builtin::Find | Builtin::GetChar | Builtin::Time => {
                want.unwrap_or_else(|| self.temp(1))
            }
            Builtin::Left
            | Builtin::Right
            | Builtin::Mid
            | Builtin::Concat
            | Builtin::Insert
            | Builtin::Delete
            | Builtin::Replace => self.string_buffer(ty, span),
            _ if matches!(k, Kind::S | Kind::W) => self.string_buffer(ty, span),
            _ => want.unwrap_or_else(|| self.temp(1)),
        }
    }

    /// The instruction computing `b` over the argument slots `xs` into `d`, for a result of
    /// kind `k`, element `re` and string capacity `cap`; `None` for the conversions the checker
    /// lowers otherwise.
    fn builtin_op(
        b: Builtin,
        d: u32,
        xs: Vec<u32>,
        k: Kind,
        re: Elem,
        cap: u32,
        wide: bool,
    ) -> Option<ExtOp> {
        Some(match b {
            Builtin::Abs if re.is_real() => ExtOp::Math {
                f: Builtin::Abs,
                d,
                s: xs[0],
                e: re,
            },
            Builtin::Abs => ExtOp::AbsI { d, s: xs[0], e: re },
            Builtin::Sqrt
            | Builtin::Ln
            | Builtin::Log
            | Builtin::Exp
            | Builtin::Sin
            | Builtin::Cos
            | Builtin::Tan
            | Builtin::Asin
            | Builtin::Acos
            | Builtin::Atan => ExtOp::Math {
                f: b,
                d,
                s: xs[0],
                e: re,
            },
            Builtin::Atan2 => ExtOp::Atan2 {
                d,
                y: xs[0],
                x: xs[1],
                e: re,
            },
            Builtin::Max | Builtin::Min => ExtOp::MinMax {
                max: b == Builtin::Max,
                d,
                args: xs,
                kind: k,
                cap,
            },
            Builtin::Limit => ExtOp::Limit {
                d,
                mn: xs[0],
                x: xs[1],
                mx: xs[2],
                kind: k,
                cap,
            },
            Builtin::Sel | Builtin::Mux => ExtOp::Select {
                mux: b == Builtin::Mux,
                d,
                k: xs[0],
                args: xs[1..].to_vec(),
                kind: k,
                cap,
            },
            Builtin::Shl | Builtin::Shr | Builtin::Rol | Builtin::Ror => ExtOp::Shift {
                f: b,
                d,
                s: xs[0],
                n: xs[1],
                e: re,
            },
            Builtin::Len | Builtin::Find => ExtOp::Str {
                f: b,
                d,
                args: xs,
                cap: 0,
                wide,
            },
            Builtin::Left
            | Builtin::Right
            | Builtin::Mid
            | Builtin::Concat
            | Builtin::Insert
            | Builtin::Delete
            | Builtin::Replace => ExtOp::Str {
                f: b,
                d,
                args: xs,
                cap,
                wide,
            },
            Builtin::ConcatDateTod => ExtOp::ConcatDateTod {
                d,
                a: xs[0],
                b: xs[1],
            },
            Builtin::MemCpy | Builtin::MemSet | Builtin::MemCmp => ExtOp::Mem {
                f: b,
                d,
                a: xs[0],
                b: xs[1],
                n: xs[2],
            },
            Builtin::Time => ExtOp::Now { d },
            Builtin::GetChar => ExtOp::GetChar {
                d,
                s: xs[0],
                p: xs[1],
            },
            Builtin::Chr => ExtOp::Chr { d, s: xs[0], cap },
            Builtin::ItfType => ExtOp::ItfType { d, s: xs[0] },
            Builtin::DtToTod
            | Builtin::DtToDate
            | Builtin::Expt
            | Builtin::Format
            | Builtin::BcdToInt
            | Builtin::IntToBcd
            | Builtin::ItfCheck
            | Builtin::New
            | Builtin::Free
            | Builtin::MemArea
            | Builtin::Address
            | Builtin::Bound => return None,
        })
    }
}
