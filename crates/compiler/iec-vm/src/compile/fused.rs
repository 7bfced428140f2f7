//! Superinstructions: runs of BOOL statements compiled to one fused instruction.

use petriplc_iec_sema::ir::{Expr, ExprKind, Place, Step, Stmt, StmtKind, UnaryOp};
use petriplc_iec_sema::types::Type;

use crate::op::Op;

use super::{raw_const, scalar, Fx, Loc, FRAME, R, TAG};

/// A condition literal (slot, negated) and the constant stores it guards.
type CondStores = ((u32, bool), Vec<(u32, u64)>);

impl<'c, 'p> Fx<'c, 'p> {
    /// A BOOL variable held in a slot of this unit, possibly negated: `x` or `NOT x`.
    pub(super) fn bool_literal(&mut self, e: &Expr) -> R<Option<(u32, bool)>> {
        let (inner, neg) = match &e.kind {
            ExprKind::Unary(UnaryOp::Not, x) => (&**x, true),
            _ => (e, false),
        };
        if inner.ty != petriplc_iec_sema::types::ids::BOOL {
            return Ok(None);
        }
        if let ExprKind::Load(p) = &inner.kind {
            if p.path
                .iter()
                .all(|s| matches!(s, Step::Field(_) | Step::Member(_)))
            {
                let pl = self.place_loc(p)?;
                if let (Loc::Slot(x), None) = (pl.loc, pl.bit) {
                    return Ok(Some((x, neg)));
                }
            }
        }
        Ok(None)
    }

    /// Compiles a run of statements that fuse into one instruction; returns how many it
    /// took (0: none fuse).
    pub(super) fn fused(&mut self, stmts: &[Stmt]) -> R<usize> {
        // IF c THEN x := k; … END_IF, repeated with the same c: one CondStore.
        let cond_stores = |me: &mut Self, s: &Stmt| -> R<Option<CondStores>> {
            let StmtKind::If {
                branches,
                else_body,
            } = &s.kind
            else {
                return Ok(None);
            };
            if branches.len() != 1 || !else_body.is_empty() || branches[0].1.is_empty() {
                return Ok(None);
            }
            let Some(lit) = me.bool_literal(&branches[0].0)? else {
                return Ok(None);
            };
            let mut stores = Vec::new();
            for b in &branches[0].1 {
                let StmtKind::Assign { target, value } = &b.kind else {
                    return Ok(None);
                };
                let ExprKind::Const(v) = &value.kind else {
                    return Ok(None);
                };
                if !scalar(me.p(), target.ty)
                    || target.path.iter().any(|s| {
                        matches!(
                            s,
                            Step::Index(_)
                                | Step::Bit(_)
                                | Step::Bits(..)
                                | Step::Deref
                                | Step::Overlay { .. }
                        )
                    })
                {
                    return Ok(None);
                }
                let pl = me.place_loc(target)?;
                let Loc::Slot(d) = pl.loc else {
                    return Ok(None);
                };
                if pl.bit.is_some() {
                    return Ok(None);
                }
                stores.push((d, raw_const(me.p(), v, target.ty)));
            }
            Ok(Some((lit, stores)))
        };
        if let Some((lit, mut stores)) = cond_stores(self, &stmts[0])? {
            let mut used = 1;
            // A store to the condition ends the group (later IFs must see it).
            if !stores.iter().any(|(d, _)| *d == lit.0) {
                while used < stmts.len() {
                    match cond_stores(self, &stmts[used])? {
                        Some((l2, more)) if l2 == lit => {
                            let stop = more.iter().any(|(d, _)| *d == lit.0);
                            stores.extend(more);
                            used += 1;
                            if stop {
                                break;
                            }
                        }
                        _ => break,
                    }
                }
            }
            let span = stmts[0].span;
            if stores.len() == 1 {
                let (d, k) = stores[0];
                let op = if lit.1 {
                    Op::CondNotMovK { c: lit.0, d, k }
                } else {
                    Op::CondMovK { c: lit.0, d, k }
                };
                self.emit(op, span);
            } else {
                let u = &mut self.c.units[self.unit];
                let start = u.stores.len() as u32;
                u.stores.extend(stores.iter().copied());
                let len = stores.len() as u32;
                self.emit(
                    Op::CondStore {
                        c: lit.0,
                        neg: lit.1,
                        start,
                        len,
                    },
                    span,
                );
            }
            return Ok(used);
        }
        // x1 := y1; x2 := y2; … with consecutive slots on both sides: one MovN.
        let plain_move = |me: &mut Self, s: &Stmt| -> R<Option<(u32, u32)>> {
            let StmtKind::Assign { target, value } = &s.kind else {
                return Ok(None);
            };
            let ExprKind::Load(src) = &value.kind else {
                return Ok(None);
            };
            if target.ty != src.ty
                || !scalar(me.p(), target.ty)
                || matches!(me.p().types.get(target.ty), Type::Subrange { .. })
            {
                return Ok(None);
            }
            let no_index = |p: &Place| {
                p.path
                    .iter()
                    .all(|s| matches!(s, Step::Field(_) | Step::Member(_)))
            };
            if !no_index(target) || !no_index(src) {
                return Ok(None);
            }
            let (d, sl) = (me.place_loc(target)?, me.place_loc(src)?);
            match (d.loc, d.bit, sl.loc, sl.bit) {
                (Loc::Slot(d), None, Loc::Slot(s), None)
                    if d & TAG == FRAME && s & TAG == FRAME =>
                {
                    Ok(Some((d, s)))
                }
                _ => Ok(None),
            }
        };
        if let Some((d0, s0)) = plain_move(self, &stmts[0])? {
            let mut n = 1u32;
            while (n as usize) < stmts.len() {
                match plain_move(self, &stmts[n as usize])? {
                    Some((d, s)) if d == d0 + n && s == s0 + n => n += 1,
                    _ => break,
                }
            }
            // Overlapping ranges would change what sequential assignments do.
            let overlap = d0 < s0 + n && s0 < d0 + n;
            if n >= 3 && !overlap {
                self.emit(Op::MovN { d: d0, s: s0, n }, stmts[0].span);
                return Ok(n as usize);
            }
        }
        Ok(0)
    }
}
