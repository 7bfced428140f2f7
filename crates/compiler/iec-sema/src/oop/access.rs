//! Members used in code: the instance's variables inside a member, `THIS^`, method and
//! action calls (`inst.M()`, `M()`, `THIS^.M()`, `SUPER^.M()`, `SUPER^()`), and properties
//! read and written (each a call of its GET or SET).

use petriplc_iec_syntax::ast::{self, Access, ExprKind as A};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::expr::err;
use crate::ir::{Expr, Place, PouId, Root, Step, VarClass};
use crate::types::{FbRef, Type};

fn is_word(e: &ast::Expr, w: &str) -> bool {
    matches!(&e.kind, A::Name(n) if n.is(w))
}

/// `THIS^` or `SUPER^`.
fn is_deref_of(e: &ast::Expr, w: &str) -> bool {
    matches!(&e.kind, A::Deref(b) if is_word(b, w))
}

impl<'a> Checker<'a> {
    /// A variable of the instance named in a member's body (after its own variables): its
    /// VAR_INST first, then the block's variables (an external its global).
    pub(crate) fn this_member_place(&mut self, id: &ast::Ident, cx: &Cx) -> Option<Place> {
        let t = cx.this.as_ref()?;
        if t.root == Root::This {
            return None;
        }
        let owner = &self.pous[t.owner as usize];
        let inst = t
            .inst_prefix
            .as_ref()
            .and_then(|pre| owner.var_by_name(&format!("{pre}{}", id.name)));
        let v = inst.or_else(|| {
            owner
                .var_by_name(&id.name)
                .filter(|&v| owner.vars[v as usize].class != VarClass::Hidden)
        })?;
        let var = &owner.vars[v as usize];
        if let VarClass::External(g) = var.class {
            return Some(Place {
                root: Root::Global(g),
                path: Vec::new(),
                ty: self.globals[g as usize].ty,
                span: id.span,
            });
        }
        Some(Place {
            root: t.root,
            path: vec![Step::Member(v)],
            ty: var.ty,
            span: id.span,
        })
    }

    /// Whether `id` in a member's body names a variable of the instance (so `id(…);` calls
    /// that instance, not a function).
    pub(crate) fn is_this_member(&mut self, id: &ast::Ident, cx: &Cx) -> bool {
        self.this_member_place(id, cx).is_some()
    }

    /// The instance itself (`THIS^`) where code works on one.
    pub(crate) fn this_place(&mut self, cx: &Cx, span: Span) -> Option<Place> {
        let t = cx.this.as_ref()?;
        let ty = self.types.fb(FbRef::User(t.owner));
        Some(Place {
            root: t.root,
            path: Vec::new(),
            ty,
            span,
        })
    }

    /// `THIS^` as a place; `None` when `base^` is an ordinary dereference.
    pub(crate) fn this_deref(&mut self, base: &ast::Expr, cx: &Cx, span: Span) -> Option<Place> {
        if !is_word(base, "THIS") || cx.names.contains_key("THIS") && cx.this.is_none() {
            return None;
        }
        cx.this.as_ref()?;
        self.this_place(cx, span)
    }

    /// Whether a place is the instance the code works on (whose internals it may use).
    pub(crate) fn is_this(&self, p: &Place, cx: &Cx) -> bool {
        p.path.is_empty() && cx.this.as_ref().is_some_and(|t| t.root == p.root)
    }

    /// A call of a method or action, `None` when the call is not one.
    /// The interface an expression gives (a call's result), kept in a hidden temporary set
    /// before the statement, so that a method can be called on it.
    /// `Err`: the call gives no interface (a REFERENCE TO an instance: `instance_of`).
    fn interface_value(&mut self, e: &ast::Expr, cx: &mut Cx) -> Result<Option<Place>, ()> {
        // Checked once to learn its type; what it reports is dropped when it is no interface
        // (it is checked again as the reference it is).
        let mark = self.diags.items.len();
        let pre = cx.pre.as_ref().map(Vec::len);
        let x = self.expr(e, cx, None);
        if x.ty == crate::types::ids::ERROR {
            return Ok(None);
        }
        if !matches!(
            self.types.get(x.ty),
            Type::Ref {
                kind: ast::RefKind::Interface,
                ..
            }
        ) {
            self.diags.items.truncate(mark);
            if let (Some(n), Some(p)) = (pre, cx.pre.as_mut()) {
                p.truncate(n);
            }
            return Err(());
        }
        if cx.pre.is_none() {
            self.error(
                diag::UNSUPPORTED,
                e.span,
                "a method of the interface a call returns is called here only in an assignment or a call statement: keep the interface in a variable first (i := s.Get(x); … i.M() …)",
            );
            return Ok(None);
        }
        let id = cx.vars.len() as crate::ir::VarId;
        // A VAR_TEMP: it may hold what a frame pointer may (check/escape.rs).
        cx.vars.push(crate::ir::Var {
            class: crate::ir::VarClass::Temp,
            ..crate::ir::Var::hidden(format!("$itf{id}"), x.ty, e.span)
        });
        let tmp = Place {
            root: Root::Var(id),
            path: Vec::new(),
            ty: x.ty,
            span: e.span,
        };
        cx.pre.get_or_insert_with(Vec::new).push(crate::ir::Stmt {
            kind: crate::ir::StmtKind::Assign {
                target: tmp.clone(),
                value: x,
            },
            span: e.span,
        });
        Ok(Some(tmp))
    }

    pub(crate) fn member_call(&mut self, call: &ast::Call, cx: &mut Cx) -> Option<Expr> {
        let span = call.span;
        let (m, this) = match &call.callee.kind {
            A::Name(n) => {
                let key = n.key();
                if !self.oop.names.contains(&key) || cx.names.contains_key(&key) {
                    return None;
                }
                let owner = cx.this.as_ref()?.owner;
                let m = *self.oop.methods.get(&(owner, key))?;
                let this = self.this_place(cx, span)?;
                if !self.may_use(m, cx, n) {
                    return Some(err(span));
                }
                (m, this)
            }
            A::Deref(b) if is_word(b, "SUPER") => {
                let Some((level, this)) = self.super_level(cx, call.callee.span) else {
                    return Some(err(span));
                };
                let owner = cx.this.as_ref()?.owner;
                let Some(&m) = self.oop.bodies.get(&(owner, level)) else {
                    return Some(err(span));
                };
                (m, this)
            }
            A::Field(base, f) => {
                let key = f.key();
                if is_deref_of(base, "SUPER") {
                    let Some((level, this)) = self.super_level(cx, base.span) else {
                        return Some(err(span));
                    };
                    let owner = cx.this.as_ref()?.owner;
                    let Some(m) = self.version_at(owner, level, &key) else {
                        let bn = self.pou_asts[level as usize].name.name.clone();
                        self.error(
                            diag::OOP_MEMBER,
                            f.span,
                            format!("{bn} (SUPER^) has no method `{}`", f.name),
                        );
                        return Some(err(span));
                    };
                    if self.oop.members[&m].modifiers.is_abstract {
                        self.error(
                            diag::OOP_MODIFIER,
                            f.span,
                            format!(
                                "SUPER^.{} is ABSTRACT in the base: it has no body to call",
                                f.name
                            ),
                        );
                        return Some(err(span));
                    }
                    (m, this)
                } else {
                    if !self.oop.names.contains(&key) {
                        // No member has the name: through an interface variable, say so.
                        let q = match &base.kind {
                            A::Name(n) => self.plain_var_type(n, cx),
                            _ => None,
                        };
                        return q
                            .and_then(|t| self.owner_of_instance(t))
                            .and_then(|q| self.no_itf_member(q, f, "method", span));
                    }
                    let inst = match &base.kind {
                        // `s.Get(x).Pop()`: a method of the interface a call returns.
                        A::Call(_) => match self.interface_value(base, cx) {
                            Ok(p) => p,
                            Err(()) => self.instance_of(base, cx),
                        },
                        _ => self.instance_of(base, cx),
                    };
                    let Some(inst) = inst else {
                        return Some(err(span));
                    };
                    let q = self.owner_of_instance(inst.ty)?;
                    let Some(&m) = self.oop.methods.get(&(q, key)) else {
                        return self.no_itf_member(q, f, "method", span);
                    };
                    if !self.may_use(m, cx, f) {
                        return Some(err(span));
                    }
                    (m, inst)
                }
            }
            _ => return None,
        };
        Some(self.fn_call_with(m, call, cx, Some(this)))
    }

    /// The block (or interface) whose members an instance of type `ty` has.
    fn owner_of_instance(&self, ty: crate::types::TypeId) -> Option<PouId> {
        match *self.types.get(ty) {
            Type::Fb(FbRef::User(q)) => Some(q),
            _ => self.itf_of_type(ty),
        }
    }

    /// A member name `f` that interface `q` lacks (E218); `None` when `q` is a block (the
    /// name is then read otherwise: a variable of the instance).
    fn no_itf_member(&mut self, q: PouId, f: &ast::Ident, what: &str, span: Span) -> Option<Expr> {
        if !self.is_interface(q) {
            return None;
        }
        let n = self.pou_asts[q as usize].name.name.clone();
        self.error(
            diag::ITF_MISUSE,
            f.span,
            format!("the interface {n} has no {what} `{}`; use what {n} declares, or __QUERYINTERFACE to reach another interface of the instance", f.name),
        );
        Some(err(span))
    }

    /// The instance a member is used on: `THIS^`, or a place.
    fn instance_of(&mut self, base: &ast::Expr, cx: &mut Cx) -> Option<Place> {
        if let A::Deref(b) = &base.kind {
            if let Some(p) = self.this_deref(b, cx, base.span) {
                return Some(p);
            }
        }
        self.place(base, cx, false)
    }

    /// The level above the one the code was written in, and the instance (`SUPER^`).
    fn super_level(&mut self, cx: &Cx, span: Span) -> Option<(PouId, Place)> {
        let Some(t) = cx.this.clone() else {
            self.error(
                diag::OOP_MEMBER,
                span,
                "SUPER^ is the base of the function block whose code this is; use it in a FUNCTION_BLOCK that EXTENDS another",
            );
            return None;
        };
        let chain = self.oop.chain(t.owner);
        let at = chain.iter().position(|&l| l == t.origin)?;
        if at == 0 {
            let n = self.pou_asts[t.origin as usize].name.name.clone();
            self.error(
                diag::OOP_MEMBER,
                span,
                format!("{n} extends no function block, so it has no SUPER^; add EXTENDS base to its declaration"),
            );
            return None;
        }
        Some((chain[at - 1], self.this_place(cx, span)?))
    }

    /// The method `key` as seen from `level` of `owner`'s chain (its own or inherited).
    fn version_at(&self, owner: PouId, level: PouId, key: &str) -> Option<PouId> {
        let chain = self.oop.chain(owner);
        let at = chain.iter().position(|&l| l == level)?;
        chain[..=at]
            .iter()
            .rev()
            .find_map(|&l| self.oop.versions.get(&(owner, l, key.to_string())).copied())
    }

    /// PRIVATE members are used inside their block, PROTECTED ones inside it and the blocks
    /// extending it; PUBLIC and INTERNAL (one project) anywhere.
    fn may_use(&mut self, m: PouId, cx: &Cx, name: &ast::Ident) -> bool {
        let member = &self.oop.members[&m];
        let access = member.modifiers.access;
        if matches!(access, Access::Public | Access::Internal) {
            return true;
        }
        let origin = member.origin;
        let inside = cx.this.as_ref().is_some_and(|t| match access {
            Access::Private => t.origin == origin,
            _ => self.oop.chain(t.owner).contains(&origin),
        });
        if inside {
            return true;
        }
        let on = self.pou_asts[origin as usize].name.name.clone();
        self.error(
            diag::OOP_ACCESS,
            name.span,
            format!(
                "{} is {} in {on}: only {} can use it; declare it PUBLIC to call it from here",
                name.name,
                access.keyword(),
                if access == Access::Private {
                    format!("the code of {on}")
                } else {
                    format!("{on} and the blocks that extend it")
                }
            ),
        );
        false
    }

    /// A property read: a call of its GET. `None` when `e` is not a property.
    pub(crate) fn property_read(&mut self, e: &ast::Expr, cx: &mut Cx) -> Option<Expr> {
        let (found, name) = self.property_of(e, cx)?;
        let Some((prop, this)) = found else {
            return Some(err(e.span));
        };
        let Some(get) = prop.get else {
            self.error(
                diag::OOP_MEMBER,
                e.span,
                format!("property {} has no GET: it can only be assigned", name.name),
            );
            return Some(err(e.span));
        };
        if !self.may_use(get, cx, &name) {
            return Some(err(e.span));
        }
        let call = ast::Call {
            callee: Box::new(e.clone()),
            args: Vec::new(),
            span: e.span,
        };
        Some(self.fn_call_with(get, &call, cx, Some(this)))
    }

    /// A property assigned: a call of its SET with the value. `None` when `target` is not a
    /// property; `Some(None)` after an error.
    pub(crate) fn property_write(
        &mut self,
        target: &ast::Expr,
        value: &ast::Expr,
        cx: &mut Cx,
    ) -> Option<Option<Expr>> {
        let (found, name) = self.property_of(target, cx)?;
        let Some((prop, this)) = found else {
            return Some(None);
        };
        let Some(set) = prop.set else {
            self.error(
                diag::OOP_MEMBER,
                target.span,
                format!("property {} has no SET: it can only be read", name.name),
            );
            return Some(None);
        };
        if !self.may_use(set, cx, &name) {
            return Some(None);
        }
        let call = ast::Call {
            callee: Box::new(target.clone()),
            args: vec![ast::Arg {
                name: Some(name.clone()),
                output: false,
                negated: false,
                value: Some(value.clone()),
                span: value.span,
            }],
            span: target.span.to(value.span),
        };
        let x = self.fn_call_with(set, &call, cx, Some(this));
        Some((x.ty != crate::types::ids::ERROR).then_some(x))
    }

    /// The property `e` names: `P` in a block's code, `inst.P`, `THIS^.P`. The middle part is
    /// `None` after an error in the instance.
    fn property_of(
        &mut self,
        e: &ast::Expr,
        cx: &mut Cx,
    ) -> Option<(Option<(super::Prop, Place)>, ast::Ident)> {
        match &e.kind {
            A::Name(n) => {
                let key = n.key();
                if !self.oop.names.contains(&key) || cx.names.contains_key(&key) {
                    return None;
                }
                let owner = cx.this.as_ref()?.owner;
                let prop = self.oop.props.get(&(owner, key))?.clone();
                let this = self.this_place(cx, e.span)?;
                Some((Some((prop, this)), n.clone()))
            }
            A::Field(base, f) => {
                let key = f.key();
                if !self.oop.names.contains(&key) || is_deref_of(base, "SUPER") {
                    return None;
                }
                let Some(inst) = self.instance_of(base, cx) else {
                    return Some((None, f.clone()));
                };
                let q = self.owner_of_instance(inst.ty)?;
                let Some(prop) = self.oop.props.get(&(q, key)).cloned() else {
                    self.no_itf_member(q, f, "property", e.span)?;
                    return Some((None, f.clone()));
                };
                Some((Some((prop, inst)), f.clone()))
            }
            _ => None,
        }
    }
}
