//! One instruction at a time: loads, stores, S/R, jumps, labels, calls and the operators folded
//! into the current result.

use petriplc_iec_syntax::ast::{self, IlInstr, IlKind, IlOp};
use petriplc_iec_syntax::depth::MAX_NESTING;
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::Checker;
use crate::expr::err;
use crate::ir::{Expr, ExprKind, Stmt, StmtKind};
use crate::types::{ids, Type};
use crate::value::Value;

use super::{cond_name, is_literal, load, reads, var_place, Cr, Il, Open};

impl Checker<'_> {
    pub(super) fn il_instr(&mut self, ins: &IlInstr, il: &mut Il<'_>, seen: &mut Vec<String>) {
        let span = ins.span;
        match &ins.kind {
            IlKind::Label(id) => {
                let key = id.key();
                if seen.contains(&key) {
                    return;
                }
                seen.push(key.clone());
                if !il.open.is_empty() {
                    self.error(
                        diag::IL_NESTING,
                        span,
                        "a label inside a parenthesised operation; close it with `)` first",
                    );
                    return;
                }
                let (lid, needs) = match il.labels.get(&key) {
                    Some(l) => (l.id, l.needs),
                    None => return,
                };
                if needs && !il.dead {
                    match il.cr.clone() {
                        Cr::Value(cr) => self.il_join(il, &key, cr, span),
                        Cr::Pending(e) => {
                            let cr = self.expr(&e, il.cx, None);
                            self.il_join(il, &key, cr, span)
                        }
                        Cr::None(why) => self.error(
                            diag::IL_NO_RESULT,
                            span,
                            format!("the code after label `{}` uses the current result, but there is none when it is reached from above ({why}); load one with LD", id.name),
                        ),
                    }
                }
                il.out.push(Stmt {
                    kind: StmtKind::Label(lid),
                    span,
                });
                il.cr = match il.labels[&key].var {
                    _ if needs && il.labels[&key].poisoned => Cr::Value(err(span)),
                    Some(v) if needs => {
                        let ty = il.cx.vars[v as usize].ty;
                        Cr::Value(load(var_place(v, ty, span)))
                    }
                    _ if needs => Cr::None("at a label reached only by a jump written after it"),
                    _ => Cr::None("after a label"),
                };
                il.dead = false;
            }
            IlKind::Op {
                op,
                negated,
                deferred,
                operand,
            } => self.il_op(il, *op, *negated, *deferred, operand.as_ref(), span),
            IlKind::Close => {
                if il.refused_open > 0 {
                    il.refused_open -= 1;
                    il.cr = Cr::Value(err(span));
                    return;
                }
                let Some(o) = il.open.pop() else {
                    self.error(
                        diag::IL_PARENS,
                        span,
                        "`)` without an open operation (AND(, ADD(, …) before it",
                    );
                    return;
                };
                let saved = match o.saved {
                    Cr::Value(x) => Some(x),
                    Cr::Pending(e) => Some(self.expr(&e, il.cx, None)),
                    Cr::None(why) => {
                        self.error(
                            diag::IL_NO_RESULT,
                            o.span,
                            format!(
                                "{}( needs the current result, but there is none here ({why}); load one with LD first",
                                o.op.name()
                            ),
                        );
                        None
                    }
                };
                let hint = saved
                    .as_ref()
                    .map(|x| x.ty)
                    .filter(|t| *t != ids::INT_LIT && *t != ids::REAL_LIT);
                let inner = self.il_take_as(il, ")", span, hint);
                let (Some(saved), Some(inner)) = (saved, inner) else {
                    il.cr = Cr::Value(err(span));
                    return;
                };
                let inner = if o.negated {
                    self.il_not(inner, o.span)
                } else {
                    inner
                };
                let bin = o.op.binary().expect("a deferred operator is binary");
                let x = self.binary_checked(bin, saved, inner, o.span.to(span));
                il.cr = Cr::Value(self.il_bounded(il, x, span));
            }
            IlKind::Jump { cond, label } => {
                if !il.open.is_empty() {
                    self.error(
                        diag::IL_NESTING,
                        span,
                        "a jump inside a parenthesised operation; close it with `)` first",
                    );
                    return;
                }
                let key = label.key();
                let Some(l) = il.labels.get(&key) else {
                    self.error(
                        diag::IL_LABEL,
                        label.span,
                        format!(
                            "no label `{}` in this body; write `{}:` before the instruction to jump to",
                            label.name, label.name
                        ),
                    );
                    return;
                };
                let (lid, needs) = (l.id, l.needs);
                let name = cond_name("JMP", *cond);
                let c = match cond {
                    Some(flag) => self.il_bool(il, &name, span).map(|c| Some((c, *flag))),
                    None => Some(None),
                };
                if needs {
                    match il.cr.clone() {
                        Cr::Value(cr) => self.il_join(il, &key, cr, span),
                        Cr::Pending(e) => {
                            let cr = self.expr(&e, il.cx, None);
                            self.il_join(il, &key, cr, span)
                        }
                        Cr::None(why) => {
                            self.error(
                                diag::IL_NO_RESULT,
                                span,
                                format!("the code after label `{}` uses the current result, but there is none at this jump ({why}); load one with LD", label.name),
                            );
                            if let Some(l) = il.labels.get_mut(&key) {
                                l.poisoned = true;
                            }
                        }
                    }
                }
                if let Some(cond) = c {
                    il.out.push(Stmt {
                        kind: StmtKind::Goto { label: lid, cond },
                        span,
                    });
                }
                if cond.is_none() {
                    il.dead = true;
                    il.cr = Cr::None("after JMP");
                }
            }
            IlKind::Call {
                cond,
                instance,
                args,
            } => {
                let call = ast::Call {
                    callee: Box::new(instance.clone()),
                    args: args.clone(),
                    span,
                };
                self.il_protect(il, None, span);
                self.il_conditional(il, *cond, "CAL", span, |ck, il| {
                    ck.call_stmt(&call, il.cx).into_iter().collect()
                });
                il.cr = Cr::None("after CAL");
            }
            IlKind::FbInput { input, instance } => self.il_fb_input(il, input, instance, span),
            IlKind::Return { cond } => {
                if !il.open.is_empty() {
                    self.error(
                        diag::IL_NESTING,
                        span,
                        "a return inside a parenthesised operation; close it with `)` first",
                    );
                    return;
                }
                self.il_conditional(il, *cond, "RET", span, |_, _| {
                    vec![Stmt {
                        kind: StmtKind::Return,
                        span,
                    }]
                });
                if cond.is_none() {
                    il.dead = true;
                    il.cr = Cr::None("after RET");
                }
            }
            IlKind::Function { name, args, formal } => {
                let mut args = args.clone();
                if !formal {
                    let first = match il.cr.clone() {
                        Cr::Pending(e) => e,
                        _ => {
                            let Some(first) = self.il_take(il, &name.name, span) else {
                                il.cr = Cr::Value(err(span));
                                return;
                            };
                            self.il_as_ast(il, first, span)
                        }
                    };
                    args.insert(
                        0,
                        ast::Arg {
                            name: None,
                            output: false,
                            negated: false,
                            span: first.span,
                            value: Some(first),
                        },
                    );
                }
                let call = ast::Expr {
                    kind: ast::ExprKind::Call(ast::Call {
                        callee: Box::new(ast::Expr {
                            kind: ast::ExprKind::Name(name.clone()),
                            span: name.span,
                        }),
                        args,
                        span,
                    }),
                    span,
                };
                if is_literal(&call) {
                    il.cr = Cr::Pending(call);
                    return;
                }
                let x = self.expr(&call, il.cx, None);
                if matches!(self.types.get(x.ty), Type::Void) {
                    self.error(
                        diag::TYPE_MISMATCH,
                        span,
                        format!("{} gives no value to become the current result; call it with CAL or from ST", name.name),
                    );
                    il.cr = Cr::Value(err(span));
                    return;
                }
                let mut r = Vec::new();
                let x = if reads(&x, &mut r) {
                    x
                } else {
                    self.il_protect(il, None, span);
                    self.il_materialise(il, x, span)
                };
                il.cr = Cr::Value(x);
            }
        }
    }

    fn il_op(
        &mut self,
        il: &mut Il<'_>,
        op: IlOp,
        negated: bool,
        deferred: bool,
        operand: Option<&ast::Expr>,
        span: Span,
    ) {
        let name = if negated {
            format!("{}N", op.name())
        } else {
            op.name().to_string()
        };
        if deferred {
            if il.open.len() >= MAX_NESTING || il.refused_open > 0 {
                if !il.too_deep {
                    il.too_deep = true;
                    self.error(
                        diag::TOO_DEEP,
                        span,
                        format!("parenthesised operations nested more than {MAX_NESTING} deep; store intermediate results with ST"),
                    );
                }
                il.refused_open += 1;
                il.cr = Cr::Value(err(span));
                return;
            }
            let saved = std::mem::replace(&mut il.cr, Cr::None("after `(`"));
            il.open.push(Open {
                op,
                negated,
                saved,
                span,
            });
            if let Some(x) = operand {
                let x = self.expr(x, il.cx, None);
                il.cr = Cr::Value(x);
            }
            return;
        }
        match op {
            IlOp::Ld => {
                let Some(x) = operand else { return };
                let x = self.expr(x, il.cx, None);
                let x = if negated { self.il_not(x, span) } else { x };
                il.cr = Cr::Value(x);
            }
            IlOp::St => {
                let Some(target) = operand else { return };
                let Some(p) = self.place(target, il.cx, true) else {
                    let _ = self.il_take(il, &name, span);
                    return;
                };
                let Some(cr) = self.il_take_as(il, &name, span, Some(p.ty)) else {
                    return;
                };
                if let Cr::Pending(_) = il.cr {
                    // Typed now: the stored value is the current result from here on.
                    il.cr = Cr::Value(cr.clone());
                }
                if !self.writable(&p, il.cx, target.span) || p.ty == ids::ERROR {
                    return;
                }
                if cr.ty == ids::ERROR {
                    return;
                }
                self.il_protect(il, Some(p.root), span);
                let value = if negated {
                    let x = if cr.ty == ids::INT_LIT {
                        self.coerce(cr.clone(), p.ty, "the operand of STN")
                    } else {
                        cr.clone()
                    };
                    self.il_not(x, span)
                } else {
                    cr.clone()
                };
                // The stored value stays the current result: read back from the target when
                // it is exactly the current result, else kept (stored first if the store
                // would change what it reads).
                let same = !negated && cr.ty == p.ty && !matches!(cr.kind, ExprKind::Const(_));
                let mut r = Vec::new();
                let pure = reads(&cr, &mut r);
                let value = if !same
                    && !matches!(cr.kind, ExprKind::Const(_))
                    && (!pure || r.contains(&p.root))
                {
                    let held = self.il_materialise(il, cr, span);
                    il.cr = Cr::Value(held.clone());
                    if negated {
                        self.il_not(held, span)
                    } else {
                        held
                    }
                } else {
                    value
                };
                let value = self.assign_value(value, p.ty, &p, target);
                if value.ty == ids::ERROR {
                    return;
                }
                il.out.push(Stmt {
                    kind: StmtKind::Assign {
                        target: p.clone(),
                        value,
                    },
                    span,
                });
                if same {
                    il.cr = Cr::Value(load(p));
                }
            }
            IlOp::S | IlOp::R => {
                let Some(target) = operand else { return };
                // `S rs` / `R sr`: the input operators of the bistables.
                let mut quiet = std::mem::take(&mut self.diags);
                let read = self.place(target, il.cx, false);
                std::mem::swap(&mut quiet, &mut self.diags);
                if read.is_some_and(|p| matches!(self.types.get(p.ty), Type::Fb(_))) {
                    let input = ast::Ident::new(op.name(), span);
                    self.il_fb_input(il, &input, target, span);
                    return;
                }
                let Some(c) = self.il_bool(il, &name, span) else {
                    return;
                };
                let Some(p) = self.place(target, il.cx, true) else {
                    return;
                };
                if !self.writable(&p, il.cx, target.span) || p.ty == ids::ERROR {
                    return;
                }
                if p.ty != ids::BOOL {
                    let t = self.types.name(p.ty);
                    self.error(
                        diag::TYPE_MISMATCH,
                        target.span,
                        format!(
                            "{name} sets or resets a BOOL, not {t}; use LD and ST for other types"
                        ),
                    );
                    return;
                }
                self.il_protect(il, Some(p.root), span);
                let mut r = Vec::new();
                let c = if !reads(&c, &mut r) || r.contains(&p.root) {
                    let held = self.il_materialise(il, c, span);
                    il.cr = Cr::Value(held.clone());
                    held
                } else {
                    c
                };
                let assign = Stmt {
                    kind: StmtKind::Assign {
                        target: p,
                        value: Expr {
                            kind: ExprKind::Const(Value::Int((op == IlOp::S) as i128)),
                            ty: ids::BOOL,
                            span,
                        },
                    },
                    span,
                };
                il.out.push(Stmt {
                    kind: StmtKind::If {
                        branches: vec![(c, vec![assign])],
                        else_body: Vec::new(),
                    },
                    span,
                });
            }
            IlOp::Not => {
                let Some(cr) = self.il_take(il, "NOT", span) else {
                    return;
                };
                let x = self.il_not(cr, span);
                il.cr = Cr::Value(self.il_bounded(il, x, span));
            }
            _ => {
                let Some(x) = operand else { return };
                let Some(cr) = self.il_take(il, &name, span) else {
                    il.cr = Cr::Value(err(span));
                    return;
                };
                let hint = Some(cr.ty).filter(|t| *t != ids::INT_LIT && *t != ids::REAL_LIT);
                let y = self.expr(x, il.cx, hint);
                let y = if negated {
                    let y = match hint {
                        Some(h) if y.ty == ids::INT_LIT => {
                            self.coerce(y, h, &format!("the operand of {name}"))
                        }
                        _ => y,
                    };
                    self.il_not(y, x.span)
                } else {
                    y
                };
                let bin = op.binary().expect("an operator with an operand");
                let r = self.binary_checked(bin, cr, y, span);
                il.cr = Cr::Value(self.il_bounded(il, r, span));
            }
        }
    }

    /// `PT timer`: the instance's input set to the current result, and the instance called.
    fn il_fb_input(
        &mut self,
        il: &mut Il<'_>,
        input: &ast::Ident,
        instance: &ast::Expr,
        span: Span,
    ) {
        let member = ast::Expr {
            kind: ast::ExprKind::Field(Box::new(instance.clone()), input.clone()),
            span: instance.span,
        };
        let place = self.place(&member, il.cx, true);
        self.il_protect(il, None, span);
        let hint = place.as_ref().map(|p| p.ty);
        if let Some(cr) = self.il_take_as(il, &input.name, span, hint) {
            if let Some(p) = place {
                if self.writable(&p, il.cx, span) && cr.ty != ids::ERROR {
                    let value = self.assign_value(cr, p.ty, &p, &member);
                    if value.ty != ids::ERROR {
                        il.out.push(Stmt {
                            kind: StmtKind::Assign { target: p, value },
                            span,
                        });
                    }
                }
            }
            let call = ast::Call {
                callee: Box::new(instance.clone()),
                args: Vec::new(),
                span,
            };
            il.out.extend(self.call_stmt(&call, il.cx));
        }
        il.cr = Cr::None("after a function block's input operator (it calls the block)");
    }
}
