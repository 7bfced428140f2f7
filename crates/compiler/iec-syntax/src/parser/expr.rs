//! Expressions by the standard's precedence: binary chains, unary, postfix (fields, indices,
//! calls), primaries and typed literals.

use crate::ast::*;
use crate::diag;
use crate::lexer::{Kw, Tok};
use crate::source::Span;

use super::{PResult, Parser, Reported};

impl<'a, 'd> Parser<'a, 'd> {
    pub(super) fn expr(&mut self) -> PResult<Expr> {
        self.enter()?;
        let r = self.binary(0);
        self.leave();
        r
    }

    /// Operators by binding power: OR 1, XOR 2, AND 3, = <> 4, < > <= >= 5, + - 6,
    /// `* / MOD` 7, ** 8. CODESYS's short-circuit `OR_ELSE` and `AND_THEN` bind as OR
    /// and AND; they are words, not reserved (a variable may still be called so elsewhere).
    fn binary_op(&self) -> Option<(BinaryOp, u8)> {
        if self.at_word("OR_ELSE") {
            return Some((BinaryOp::OrElse, 1));
        }
        if self.at_word("AND_THEN") {
            return Some((BinaryOp::AndThen, 3));
        }
        Some(match self.peek().tok {
            Tok::Kw(Kw::Or) => (BinaryOp::Or, 1),
            Tok::Kw(Kw::Xor) => (BinaryOp::Xor, 2),
            Tok::Kw(Kw::And) | Tok::Amp => (BinaryOp::And, 3),
            Tok::Eq => (BinaryOp::Eq, 4),
            Tok::Ne => (BinaryOp::Ne, 4),
            Tok::Lt => (BinaryOp::Lt, 5),
            Tok::Le => (BinaryOp::Le, 5),
            Tok::Gt => (BinaryOp::Gt, 5),
            Tok::Ge => (BinaryOp::Ge, 5),
            Tok::Plus => (BinaryOp::Add, 6),
            Tok::Minus => (BinaryOp::Sub, 6),
            Tok::Star => (BinaryOp::Mul, 7),
            Tok::Slash => (BinaryOp::Div, 7),
            Tok::Kw(Kw::Mod) => (BinaryOp::Mod, 7),
            Tok::Power => (BinaryOp::Power, 8),
            _ => return None,
        })
    }

    fn binary(&mut self, min: u8) -> PResult<Expr> {
        let mut links = 0;
        let r = self.binary_chain(min, &mut links);
        self.unlink(links);
        r
    }

    fn binary_chain(&mut self, min: u8, links: &mut usize) -> PResult<Expr> {
        let mut lhs = self.unary()?;
        while let Some((op, bp)) = self.binary_op() {
            if bp <= min {
                break;
            }
            self.bump();
            self.link(links)?;
            self.enter()?;
            let rhs = self.binary(bp);
            self.leave();
            let rhs = rhs?;
            let span = lhs.span.to(rhs.span);
            lhs = Expr {
                kind: ExprKind::Binary(op, Box::new(lhs), Box::new(rhs)),
                span,
            };
        }
        Ok(lhs)
    }

    pub(super) fn unary(&mut self) -> PResult<Expr> {
        let start = self.peek().span;
        let op = match self.peek().tok {
            Tok::Minus => UnaryOp::Neg,
            Tok::Plus => UnaryOp::Plus,
            // NOT(IN := x): the standard function with its parameter named (`NOT(x)` is the
            // operator on a parenthesised operand, the same value).
            Tok::Kw(Kw::Not)
                if self.peek_at(1).tok == Tok::LParen
                    && self.peek_at(2).tok == Tok::Ident
                    && self.peek_at(3).tok == Tok::Assign =>
            {
                return self.postfix();
            }
            Tok::Kw(Kw::Not) => UnaryOp::Not,
            _ => return self.postfix(),
        };
        self.bump();
        self.enter()?;
        let e = self.unary();
        self.leave();
        let e = e?;
        let span = start.to(e.span);
        Ok(Expr {
            kind: ExprKind::Unary(op, Box::new(e)),
            span,
        })
    }

    /// A primary followed by `.field`, `.3`, `[i]` and `(args)`.
    pub(super) fn postfix(&mut self) -> PResult<Expr> {
        let mut links = 0;
        let r = self.postfix_chain(&mut links);
        self.unlink(links);
        r
    }

    /// The fields, subscripts, calls and `^` after `e` (already read): the rest of a
    /// designator such as a FOR loop's control variable `a[1]`.
    pub(super) fn designator_after(&mut self, e: Expr) -> PResult<Expr> {
        let mut links = 0;
        let r = self.postfix_from(e, &mut links);
        self.unlink(links);
        r
    }

    fn postfix_chain(&mut self, links: &mut usize) -> PResult<Expr> {
        let e = self.primary()?;
        self.postfix_from(e, links)
    }

    fn postfix_from(&mut self, mut e: Expr, links: &mut usize) -> PResult<Expr> {
        loop {
            if matches!(
                self.peek().tok,
                Tok::Dot | Tok::LBracket | Tok::LParen | Tok::Caret
            ) {
                self.link(links)?;
            }
            match self.peek().tok {
                Tok::Dot => {
                    self.bump();
                    match self.peek().tok.clone() {
                        Tok::Int(n) => {
                            let t = self.bump();
                            let span = e.span.to(t.span);
                            e = Expr {
                                kind: ExprKind::Bit(Box::new(e), n.min(u32::MAX as u128) as u32),
                                span,
                            };
                        }
                        Tok::Direct(text) => {
                            // x.%X3, x.%B1, x.%W0, x.%D1: partial access.
                            let t = self.bump();
                            let mut chars = text.chars();
                            let size = match chars.next().map(|c| c.to_ascii_uppercase()) {
                                Some('X') => Some(1),
                                Some('B') => Some(8),
                                Some('W') => Some(16),
                                Some('D') => Some(32),
                                _ => None,
                            };
                            let index = chars.as_str().parse::<u32>().ok();
                            let (Some(size), Some(index)) = (size, index) else {
                                self.error_at(
                                    diag::UNSUPPORTED,
                                    t.span,
                                    "partial access after a variable is a bit (.%X3 or .3), a byte (.%B1), a word (.%W0) or a double word (.%D1)",
                                );
                                return Err(Reported);
                            };
                            let span = e.span.to(t.span);
                            let base = Box::new(e);
                            e = Expr {
                                kind: if size == 1 {
                                    ExprKind::Bit(base, index)
                                } else {
                                    ExprKind::Part(base, size, index)
                                },
                                span,
                            };
                        }
                        _ => {
                            let f = self.ident("a field name after `.`")?;
                            let span = e.span.to(f.span);
                            e = Expr {
                                kind: ExprKind::Field(Box::new(e), f),
                                span,
                            };
                        }
                    }
                }
                Tok::LBracket => {
                    self.bump();
                    let mut idx = Vec::new();
                    loop {
                        idx.push(self.expr()?);
                        if self.eat(&Tok::Comma).is_none() {
                            break;
                        }
                    }
                    let end = self.expect(&Tok::RBracket, "`]` after the index")?;
                    let span = e.span.to(end.span);
                    e = Expr {
                        kind: ExprKind::Index(Box::new(e), idx),
                        span,
                    };
                }
                Tok::LParen => {
                    if !matches!(
                        e.kind,
                        ExprKind::Name(_)
                            | ExprKind::Field(..)
                            | ExprKind::Index(..)
                            | ExprKind::Deref(_)
                    ) {
                        break;
                    }
                    let (args, end) = self.args()?;
                    let span = e.span.to(end);
                    e = Expr {
                        kind: ExprKind::Call(Call {
                            callee: Box::new(e),
                            args,
                            span,
                        }),
                        span,
                    };
                }
                Tok::Caret => {
                    let t = self.bump();
                    let span = e.span.to(t.span);
                    e = Expr {
                        kind: ExprKind::Deref(Box::new(e)),
                        span,
                    };
                }
                _ => break,
            }
        }
        Ok(e)
    }

    /// `( [arg {, arg}] )`; returns the closing parenthesis's span.
    pub(super) fn args(&mut self) -> PResult<(Vec<Arg>, Span)> {
        self.expect(&Tok::LParen, "`(`")?;
        let mut args = Vec::new();
        if !self.at(&Tok::RParen) {
            loop {
                args.push(self.arg()?);
                if self.eat(&Tok::Comma).is_none() {
                    break;
                }
                if self.at(&Tok::RParen) {
                    break;
                }
            }
        }
        let end = self.expect(&Tok::RParen, "`)` or `,` in the argument list")?;
        Ok((args, end.span))
    }

    fn arg(&mut self) -> PResult<Arg> {
        let start = self.peek().span;
        let negated = self.at_kw(Kw::Not)
            && Self::is_name(&self.peek_at(1).tok)
            && self.peek_at(2).tok == Tok::Arrow;
        if negated {
            self.bump();
        }
        if self.at_name() && matches!(self.peek_at(1).tok, Tok::Assign | Tok::Arrow) {
            let name = self.ident("a parameter name")?;
            let output = self.bump().tok == Tok::Arrow;
            let value = if output && matches!(self.peek().tok, Tok::Comma | Tok::RParen) {
                None
            } else if output {
                Some(self.postfix()?)
            } else {
                Some(self.expr()?)
            };
            return Ok(Arg {
                name: Some(name),
                output,
                negated,
                value,
                span: start.to(self.prev_span()),
            });
        }
        // TwinCAT's `__NEW(POINTER TO T, n)` (an array of n pointers): read as a call of
        // `POINTER TO` (a name no identifier can spell) on the type, which __NEW takes apart.
        if (self.at_word("POINTER") || self.at_word("REFERENCE"))
            && self.peek_at(1).tok == Tok::Kw(Kw::To)
        {
            let word = self.peek().span;
            let text = format!("{} TO", self.text_of(word).to_ascii_uppercase());
            self.bump();
            self.bump();
            let v = self.postfix()?;
            let span = start.to(v.span);
            let callee = Expr {
                kind: ExprKind::Name(Ident {
                    name: text,
                    span: word,
                }),
                span: word,
            };
            return Ok(Arg {
                name: None,
                output: false,
                negated: false,
                span,
                value: Some(Expr {
                    kind: ExprKind::Call(Call {
                        callee: Box::new(callee),
                        args: vec![Arg {
                            name: None,
                            output: false,
                            negated: false,
                            span: v.span,
                            value: Some(v),
                        }],
                        span,
                    }),
                    span,
                }),
            });
        }
        let v = self.expr()?;
        Ok(Arg {
            name: None,
            output: false,
            negated: false,
            span: v.span,
            value: Some(v),
        })
    }

    pub(super) fn primary(&mut self) -> PResult<Expr> {
        let t = self.peek().clone();
        let lit = |kind| Ok(Expr { kind, span: t.span });
        match t.tok {
            Tok::Int(v) => {
                self.bump();
                lit(ExprKind::Literal(Literal::Int {
                    value: v as i128,
                    ty: None,
                }))
            }
            Tok::Real(v) => {
                self.bump();
                lit(ExprKind::Literal(Literal::Real { value: v, ty: None }))
            }
            Tok::Kw(Kw::True) | Tok::Kw(Kw::False) => {
                self.bump();
                lit(ExprKind::Literal(Literal::Bool {
                    value: t.tok == Tok::Kw(Kw::True),
                    ty: None,
                }))
            }
            Tok::Str { bytes, wide } => {
                self.bump();
                lit(ExprKind::Literal(Literal::String {
                    bytes,
                    wide,
                    ty: None,
                }))
            }
            Tok::Time { kind, nanos } => {
                self.bump();
                lit(ExprKind::Literal(Literal::Time { kind, nanos }))
            }
            Tok::Direct(text) => {
                self.bump();
                lit(ExprKind::Direct(text))
            }
            Tok::TypedPrefix => self.typed_literal(),
            // The standard functions AND, OR, XOR and MOD called by name (`AND(a, b, c)`):
            // where an operand starts, these keywords cannot be operators (NOT comes here
            // only from `unary`, with a named parameter).
            Tok::Kw(k @ (Kw::And | Kw::Or | Kw::Xor | Kw::Mod | Kw::Not))
                if self.peek_at(1).tok == Tok::LParen =>
            {
                self.bump();
                Ok(Expr {
                    span: t.span,
                    kind: ExprKind::Name(Ident::new(k.text(), t.span)),
                })
            }
            _ if self.at_name() => {
                let id = self.ident("a name")?;
                Ok(Expr {
                    span: id.span,
                    kind: ExprKind::Name(id),
                })
            }
            Tok::LParen => {
                self.bump();
                let e = self.expr()?;
                let end = self.expect(&Tok::RParen, "`)`")?;
                Ok(Expr {
                    kind: ExprKind::Paren(Box::new(e)),
                    span: t.span.to(end.span),
                })
            }
            Tok::Error => {
                self.bump();
                Err(Reported)
            }
            _ => Err(self.expected("an expression")),
        }
    }

    /// `INT#5`, `INT#-5`, `REAL#1.5`, `BOOL#TRUE`, `WORD#16#FF`, `Color#Red`.
    fn typed_literal(&mut self) -> PResult<Expr> {
        let p = self.bump();
        let name_span = Span::new(self.file, p.span.start as usize, p.span.end as usize - 1);
        let ty = Ident::new(self.text_of(name_span), name_span);
        let neg = match self.peek().tok {
            Tok::Minus => {
                self.bump();
                true
            }
            Tok::Plus => {
                self.bump();
                false
            }
            _ => false,
        };
        let t = self.peek().clone();
        let kind = match t.tok {
            Tok::Int(v) => Literal::Int {
                value: if neg { -(v as i128) } else { v as i128 },
                ty: Some(ty),
            },
            Tok::Real(v) => Literal::Real {
                value: if neg { -v } else { v },
                ty: Some(ty),
            },
            Tok::Kw(Kw::True | Kw::False) if !neg => Literal::Bool {
                value: t.tok == Tok::Kw(Kw::True),
                ty: Some(ty),
            },
            Tok::Ident if !neg => Literal::Enum {
                ty,
                value: Ident::new(self.text_of(t.span), t.span),
            },
            Tok::Str { bytes, wide } if !neg => {
                // STRING#'abc', WSTRING#"abc"
                self.bump();
                return Ok(Expr {
                    kind: ExprKind::Literal(Literal::String {
                        bytes,
                        wide,
                        ty: Some(ty),
                    }),
                    span: p.span.to(t.span),
                });
            }
            _ => {
                return Err(self.expected(&format!(
                    "a value after `{}#` (e.g. {}#5)",
                    ty.name, ty.name
                )))
            }
        };
        self.bump();
        Ok(Expr {
            kind: ExprKind::Literal(kind),
            span: p.span.to(t.span),
        })
    }
}
