//! Interfaces (docs/iec.md, "Interfaces"). An INTERFACE is read as a FUNCTION_BLOCK without
//! variables or body (`PouOop::interface`) whose METHODs and PROPERTY accessors are members
//! like a block's; a variable of an interface's type holds a checked handle to an instance
//! (`RefKind::Interface`, one slot, 0 when it designates none), whose tag is the instance's own
//! block type.
//!
//! Each member of an interface is a FUNCTION-like POU whose THIS is an input (the handle) and
//! whose body the checker writes: a CASE over the tag with one arm per block implementing the
//! interface (the whole project is known), calling that block's method with THIS dereferenced
//! as that block (`ItfType`; each arm's handle checked again by the dereference). A call
//! through an interface checks the handle first (`ItfCheck`: a NULL interface is a fault at
//! the call), so VM and machine code run dispatch as ordinary calls.

use std::collections::HashSet;

use petriplc_iec_syntax::ast::{Ident, PouKind, RefKind};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{
    Builtin, CaseArm, Expr, ExprKind, FnCall, Place, PouId, Root, Step, Stmt, StmtKind, Var,
    VarClass, VarId,
};
use crate::types::{ids, FbRef, Type, TypeId};
use crate::value::Value;

use super::{Member, MemberKind};

/// TwinCAT's root interface, implied for every interface: nothing to declare or implement.
fn is_system_root(id: &Ident) -> bool {
    let last = id.name.rsplit('.').next().unwrap_or(&id.name);
    last.eq_ignore_ascii_case("IQueryInterface")
}

impl<'a> Checker<'a> {
    /// Whether POU `p` is an INTERFACE (not one of its members nor its query function).
    pub(crate) fn is_interface(&self, p: PouId) -> bool {
        // A member's or a query function's syntax tree may be the interface's own.
        self.pou_asts[p as usize].oop.interface
            && !self.oop.members.contains_key(&p)
            && !self.oop.query_of.contains_key(&p)
    }

    /// The type of variables of INTERFACE `p`.
    pub(crate) fn itf_type(&mut self, p: PouId) -> TypeId {
        if let Some(&t) = self.oop.itf_types.get(&p) {
            return t;
        }
        let name = self.pou_asts[p as usize].name.name.clone();
        // A marker named as the interface, so messages name it.
        let marker = self.types.add(Type::Struct {
            name,
            fields: Vec::new(),
        });
        let t = self.types.reference(RefKind::Interface, marker);
        self.oop.itf_types.insert(p, t);
        self.oop.itf_of.insert(t, p);
        t
    }

    /// The interface a type is the type of.
    pub(crate) fn itf_of_type(&self, t: TypeId) -> Option<PouId> {
        self.oop.itf_of.get(&t).copied()
    }

    /// The interface a name in IMPLEMENTS or EXTENDS designates (`Lib.I_X` by its last part).
    fn lookup_itf(&self, id: &Ident) -> Option<PouId> {
        let last = id.name.rsplit('.').next().unwrap_or(&id.name);
        let &p = self.pou_names.get(&last.to_ascii_uppercase())?;
        self.is_interface(p).then_some(p)
    }

    /// Every interface block (or interface) `p` is: those it (or a base) names, their bases,
    /// transitively; an interface is itself.
    pub(crate) fn interfaces_of(&self, p: PouId) -> Vec<PouId> {
        let mut todo: Vec<PouId> = Vec::new();
        if self.is_interface(p) {
            todo.push(p);
        } else {
            for level in self.oop.chain(p) {
                for i in &self.pou_asts[level as usize].oop.implements {
                    todo.extend(self.lookup_itf(i));
                }
            }
        }
        let mut out = Vec::new();
        while let Some(q) = todo.pop() {
            if out.contains(&q) {
                continue;
            }
            out.push(q);
            for i in &self.pou_asts[q as usize].oop.implements {
                todo.extend(self.lookup_itf(i));
            }
        }
        out
    }

    /// The blocks whose instances an interface `itf` may designate: every FUNCTION_BLOCK
    /// that is not ABSTRACT and implements it (an instance's type is its own block).
    pub(crate) fn implementers(&self, itf: PouId) -> Vec<PouId> {
        (0..self.pou_asts.len() as PouId)
            .filter(|&p| {
                let a = self.pou_asts[p as usize];
                !self.oop.members.contains_key(&p)
                    && a.kind == PouKind::FunctionBlock
                    && !a.oop.interface
                    && !a.oop.modifiers.is_abstract
                    && self.interfaces_of(p).contains(&itf)
            })
            .collect()
    }

    /// After the members are collected: an interface has its bases' methods and properties
    /// too (their dispatch covers every block implementing the derived one).
    pub(crate) fn inherit_interface_members(&mut self) {
        for p in 0..self.pou_asts.len() as PouId {
            if !self.is_interface(p) {
                continue;
            }
            for base in self.interfaces_of(p) {
                if base == p {
                    continue;
                }
                let methods: Vec<(String, PouId)> = self
                    .oop
                    .methods
                    .iter()
                    .filter(|((o, _), _)| *o == base)
                    .map(|((_, k), &m)| (k.clone(), m))
                    .collect();
                for (k, m) in methods {
                    self.oop.methods.entry((p, k)).or_insert(m);
                }
                let props: Vec<(String, super::Prop)> = self
                    .oop
                    .props
                    .iter()
                    .filter(|((o, _), _)| *o == base)
                    .map(|((_, k), pr)| (k.clone(), pr.clone()))
                    .collect();
                for (k, pr) in props {
                    self.oop.props.entry((p, k)).or_insert(pr);
                }
            }
        }
    }

    /// A member of an interface: a handle per implementing block (the arms' THIS), then THIS,
    /// an input holding the interface.
    pub(crate) fn itf_member_vars(&mut self, m: &Member<'a>, cx: &mut Cx) {
        for k in self.implementers(m.owner) {
            let fb = self.types.fb(FbRef::User(k));
            let ty = self.types.reference(RefKind::PointerTo, fb);
            let name = format!("THIS AS {}", self.pou_asts[k as usize].name.name);
            cx.vars.push(Var::hidden(name, ty, m.span));
        }
        let ty = self.itf_type(m.owner);
        cx.vars.push(Var {
            class: VarClass::Input,
            ..Var::hidden("THIS".into(), ty, m.span)
        });
    }

    /// The body of an interface's member, the dispatch (`true`); `false` for any other POU.
    pub(crate) fn itf_dispatch(&mut self, p: PouId) -> bool {
        let Some(m) = self.oop.members.get(&p).cloned() else {
            return false;
        };
        if !self.is_interface(m.owner) {
            return false;
        }
        let vars = self.pous[p as usize].vars.clone();
        let Some(this) = vars.len().checked_sub(1) else {
            return true;
        };
        let this = this as VarId;
        let span = m.span;
        let load = |v: VarId, ty: TypeId| Expr {
            kind: ExprKind::Load(Place {
                root: Root::Var(v),
                path: Vec::new(),
                ty: vars[v as usize].ty,
                span,
            }),
            ty,
            span,
        };
        let this_ty = vars[this as usize].ty;
        let selector = Expr {
            kind: ExprKind::Builtin(Builtin::ItfType, vec![load(this, this_ty)]),
            ty: ids::DINT,
            span,
        };
        let key = m.name.to_ascii_uppercase();
        let mut arms = Vec::new();
        let first = vars
            .iter()
            .position(|v| v.class == VarClass::Hidden && v.name.starts_with("THIS AS "))
            .unwrap_or(0);
        for (n, k) in self.implementers(m.owner).into_iter().enumerate() {
            let target = match m.kind {
                MemberKind::Method => self.oop.methods.get(&(k, key.clone())).copied(),
                MemberKind::Get => self.oop.props.get(&(k, key.clone())).and_then(|x| x.get),
                MemberKind::Set => self.oop.props.get(&(k, key.clone())).and_then(|x| x.set),
                _ => None,
            };
            // A block without the member is reported by `implements_rules`.
            let Some(target) = target.filter(|t| {
                let tm = &self.oop.members[t];
                tm.kind == m.kind && !tm.modifiers.is_abstract
            }) else {
                continue;
            };
            self.interface(target);
            let h = (first + n) as VarId;
            let fb = self.types.fb(FbRef::User(k));
            let callee = self.pous[target as usize].clone();
            let (mut inputs, mut in_outs, mut outputs) = (Vec::new(), Vec::new(), Vec::new());
            for (j, v) in callee.vars.iter().enumerate() {
                let j = j as VarId;
                if v.class == VarClass::InOut && v.name == "THIS" {
                    let this_k = Place {
                        root: Root::Var(h),
                        path: vec![Step::Deref],
                        ty: fb,
                        span,
                    };
                    in_outs.push((j, this_k));
                    continue;
                }
                let mine = vars.iter().position(|w| {
                    w.class == v.class && w.name.eq_ignore_ascii_case(&v.name) && w.name != "THIS"
                });
                let Some(d) = mine.map(|d| d as VarId) else {
                    continue;
                };
                let place = Place {
                    root: Root::Var(d),
                    path: Vec::new(),
                    ty: vars[d as usize].ty,
                    span,
                };
                match v.class {
                    VarClass::Input => inputs.push((j, load(d, v.ty))),
                    VarClass::InOut => in_outs.push((j, place)),
                    VarClass::Output => outputs.push((j, place)),
                    _ => {}
                }
            }
            let rty = callee
                .result
                .map_or(ids::VOID, |r| callee.vars[r as usize].ty);
            let call = Expr {
                kind: ExprKind::Call(FnCall {
                    pou: target,
                    inputs,
                    in_outs,
                    outputs,
                }),
                ty: rty,
                span,
            };
            let h_ty = vars[h as usize].ty;
            let mut body = vec![Stmt {
                kind: StmtKind::Assign {
                    target: Place {
                        root: Root::Var(h),
                        path: Vec::new(),
                        ty: h_ty,
                        span,
                    },
                    value: load(this, h_ty),
                },
                span,
            }];
            body.push(Stmt {
                kind: match self.pous[p as usize].result {
                    Some(r) => StmtKind::Assign {
                        target: Place {
                            root: Root::Var(r),
                            path: Vec::new(),
                            ty: vars[r as usize].ty,
                            span,
                        },
                        value: call,
                    },
                    None => StmtKind::Eval(call),
                },
                span,
            });
            // Dispatch is a call: recursion through it is refused as any other (frames are
            // static).
            self.calls.push((Some(p), target, span));
            let tid = i128::from(fb);
            arms.push(CaseArm {
                ranges: vec![(tid, tid)],
                body,
            });
        }
        self.pous[p as usize].body = vec![Stmt {
            kind: StmtKind::Case {
                selector,
                arms,
                else_body: Vec::new(),
            },
            span,
        }];
        true
    }

    /// THIS of a call through an interface: the handle, checked not NULL where the call is.
    pub(crate) fn itf_this(&self, place: Place, span: Span) -> Expr {
        let ty = place.ty;
        Expr {
            kind: ExprKind::Builtin(
                Builtin::ItfCheck,
                vec![Expr {
                    kind: ExprKind::Load(place),
                    ty,
                    span,
                }],
            ),
            ty,
            span,
        }
    }

    /// A value stored where interface type `to` is needed: an instance of a block that
    /// implements it (its handle), an interface that extends it, 0. `None` when `to` is not
    /// an interface or the value is of another kind (the ordinary rules apply).
    pub(crate) fn itf_coerce(&mut self, x: &Expr, to: TypeId, what: &str) -> Option<Expr> {
        let itf = self.itf_of_type(to)?;
        let span = x.span;
        let iname = self.pou_asts[itf as usize].name.name.clone();
        match self.types.get(x.ty).clone() {
            Type::IntLit if x.const_int() == Some(0) => Some(Expr {
                kind: ExprKind::Const(Value::Int(0)),
                ty: to,
                span,
            }),
            Type::Fb(FbRef::User(k)) => {
                let ExprKind::Load(place) = &x.kind else {
                    return None;
                };
                let kname = self.pou_asts[k as usize].name.name.clone();
                if !self.interfaces_of(k).contains(&itf) {
                    self.error(
                        diag::ITF_NOT_IMPLEMENTED,
                        span,
                        format!("{what} is an instance of {kname}, which does not implement {iname}; add IMPLEMENTS {iname} to {kname} or give an instance of a block that implements it"),
                    );
                    return Some(crate::expr::err(span));
                }
                Some(Expr {
                    kind: ExprKind::Ref(place.clone()),
                    ty: to,
                    span,
                })
            }
            Type::Fb(FbRef::Native(_)) => {
                self.error(
                    diag::ITF_NOT_IMPLEMENTED,
                    span,
                    format!("{what} is an instance of a standard function block, which implements no interface; {iname} needs an instance of a block that IMPLEMENTS it"),
                );
                Some(crate::expr::err(span))
            }
            Type::Ref {
                kind: RefKind::Interface,
                ..
            } => {
                let from = self.itf_of_type(x.ty)?;
                if self.interfaces_of(from).contains(&itf) {
                    return Some(Expr {
                        ty: to,
                        ..x.clone()
                    });
                }
                let fname = self.pou_asts[from as usize].name.name.clone();
                self.error(
                    diag::ITF_NOT_IMPLEMENTED,
                    span,
                    format!("{what} is {fname}, which does not extend {iname}; cast with __QUERYINTERFACE({fname}_value, {iname}_variable), which tells whether the instance implements {iname}"),
                );
                Some(crate::expr::err(span))
            }
            _ => None,
        }
    }

    /// The rules of IMPLEMENTS, checked once every interface is known: the names are
    /// interfaces, and a concrete block has each of their members with their signatures.
    pub(crate) fn implements_rules(&mut self, p: PouId) {
        let ast = self.pou_asts[p as usize];
        let interface = ast.oop.interface;
        for i in &ast.oop.implements {
            if is_system_root(i) || self.lookup_itf(i).is_some() {
                continue;
            }
            let msg = match self.pou_names.get(&i.key()) {
                Some(&q) => format!(
                    "`{}` is a {}, not an INTERFACE; {}",
                    i.name,
                    self.pou_asts[q as usize].kind.keyword(),
                    if interface {
                        "an INTERFACE extends INTERFACEs only"
                    } else {
                        "a FUNCTION_BLOCK's base goes after EXTENDS"
                    }
                ),
                None => format!("`{}` is not an INTERFACE declared among these sources; declare it, check the source that declares it together with these, or correct the name", i.name),
            };
            self.error(diag::ITF_NOT_INTERFACE, i.span, msg);
        }
        if interface {
            // As a FUNCTION_BLOCK's EXTENDS (E210): the chain of bases must end.
            for i in &ast.oop.implements {
                let cycle = self
                    .lookup_itf(i)
                    .is_some_and(|b| self.interfaces_of(b).contains(&p));
                if cycle {
                    self.error(
                        diag::OOP_DECLARATION,
                        i.span,
                        format!(
                            "{} extends itself through {}; a chain of EXTENDS must end",
                            ast.name.name, i.name
                        ),
                    );
                }
            }
        }
        if interface || ast.kind != PouKind::FunctionBlock {
            if !interface && !ast.oop.implements.is_empty() {
                self.error(
                    diag::OOP_DECLARATION,
                    ast.name.span,
                    format!(
                        "only a FUNCTION_BLOCK implements interfaces; {} is a {}",
                        ast.name.name,
                        ast.kind.keyword()
                    ),
                );
            }
            return;
        }
        let concrete = !ast.oop.modifiers.is_abstract;
        let bname = ast.name.name.clone();
        let mut itfs = self.interfaces_of(p);
        itfs.sort_unstable();
        let mut seen = HashSet::new();
        for itf in itfs {
            let iname = self.pou_asts[itf as usize].name.name.clone();
            let mut wanted: Vec<(String, PouId)> = self
                .oop
                .methods
                .iter()
                .filter(|((o, _), _)| *o == itf)
                .map(|((_, k), &m)| (k.clone(), m))
                .collect();
            wanted.sort();
            for (key, im) in wanted {
                if !seen.insert((key.clone(), im)) {
                    continue;
                }
                let mname = self.oop.members[&im].name.clone();
                let got = self
                    .oop
                    .methods
                    .get(&(p, key))
                    .copied()
                    .filter(|m| self.oop.members[m].kind == MemberKind::Method);
                match got {
                    Some(m) if !self.oop.members[&m].modifiers.is_abstract || !concrete => {
                        self.same_signature(im, m, &bname, &iname)
                    }
                    _ if !concrete => {}
                    _ => self.error(
                        diag::ITF_MISSING,
                        ast.name.span,
                        format!("{bname} implements {iname} but has no method {mname}; add METHOD {mname} with the interface's parameters to {bname}, or declare it FUNCTION_BLOCK ABSTRACT"),
                    ),
                }
            }
            let mut props: Vec<(String, super::Prop)> = self
                .oop
                .props
                .iter()
                .filter(|((o, _), _)| *o == itf)
                .map(|((_, k), pr)| (k.clone(), pr.clone()))
                .collect();
            props.sort_by(|a, b| a.0.cmp(&b.0));
            for (key, ip) in props {
                let got = self.oop.props.get(&(p, key.clone())).cloned();
                for (want, have, acc) in [
                    (ip.get, got.as_ref().and_then(|g| g.get), "GET"),
                    (ip.set, got.as_ref().and_then(|g| g.set), "SET"),
                ] {
                    let Some(want) = want else {
                        continue;
                    };
                    if !seen.insert((format!("{key} {acc}"), want)) {
                        continue;
                    }
                    let pname = self.oop.members[&want].name.clone();
                    match have {
                        Some(h) => self.same_signature(want, h, &bname, &iname),
                        None if !concrete => {}
                        None => self.error(
                            diag::ITF_MISSING,
                            ast.name.span,
                            format!("{bname} implements {iname} but has no {acc} for property {pname}; add PROPERTY {pname} with a {acc} accessor to {bname}, or declare it FUNCTION_BLOCK ABSTRACT"),
                        ),
                    }
                }
            }
        }
    }

    /// An interface's member `want` and its implementation `have` take and give the same.
    fn same_signature(&mut self, want: PouId, have: PouId, bname: &str, iname: &str) {
        self.interface(want);
        self.interface(have);
        let (a, b) = (self.member_sig(want), self.member_sig(have));
        if a == b {
            return;
        }
        let m = &self.oop.members[&have];
        let (name, span) = (m.name.clone(), m.span);
        self.error(
            diag::ITF_SIGNATURE,
            span,
            format!(
                "{bname}'s {name} implements {iname}'s with other parameters: ({}) instead of ({}); give it the interface's inputs, outputs, in-outs and result type",
                Self::show_sig(&b),
                Self::show_sig(&a)
            ),
        );
    }
}
