//! CODESYS's `ADR` of a variable that lives only during one call (a FUNCTION's variables, a
//! VAR_TEMP, and what a VAR_IN_OUT designates, which may be the caller's temporary) is allowed only where the pointer cannot outlive the call: it is kept in the
//! POU's own VAR/VAR_TEMP pointer variables, dereferenced, compared and moved by pointer
//! arithmetic, passed to a FUNCTION's or METHOD's input that keeps it no longer than its call
//! (the same rules in the callee: `kept_inputs`), never stored elsewhere (E201). No run-time
//! check is needed then: a pointer to a frame exists only while the frame does.

use std::collections::{BTreeMap, BTreeSet};

use petriplc_iec_syntax::diag;

use crate::ir::{
    BinaryOp, Builtin, Expr, ExprKind, Place, PouId, PouKind, Root, Step, Stmt, StmtKind,
};
use crate::ir::{GlobalId, VarClass, VarId};
use crate::types::TypeTable;

use super::Checker;

impl<'a> Checker<'a> {
    /// [`Self::frame_escapes`] for every body checked.
    pub(super) fn all_frame_escapes(&mut self) {
        let receivers = self.receivers();
        let free = self.free_inputs(&receivers);
        for (p, kind) in std::mem::take(&mut self.escape_todo) {
            let body = std::mem::take(&mut self.pous[p as usize].body);
            self.frame_escapes(p, kind, &body, (&free, &receivers));
            self.pous[p as usize].body = body;
        }
    }

    /// The methods (with their THIS) of blocks that may live in a frame that may return
    /// their instance's address (`Append := THIS^;`, directly or from another such call on
    /// THIS): that result is a frame pointer wherever the instance is one
    /// ([`Flow::carries`]). Found by growing the set until it is stable.
    fn receivers(&self) -> BTreeMap<PouId, VarId> {
        let mut candidates = Vec::new();
        for (&p, m) in &self.oop.members {
            let pou = &self.pous[p as usize];
            let Some(r) = pou.result else { continue };
            if !self.holds_pointer(pou.vars[r as usize].ty) || !self.in_frame(m.owner) {
                continue;
            }
            if let Some(t) = this_of(&pou.vars) {
                candidates.push((p, t, r));
            }
        }
        candidates.sort_unstable();
        // A call through an interface: its dispatch takes the handle as its last input
        // and gives it to the implementation's THIS; the result may be the instance's
        // address when the handle is a frame pointer (whichever implementation runs).
        let mut out = BTreeMap::new();
        for (&p, m) in &self.oop.members {
            if self.is_interface(m.owner) {
                if let Some(last) = self.pous[p as usize].vars.len().checked_sub(1) {
                    out.insert(p, last as VarId);
                }
            }
        }
        let none = BTreeSet::new();
        loop {
            let before = out.len();
            for &(p, this, r) in &candidates {
                if out.contains_key(&p) {
                    continue;
                }
                let n = self.pous[p as usize].vars.len();
                let frame: Vec<bool> = (0..n).map(|v| v == this as usize).collect();
                let slots: Vec<bool> = self.pous[p as usize]
                    .vars
                    .iter()
                    .enumerate()
                    .map(|(v, x)| {
                        v == r as usize || matches!(x.class, VarClass::Local | VarClass::Temp)
                    })
                    .collect();
                let mut holders = BTreeSet::new();
                let body = &self.pous[p as usize].body;
                holders_of(
                    &self.types,
                    body,
                    (&frame, &slots),
                    &mut holders,
                    (&none, &out),
                    Some(this),
                );
                if holders.contains(&r) {
                    out.insert(p, this);
                }
            }
            if out.len() == before {
                return out;
            }
        }
    }

    /// The pointer inputs of FUNCTIONs and METHODs that do not keep what they are given
    /// beyond the call: in the callee the pointer is only dereferenced, compared, moved,
    /// kept in its VAR/VAR_TEMP pointers and passed to such inputs, as a frame pointer
    /// may be. Found by growing the set of inputs that do keep it until it is stable.
    fn free_inputs(&self, receivers: &BTreeMap<PouId, VarId>) -> BTreeSet<(PouId, VarId)> {
        let mut candidates = Vec::new();
        for &(p, kind) in &self.escape_todo {
            let member = self.oop.members.contains_key(&p);
            if kind != PouKind::Function && !member {
                continue;
            }
            for (v, var) in self.pous[p as usize].vars.iter().enumerate() {
                if var.class == VarClass::Input && self.holds_pointer(var.ty) {
                    candidates.push((p, v as VarId));
                }
            }
        }
        let mut free: BTreeSet<(PouId, VarId)> = candidates.iter().copied().collect();
        loop {
            let mut kept = Vec::new();
            for &(p, v) in free.iter() {
                let vars = &self.pous[p as usize].vars;
                let frame = vec![false; vars.len()];
                let local: Vec<bool> = vars
                    .iter()
                    .map(|x| matches!(x.class, VarClass::Local | VarClass::Temp))
                    .collect();
                // The callee's own VAR/VAR_TEMP pointers may hold it, as a frame's.
                let slots = local.clone();
                let mut errors = Vec::new();
                let body = &self.pous[p as usize].body;
                follow(
                    &self.types,
                    body,
                    (&frame, &slots),
                    BTreeSet::from([v]),
                    (&free, receivers),
                    None,
                    &mut errors,
                );
                if !errors.is_empty() {
                    kept.push((p, v));
                }
            }
            if kept.is_empty() {
                return free;
            }
            for k in kept {
                free.remove(&k);
            }
        }
    }

    /// Checks that no pointer to the frame of POU `p` escapes its body.
    fn frame_escapes(
        &mut self,
        p: PouId,
        kind: PouKind,
        body: &[Stmt],
        (free, receivers): (&BTreeSet<(PouId, VarId)>, &BTreeMap<PouId, VarId>),
    ) {
        let vars = self.pous[p as usize].vars.clone();
        // A block with an instance in a FUNCTION's or METHOD's frame (or inside such an
        // instance) may end with that call: its variables are a frame's too.
        let in_frame = kind == PouKind::FunctionBlock && self.in_frame(p);
        // A method's THIS is its block's instance, which outlives the call unless the
        // instance is itself in a frame.
        let this_lasts = self
            .oop
            .members
            .get(&p)
            .is_some_and(|m| !self.in_frame(m.owner));
        let frame: Vec<bool> = vars
            .iter()
            .map(|v| {
                if this_lasts && v.name == "THIS" && v.class == VarClass::InOut {
                    return false;
                }
                // An in-out designates a caller's variable, which may be the caller's own
                // temporary: a pointer to it lasts only as long as the call, as a frame's.
                matches!(v.class, VarClass::Temp | VarClass::InOut)
                    || ((kind == PouKind::Function || in_frame)
                        && !matches!(v.class, VarClass::External(_) | VarClass::Global))
            })
            .collect();
        // A plain VAR/VAR_TEMP of the POU of a frame's lifetime (a FUNCTION's inputs,
        // outputs and result are not: the caller sees them; a function block's VAR outlives
        // the call) may hold a frame pointer.
        let slots: Vec<bool> = vars
            .iter()
            .zip(&frame)
            .map(|(v, f)| *f && matches!(v.class, VarClass::Local | VarClass::Temp))
            .collect();
        let mut errors = Vec::new();
        let flow = |frame: &[bool], slots: &[bool], own: Option<VarId>, errors: &mut Vec<_>| {
            // Variables that may hold such a pointer: plain VAR/VAR_TEMP pointers assigned one.
            follow(
                &self.types,
                body,
                (frame, slots),
                BTreeSet::new(),
                (free, receivers),
                own,
                errors,
            );
        };
        let this = self
            .oop
            .members
            .get(&p)
            .filter(|_| !this_lasts)
            .and_then(|_| this_of(&vars));
        match this {
            // A member of a block that may live in a frame: its own variables always end
            // with the call, its instance may (then a caller that gets its address, from
            // the result, treats it as a frame pointer: `receivers`). The two are followed
            // apart; the instance's may be kept in the instance and given as the result.
            Some(this) => {
                let mut own = frame.clone();
                own[this as usize] = false;
                flow(&own, &slots, None, &mut errors);
                let only_this: Vec<bool> = (0..frame.len()).map(|v| v == this as usize).collect();
                let mut with_result = slots.clone();
                if let Some(r) = self.pous[p as usize].result {
                    with_result[r as usize] = true;
                }
                flow(&only_this, &with_result, Some(this), &mut errors);
            }
            None => flow(&frame, &slots, None, &mut errors),
        }
        errors.sort_by_key(|e| (e.0.start, e.0.end));
        errors.dedup_by_key(|e| (e.0.start, e.0.end));
        let why = if in_frame {
            " (an instance of this block is a FUNCTION's or METHOD's variable, which ends with its call)"
        } else {
            ""
        };
        for (span, target) in errors {
            let name = match target {
                Into::Var(v) => Some(vars[v as usize].name.clone()),
                Into::Global(g) => Some(self.globals[g as usize].name.clone()),
                Into::Elsewhere => None,
            };
            let msg = match name {
                Some(n) => format!(
                    "a pointer to this {}'s own variables is stored in `{}`, which outlives the call; keep it in a pointer declared in the POU's VAR_TEMP (a FUNCTION's VAR){}",
                    kind.keyword(),
                    n,
                    why
                ),
                _ => format!(
                    "a pointer to this {}'s own variables may only be kept in its VAR or VAR_TEMP pointers, dereferenced, compared and moved (p + n); it must not be stored elsewhere, nor given to a call that may keep it (a function block's input, a FUNCTION's or METHOD's input that it stores), since the variables end with the call{}",
                    kind.keyword(),
                    why
                ),
            };
            self.error(diag::NO_ADDRESS, span, msg);
        }
    }
}

impl Checker<'_> {
    /// Whether a value of type `ty` is a pointer or a structure with a pointer field (an
    /// AnyType, a T_Generic): what a frame pointer may be passed in.
    fn holds_pointer(&self, ty: crate::types::TypeId) -> bool {
        self.types.ref_target(ty).is_some()
            || matches!(self.types.get(ty), crate::types::Type::Struct { fields, .. }
                if fields.iter().any(|f| self.types.ref_target(f.ty).is_some()))
    }

    /// Whether block `p` has an instance in a FUNCTION's or METHOD's frame, directly or
    /// inside another block's instance that has one.
    fn in_frame(&self, p: PouId) -> bool {
        let mut seen = BTreeSet::new();
        let mut todo: Vec<PouId> = self.frame_fbs.iter().copied().collect();
        while let Some(q) = todo.pop() {
            if q == p {
                return true;
            }
            if !seen.insert(q) {
                continue;
            }
            for v in &self.pous[q as usize].vars {
                if v.class != VarClass::InOut {
                    todo.extend(self.blocks_in(v.ty));
                }
            }
        }
        false
    }
}

/// Every escape from `body` of a pointer into the frame (or held by `holders` at the start),
/// once the variables that come to hold one are found.
#[allow(clippy::too_many_arguments)]
fn follow(
    types: &TypeTable,
    body: &[Stmt],
    (frame, slots): (&[bool], &[bool]),
    mut holders: BTreeSet<VarId>,
    (free, receivers): (&BTreeSet<(PouId, VarId)>, &BTreeMap<PouId, VarId>),
    own: Option<VarId>,
    errors: &mut Vec<(petriplc_iec_syntax::source::Span, Into)>,
) {
    holders_of(
        types,
        body,
        (frame, slots),
        &mut holders,
        (free, receivers),
        own,
    );
    let mut f = Flow {
        types,
        frame,
        slots,
        holders: &mut holders,
        free,
        receivers,
        own,
        errors: Some(errors),
    };
    f.stmts(body);
}

/// A member's THIS: its instance, passed as the last in-out.
fn this_of(vars: &[crate::ir::Var]) -> Option<VarId> {
    vars.iter()
        .position(|v| v.name == "THIS" && v.class == VarClass::InOut)
        .map(|t| t as VarId)
}

/// Grows `holders` with the variables a frame pointer is assigned to, until stable.
fn holders_of(
    types: &TypeTable,
    body: &[Stmt],
    (frame, slots): (&[bool], &[bool]),
    holders: &mut BTreeSet<VarId>,
    (free, receivers): (&BTreeSet<(PouId, VarId)>, &BTreeMap<PouId, VarId>),
    own: Option<VarId>,
) {
    loop {
        let before = holders.len();
        let mut f = Flow {
            types,
            frame,
            slots,
            holders,
            free,
            receivers,
            own,
            errors: None,
        };
        f.stmts(body);
        if holders.len() == before {
            return;
        }
    }
}

struct Flow<'f> {
    types: &'f TypeTable,
    /// The variables whose address is a frame pointer.
    frame: &'f [bool],
    /// The variables that may hold one (the POU's own VAR/VAR_TEMP of a frame's lifetime).
    slots: &'f [bool],
    /// Inputs of callees that keep a pointer no longer than the call.
    free: &'f BTreeSet<(PouId, VarId)>,
    holders: &'f mut BTreeSet<VarId>,
    /// Methods of blocks that may live in a frame whose result may be their instance's
    /// address (`Append := THIS^;`), and the members of interfaces (their dispatch), with
    /// their THIS: such a call on a frame instance gives a frame pointer.
    receivers: &'f BTreeMap<PouId, VarId>,
    /// A method's THIS when the pointers followed are its instance's: storing them in the
    /// instance itself is no escape (they end together).
    own: Option<VarId>,
    /// `None` while the holders are gathered; then every escape found, with the variable
    /// it was stored in, if any.
    errors: Option<&'f mut Vec<(petriplc_iec_syntax::source::Span, Into)>>,
}

/// Where an escaping frame pointer goes.
#[derive(Clone, Copy)]
enum Into {
    Var(VarId),
    Global(GlobalId),
    Elsewhere,
}

impl Flow<'_> {
    /// Whether the value of `e` may be a pointer into the frame.
    fn carries(&self, e: &Expr) -> bool {
        match &e.kind {
            // An address inside what a pointer designates is a frame pointer when that
            // pointer is one (`ADR(p^.x)`, `ADR(p[2])`).
            ExprKind::Ref(p) => self.address_carries(p),
            // A holder, or a field of one that holds a reference (a structure holding the
            // pointer: an AnyType's pValue, not its diSize).
            ExprKind::Load(p) => {
                matches!(p.root, Root::Var(v) if self.holders.contains(&v))
                    && (p.path.is_empty()
                        || (p.path.iter().all(|s| matches!(s, Step::Field(_)))
                            && self.types.holds_reference(p.ty)))
            }
            ExprKind::Binary(BinaryOp::Add | BinaryOp::Sub, a, b) => {
                self.carries(a) || self.carries(b)
            }
            ExprKind::Convert(x) => self.carries(x),
            // The NULL check of a call through an interface passes the handle on.
            ExprKind::Builtin(Builtin::ItfCheck, args) => args.iter().any(|x| self.carries(x)),
            // A method that may return its instance's address, called on an instance whose
            // address is a frame pointer.
            ExprKind::Call(c) => {
                self.types.holds_reference(e.ty)
                    && self.receivers.get(&c.pou).is_some_and(|this| {
                        c.in_outs
                            .iter()
                            .any(|(v, p)| v == this && self.address_carries(p))
                            || c.inputs.iter().any(|(v, x)| v == this && self.carries(x))
                    })
            }
            _ => false,
        }
    }

    /// Whether the address of `p` may be a pointer into the frame.
    fn address_carries(&self, p: &Place) -> bool {
        match p.path.iter().position(|s| matches!(s, Step::Deref)) {
            None => matches!(p.root, Root::Var(v) if self.frame[v as usize]),
            Some(k) => match (p.root, p.path.first()) {
                (Root::Value, Some(Step::Value(x))) => self.carries(x),
                (Root::Var(v), _) => k == 0 && self.holders.contains(&v),
                _ => false,
            },
        }
    }

    fn escape(&mut self, e: &Expr, into: Into) {
        if let Some(errs) = self.errors.as_deref_mut() {
            errs.push((e.span, into));
        }
    }

    fn stmts(&mut self, body: &[Stmt]) {
        for s in body {
            self.stmt(s);
        }
    }

    fn stmt(&mut self, s: &Stmt) {
        match &s.kind {
            StmtKind::Assign { target, value } => {
                self.place(target);
                if self.carries(value) {
                    match (target.root, target.path.is_empty()) {
                        (Root::Var(v), true) if self.is_holder_slot(v) => {
                            self.holders.insert(v);
                        }
                        // A field of a structure in the POU's VAR/VAR_TEMP (an ANY input's
                        // whole value, check/any.rs): the structure holds it from now on.
                        (Root::Var(v), false)
                            if self.is_holder_slot(v)
                                && matches!(target.path[..], [Step::Field(_)]) =>
                        {
                            self.holders.insert(v);
                        }
                        (Root::Var(v), false) if Some(v) == self.own => {}
                        (Root::Var(v), _) => self.escape(value, Into::Var(v)),
                        (Root::Global(g), _) => self.escape(value, Into::Global(g)),
                        (Root::This | Root::Value, _) => self.escape(value, Into::Elsewhere),
                    }
                    self.inner(value);
                } else {
                    self.expr(value);
                }
            }
            StmtKind::CallFb(c) => {
                self.place(&c.instance);
                c.inputs.iter().for_each(|(_, x)| self.expr(x));
                c.in_outs.iter().for_each(|(_, p)| self.place(p));
                c.outputs.iter().for_each(|(_, p, _)| self.place(p));
            }
            // A call for its effects: a pointer it returns is dropped, not kept.
            StmtKind::Eval(x) => self.inner(x),
            StmtKind::If {
                branches,
                else_body,
            } => {
                for (c, b) in branches {
                    self.expr(c);
                    self.stmts(b);
                }
                self.stmts(else_body);
            }
            StmtKind::Case {
                selector,
                arms,
                else_body,
            } => {
                self.expr(selector);
                arms.iter().for_each(|a| self.stmts(&a.body));
                self.stmts(else_body);
            }
            StmtKind::For(f) => {
                self.place(&f.var);
                self.expr(&f.from);
                self.expr(&f.to);
                self.expr(&f.by);
                self.stmts(&f.body);
            }
            StmtKind::While { cond, body } => {
                self.expr(cond);
                self.stmts(body);
            }
            StmtKind::Repeat { body, until } => {
                self.stmts(body);
                self.expr(until);
            }
            StmtKind::Goto {
                cond: Some((c, _)), ..
            } => self.expr(c),
            StmtKind::Exit
            | StmtKind::Continue
            | StmtKind::Return
            | StmtKind::Label(_)
            | StmtKind::Goto { cond: None, .. } => {}
        }
    }

    fn is_holder_slot(&self, v: VarId) -> bool {
        self.slots[v as usize]
    }

    /// An expression whose value must not be a frame pointer.
    fn expr(&mut self, e: &Expr) {
        if self.carries(e) {
            self.escape(e, Into::Elsewhere);
        }
        self.inner(e);
    }

    /// The operands of `e`: comparisons (equality and CODESYS's ordering) and pointer
    /// arithmetic may take a frame pointer.
    fn inner(&mut self, e: &Expr) {
        match &e.kind {
            ExprKind::Const(_) => {}
            ExprKind::Load(p) | ExprKind::Ref(p) => self.place(p),
            ExprKind::Unary(_, x) | ExprKind::Trunc(x) => self.expr(x),
            ExprKind::Convert(x) => {
                if self.carries(e) {
                    self.inner(x)
                } else {
                    self.expr(x)
                }
            }
            ExprKind::Binary(op, a, b) => {
                let ok = matches!(
                    op,
                    BinaryOp::Eq
                        | BinaryOp::Ne
                        | BinaryOp::Lt
                        | BinaryOp::Le
                        | BinaryOp::Gt
                        | BinaryOp::Ge
                ) || self.carries(e);
                for x in [a, b] {
                    if ok {
                        self.inner(x)
                    } else {
                        self.expr(x)
                    }
                }
            }
            ExprKind::Call(c) => {
                for (v, x) in &c.inputs {
                    // An interface's handle, which the dispatch passes on as THIS.
                    let handle = self.receivers.get(&c.pou) == Some(v);
                    match handle || self.free.contains(&(c.pou, *v)) {
                        true => self.inner(x),
                        false => self.expr(x),
                    }
                }
                c.in_outs.iter().for_each(|(_, p)| self.place(p));
                c.outputs.iter().for_each(|(_, p)| self.place(p));
            }
            // MEMCPY, MEMSET and MEMCMP use the pointers they are given and keep none; a
            // pointer's number designates nothing; an interface call's NULL check passes
            // the handle on (`carries`).
            ExprKind::Builtin(
                Builtin::MemCpy
                | Builtin::MemSet
                | Builtin::MemCmp
                | Builtin::Address
                | Builtin::ItfCheck,
                args,
            ) => args.iter().for_each(|x| self.inner(x)),
            ExprKind::Builtin(_, args) => args.iter().for_each(|x| self.expr(x)),
        }
    }

    fn place(&mut self, p: &Place) {
        for s in &p.path {
            match s {
                Step::Index(ix) => ix.iter().for_each(|x| self.expr(x)),
                // Dereferenced where it is computed: it may be a frame pointer.
                Step::Value(x) => self.inner(x),
                _ => {}
            }
        }
    }
}
