//! Statements: assignments, IF, CASE, loops, labels and jumps.

use petriplc_iec_sema::ir::{self, Expr, ExprKind, Place, Stmt, StmtKind, UnaryOp};
use petriplc_iec_sema::types::{Elem, TypeId};
use petriplc_iec_syntax::source::Span;

use crate::ext::ExtOp;
use crate::op::{int_class, Cmp, IntClass, Op};

use super::{
    elem_of, elem_or_dint, raw_const, scalar, CompileError, Fx, Loc, LoopCx, R, TAG, TEMP,
};

impl<'c, 'p> Fx<'c, 'p> {
    pub(super) fn stmts(&mut self, stmts: &[Stmt]) -> R<()> {
        let mut i = 0;
        while i < stmts.len() {
            let mark = self.temp_top;
            let used = self.fused(&stmts[i..])?;
            if used == 0 {
                self.stmt(&stmts[i])?;
                i += 1;
            } else {
                i += used;
            }
            self.temp_top = mark;
        }
        Ok(())
    }

    fn stmt(&mut self, s: &Stmt) -> R<()> {
        let span = s.span;
        match &s.kind {
            StmtKind::Assign { target, value } => {
                if let Some(view) = self.view_of(target)? {
                    let v = self.expr(value, None)?;
                    self.view_store(view, v, span);
                    return Ok(());
                }
                let dst = self.place_loc(target)?;
                self.store_expr(&dst, target.ty, value)?;
            }
            StmtKind::CallFb(call) => self.call_fb(call, span)?,
            StmtKind::Eval(e) => {
                self.expr(e, None)?;
            }
            StmtKind::If {
                branches,
                else_body,
            } => self.if_stmt(branches, else_body, span)?,
            StmtKind::Case {
                selector,
                arms,
                else_body,
            } => self.case(selector, arms, else_body, span)?,
            StmtKind::For(f) => self.for_loop(&f.var, &f.from, &f.to, &f.by, &f.body, span)?,
            StmtKind::While { cond, body } => {
                let top = self.pc();
                let c = self.expr(cond, None)?;
                let exit = self.emit(Op::JmpF { c, t: 0 }, span);
                self.loops.push(LoopCx {
                    exits: vec![exit],
                    continues: Vec::new(),
                });
                self.stmts(body)?;
                self.emit(Op::Loop { t: top }, span);
                let l = self.loops.pop().unwrap_or(LoopCx {
                    exits: vec![],
                    continues: vec![],
                });
                let end = self.pc();
                for e in l.exits {
                    self.patch(e, end);
                }
                for c in l.continues {
                    self.patch(c, top);
                }
            }
            StmtKind::Repeat { body, until } => {
                let top = self.pc();
                self.loops.push(LoopCx {
                    exits: Vec::new(),
                    continues: Vec::new(),
                });
                self.stmts(body)?;
                let cond_pc = self.pc();
                let c = self.expr(until, None)?;
                let done = self.emit(Op::JmpT { c, t: 0 }, span);
                self.emit(Op::Loop { t: top }, span);
                let l = self.loops.pop().unwrap_or(LoopCx {
                    exits: vec![],
                    continues: vec![],
                });
                let end = self.pc();
                self.patch(done, end);
                for e in l.exits {
                    self.patch(e, end);
                }
                for c in l.continues {
                    self.patch(c, cond_pc);
                }
            }
            StmtKind::Exit => {
                let at = self.emit(Op::Jmp { t: 0 }, span);
                if let Some(l) = self.loops.last_mut() {
                    l.exits.push(at);
                }
            }
            StmtKind::Continue => {
                let at = self.emit(Op::Jmp { t: 0 }, span);
                if let Some(l) = self.loops.last_mut() {
                    l.continues.push(at);
                }
            }
            StmtKind::Return => self.ret(span),
            StmtKind::Label(l) => {
                let here = self.pc();
                self.labels.insert(*l, here);
            }
            StmtKind::Goto { label, cond } => self.goto(*label, cond.as_ref(), span)?,
        }
        Ok(())
    }

    fn if_stmt(&mut self, branches: &[(Expr, Vec<Stmt>)], else_body: &[Stmt], span: Span) -> R<()> {
        // IF c THEN x := constant; END_IF → one instruction.
        if branches.len() == 1 && else_body.is_empty() && branches[0].1.len() == 1 {
            if let StmtKind::Assign { target, value } = &branches[0].1[0].kind {
                let deref = target.path.iter().any(|s| {
                    matches!(
                        s,
                        petriplc_iec_sema::ir::Step::Deref
                            | petriplc_iec_sema::ir::Step::Overlay { .. }
                    )
                });
                if let (ExprKind::Const(v), true, false) =
                    (&value.kind, scalar(self.p(), target.ty), deref)
                {
                    let dst = self.place_loc(target)?;
                    if let (Loc::Slot(d), None) = (dst.loc, dst.bit) {
                        let k = raw_const(self.p(), v, target.ty);
                        let k = self.store_raw_for(target.ty, k);
                        let (c, negated) = self.cond_operand(&branches[0].0)?;
                        let op = if negated {
                            Op::CondNotMovK { c, d, k }
                        } else {
                            Op::CondMovK { c, d, k }
                        };
                        self.emit(op, branches[0].1[0].span);
                        return Ok(());
                    }
                }
            }
        }
        let mut ends = Vec::new();
        for (i, (cond, body)) in branches.iter().enumerate() {
            let mark = self.temp_top;
            let (c, negated) = self.cond_operand(cond)?;
            self.temp_top = mark;
            let skip = if negated {
                self.emit(Op::JmpT { c, t: 0 }, cond.span)
            } else {
                self.emit(Op::JmpF { c, t: 0 }, cond.span)
            };
            self.stmts(body)?;
            let last = i + 1 == branches.len() && else_body.is_empty();
            if !last {
                ends.push(self.emit(Op::Jmp { t: 0 }, span));
            }
            let here = self.pc();
            self.patch(skip, here);
        }
        self.stmts(else_body)?;
        let end = self.pc();
        for e in ends {
            self.patch(e, end);
        }
        Ok(())
    }

    /// A jump to a label. A jump back (a loop) spends the scan's iteration budget, so a body
    /// that jumps back for ever faults like an endless WHILE.
    fn goto(&mut self, label: u32, cond: Option<&(Expr, bool)>, span: Span) -> R<()> {
        let back = self.labels.get(&label).copied();
        let mark = self.temp_top;
        let test = match cond {
            Some((c, flag)) => {
                let (slot, negated) = self.cond_operand(c)?;
                Some((slot, *flag != negated))
            }
            None => None,
        };
        self.temp_top = mark;
        match (back, test) {
            (Some(t), None) => {
                self.emit(Op::Loop { t }, span);
            }
            (Some(t), Some((c, when))) => {
                let skip = if when {
                    self.emit(Op::JmpF { c, t: 0 }, span)
                } else {
                    self.emit(Op::JmpT { c, t: 0 }, span)
                };
                self.emit(Op::Loop { t }, span);
                let here = self.pc();
                self.patch(skip, here);
            }
            (None, None) => {
                let at = self.emit(Op::Jmp { t: 0 }, span);
                self.gotos.push((at, label));
            }
            (None, Some((c, when))) => {
                let at = if when {
                    self.emit(Op::JmpT { c, t: 0 }, span)
                } else {
                    self.emit(Op::JmpF { c, t: 0 }, span)
                };
                self.gotos.push((at, label));
            }
        }
        Ok(())
    }

    /// A condition's slot, and whether it is negated (`NOT x` tests x).
    fn cond_operand(&mut self, cond: &Expr) -> R<(u32, bool)> {
        if let ExprKind::Unary(UnaryOp::Not, inner) = &cond.kind {
            if inner.ty == petriplc_iec_sema::types::ids::BOOL {
                return Ok((self.expr(inner, None)?, true));
            }
        }
        Ok((self.expr(cond, None)?, false))
    }

    /// The raw slot stored for a constant of `ty` (REAL constants already rounded).
    fn store_raw_for(&self, _ty: TypeId, raw: u64) -> u64 {
        raw
    }

    fn case(
        &mut self,
        selector: &Expr,
        arms: &[ir::CaseArm],
        else_body: &[Stmt],
        span: Span,
    ) -> R<()> {
        let sel = self.expr(selector, None)?;
        let sel = if matches!(self.temp_tag(sel), Some(TEMP)) {
            sel
        } else {
            // Keep the selector's value even if a branch changes it.
            let t = self.temp(1);
            self.emit(Op::Mov { d: t, s: sel }, span);
            t
        };
        let unsigned = matches!(
            elem_of(self.p(), selector.ty),
            Some(Elem::Ulint | Elem::Lword)
        );
        let cmp = |op: Cmp, d: u32, a: u32, b: u32| {
            if unsigned {
                Op::CmpU { op, d, a, b }
            } else {
                Op::CmpI { op, d, a, b }
            }
        };
        let t = self.temp(1);
        let t2 = self.temp(1);
        let mut arm_jumps: Vec<Vec<usize>> = Vec::new();
        for arm in arms {
            let mut jumps = Vec::new();
            for (lo, hi) in &arm.ranges {
                let klo = self.konst(*lo as i64 as u64);
                if lo == hi {
                    self.emit(cmp(Cmp::Eq, t, sel, klo), span);
                } else {
                    let khi = self.konst(*hi as i64 as u64);
                    self.emit(cmp(Cmp::Ge, t, sel, klo), span);
                    self.emit(cmp(Cmp::Le, t2, sel, khi), span);
                    self.emit(Op::And { d: t, a: t, b: t2 }, span);
                }
                jumps.push(self.emit(Op::JmpT { c: t, t: 0 }, span));
            }
            arm_jumps.push(jumps);
        }
        let mut ends = Vec::new();
        self.stmts(else_body)?;
        ends.push(self.emit(Op::Jmp { t: 0 }, span));
        for (arm, jumps) in arms.iter().zip(arm_jumps) {
            let here = self.pc();
            for j in jumps {
                self.patch(j, here);
            }
            self.stmts(&arm.body)?;
            ends.push(self.emit(Op::Jmp { t: 0 }, span));
        }
        let end = self.pc();
        for e in ends {
            self.patch(e, end);
        }
        Ok(())
    }

    fn temp_tag(&self, x: u32) -> Option<u32> {
        Some(x & TAG)
    }

    fn for_loop(
        &mut self,
        var: &Place,
        from: &Expr,
        to: &Expr,
        by: &Expr,
        body: &[Stmt],
        span: Span,
    ) -> R<()> {
        let v = self.place_loc(var)?;
        let Loc::Slot(vs) = v.loc else {
            return Err(CompileError::Unsupported(
                "a FOR control variable must be a variable of the POU itself".into(),
            ));
        };
        let e = elem_or_dint(self.p(), var.ty);
        // Bounds and step are evaluated once, before the first iteration.
        let x = self.expr(from, None)?;
        let t_from = self.temp(1);
        self.emit(Op::Mov { d: t_from, s: x }, span);
        let t_to = self.temp(1);
        let x = self.expr(to, Some(t_to))?;
        if x != t_to {
            self.emit(Op::Mov { d: t_to, s: x }, span);
        }
        let t_by = self.temp(1);
        let x = self.expr(by, Some(t_by))?;
        if x != t_by {
            self.emit(Op::Mov { d: t_by, s: x }, span);
        }
        self.emit(Op::Mov { d: vs, s: t_from }, span);
        if by.const_int().is_none() {
            self.ext(ExtOp::NonZeroStep { s: t_by }, by.span);
        }
        let (r, u) = match int_class(e) {
            IntClass::Narrow(r) => (r, false),
            IntClass::Long => (7, false),
            IntClass::ULong => (8, true),
        };
        // Entry test: by > 0 ? v <= to : v >= to.
        let cmp = |op: Cmp, d: u32, a: u32, b: u32| {
            if u {
                Op::CmpU { op, d, a, b }
            } else {
                Op::CmpI { op, d, a, b }
            }
        };
        let t_c = self.temp(1);
        let negative = by.const_int().map(|k| k < 0);
        match negative {
            Some(false) => {
                self.emit(cmp(Cmp::Le, t_c, vs, t_to), span);
            }
            Some(true) => {
                self.emit(cmp(Cmp::Ge, t_c, vs, t_to), span);
            }
            None => {
                let zero = self.konst(0);
                let t_pos = self.temp(1);
                let t_a = self.temp(1);
                self.emit(
                    Op::CmpI {
                        op: Cmp::Gt,
                        d: t_pos,
                        a: t_by,
                        b: zero,
                    },
                    span,
                );
                self.emit(cmp(Cmp::Le, t_a, vs, t_to), span);
                self.emit(
                    Op::And {
                        d: t_a,
                        a: t_a,
                        b: t_pos,
                    },
                    span,
                );
                self.emit(cmp(Cmp::Ge, t_c, vs, t_to), span);
                self.emit(
                    Op::AndN {
                        d: t_c,
                        a: t_c,
                        b: t_pos,
                    },
                    span,
                );
                self.emit(
                    Op::Or {
                        d: t_c,
                        a: t_c,
                        b: t_a,
                    },
                    span,
                );
            }
        }
        let exit = self.emit(Op::JmpF { c: t_c, t: 0 }, span);
        let body_start = self.pc();
        self.loops.push(LoopCx {
            exits: vec![exit],
            continues: Vec::new(),
        });
        self.stmts(body)?;
        let cont = self.pc();
        self.emit(
            Op::ForNext {
                v: vs,
                to: t_to,
                by: t_by,
                t: body_start,
                r,
                u,
            },
            span,
        );
        let l = self.loops.pop().unwrap_or(LoopCx {
            exits: vec![],
            continues: vec![],
        });
        let end = self.pc();
        for x in l.exits {
            self.patch(x, end);
        }
        for c in l.continues {
            self.patch(c, cont);
        }
        Ok(())
    }
}
