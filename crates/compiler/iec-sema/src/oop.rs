//! Object orientation (docs/iec.md, "Object orientation"), lowered to what the IR already
//! has. A method, a property's GET or SET and an action are each a FUNCTION-like POU whose
//! last variable, `THIS`, is an in-out of the instance's type: a call passes the instance by
//! reference, the member reads and writes the instance's variables through it, and its
//! own VAR are a function's (initialised at every call). A method's VAR_INST live in the
//! instance, as hidden variables named `LEVEL.METHOD.NAME`.
//!
//! EXTENDS is flattened: a derived block has its bases' variables (root first) and its own
//! copy of every member it inherits, and of each base's body (for `SUPER^()`), all checked
//! with THIS of the derived type. Calls through THIS, which CODESYS and TwinCAT dispatch to
//! the most derived override, are then resolved when the project is checked: the whole
//! project is known, so no call needs a run-time choice. A call through an INTERFACE does
//! need one: `itf.rs`.

use petriplc_iec_syntax::ast::{self, Modifiers, PouKind};
use petriplc_iec_syntax::diag;

use crate::check::{Checker, Cx, Shape};
use crate::ir::{self, PouId, Root, Var, VarClass, VarId};
use crate::types::FbRef;

pub(crate) use crate::members::{Member, MemberKind, Prop, This};

mod access;
mod itf;
mod query;
mod rules;

impl<'a> Checker<'a> {
    /// Registers every member of every block as a POU of its own (after `collect`).
    pub(crate) fn collect_members(&mut self) {
        let n = self.pou_asts.len() as PouId;
        for p in 0..n {
            let ast = self.pou_asts[p as usize];
            if ast.kind == PouKind::Function {
                if !ast.oop.is_empty() {
                    self.error(
                        diag::OOP_DECLARATION,
                        ast.name.span,
                        format!("FUNCTION {} cannot have methods, properties, actions, EXTENDS or IMPLEMENTS; make it a FUNCTION_BLOCK", ast.name.name),
                    );
                }
                continue;
            }
            let Some(chain) = self.chain_of(p) else {
                continue;
            };
            if chain.len() > 1 {
                self.oop.chains.insert(p, chain.clone());
            }
            for &level in &chain {
                let last = level == p;
                self.level_members(p, level, last);
            }
        }
        self.inherit_interface_members();
        self.collect_queries();
    }

    /// A block's EXTENDS chain, root first; `None` after an error (reported).
    fn chain_of(&mut self, p: PouId) -> Option<Vec<PouId>> {
        let mut chain = vec![p];
        let mut at = p;
        while let Some(base) = &self.pou_asts[at as usize].oop.extends {
            let here = self.pou_asts[at as usize];
            // `Library.Block`: the project is one namespace, the block is looked up by name.
            let (lib, name) = match base.name.rsplit_once('.') {
                Some((l, n)) => (Some(l), n),
                None => (None, base.name.as_str()),
            };
            let Some(&b) = self.pou_names.get(&name.to_ascii_uppercase()) else {
                let hint = match lib {
                    Some(l) => format!("it comes from the library {l}: check the library's sources together with this one"),
                    None => format!("declare FUNCTION_BLOCK {name} or correct the name"),
                };
                self.error(
                    diag::OOP_DECLARATION,
                    base.span,
                    format!(
                        "{} extends `{}`, which is not declared among these sources; {hint}",
                        here.name.name, base.name
                    ),
                );
                return None;
            };
            let bk = self.pou_asts[b as usize].kind;
            if here.kind != PouKind::FunctionBlock || bk != PouKind::FunctionBlock {
                self.error(
                    diag::OOP_DECLARATION,
                    base.span,
                    format!(
                        "only a FUNCTION_BLOCK extends another FUNCTION_BLOCK; {} is a {} and {} a {}",
                        here.name.name,
                        here.kind.keyword(),
                        base.name,
                        bk.keyword()
                    ),
                );
                return None;
            }
            if chain.contains(&b) {
                self.error(
                    diag::OOP_DECLARATION,
                    base.span,
                    format!(
                        "{} extends itself through {}; a chain of EXTENDS must end",
                        self.pou_asts[p as usize].name.name, base.name
                    ),
                );
                return None;
            }
            if self.pou_asts[b as usize].oop.modifiers.is_final {
                self.error(
                    diag::OOP_MODIFIER,
                    base.span,
                    format!(
                        "{} is FINAL and cannot be extended; remove FINAL from it or extend another block",
                        base.name
                    ),
                );
            }
            chain.push(b);
            at = b;
        }
        chain.reverse();
        Some(chain)
    }

    /// The members written at `level` of `owner`'s chain, as members of `owner`.
    fn level_members(&mut self, owner: PouId, level: PouId, last: bool) {
        let lib_pou: &'a ast::Pou = self.pou_asts[level as usize];
        let owner_name = self.pou_asts[owner as usize].name.name.clone();
        if !last {
            let m = Member {
                owner,
                origin: level,
                kind: MemberKind::BaseBody,
                name: format!("SUPER^ {}", lib_pou.name.name),
                modifiers: Modifiers::default(),
                body: Some(&lib_pou.body),
                span: lib_pou.name.span,
            };
            let id = self.add_member(lib_pou, m, format!("{owner_name}.{}", lib_pou.name.name));
            self.oop.bodies.insert((owner, level), id);
        }
        for method in &lib_pou.oop.methods {
            let key = method.pou.name.key();
            let m = Member {
                owner,
                origin: level,
                kind: MemberKind::Method,
                name: method.pou.name.name.clone(),
                modifiers: method.modifiers,
                body: None,
                span: method.pou.name.span,
            };
            let id = self.add_member(
                &method.pou,
                m,
                format!("{owner_name}.{}", method.pou.name.name),
            );
            if let Some(&prev) = self.oop.methods.get(&(owner, key.clone())) {
                self.overriding(prev, id);
            }
            self.oop.versions.insert((owner, level, key.clone()), id);
            self.oop.methods.insert((owner, key.clone()), id);
            self.oop.names.insert(key);
        }
        for prop in &lib_pou.oop.properties {
            let key = prop.name.key();
            let mut entry = Prop::default();
            for (acc, kind) in [(&prop.get, MemberKind::Get), (&prop.set, MemberKind::Set)] {
                let Some(acc) = acc else {
                    continue;
                };
                let m = Member {
                    owner,
                    origin: level,
                    kind,
                    name: prop.name.name.clone(),
                    modifiers: prop.modifiers,
                    body: None,
                    span: prop.name.span,
                };
                let what = if kind == MemberKind::Get {
                    "GET"
                } else {
                    "SET"
                };
                let id = self.add_member(acc, m, format!("{owner_name}.{}.{what}", prop.name.name));
                if kind == MemberKind::Get {
                    entry.get = Some(id);
                } else {
                    entry.set = Some(id);
                }
            }
            if let Some(prev) = self.oop.props.get(&(owner, key.clone())).cloned() {
                for (a, b) in [(prev.get, entry.get), (prev.set, entry.set)] {
                    if let (Some(a), Some(b)) = (a, b) {
                        self.overriding(a, b);
                    }
                }
                entry.get = entry.get.or(prev.get);
                entry.set = entry.set.or(prev.set);
            }
            self.oop.props.insert((owner, key.clone()), entry);
            self.oop.names.insert(key);
        }
        for action in &lib_pou.oop.actions {
            let key = action.name.key();
            let m = Member {
                owner,
                origin: level,
                kind: MemberKind::Action,
                name: action.name.name.clone(),
                modifiers: Modifiers::default(),
                body: Some(&action.body),
                span: action.name.span,
            };
            let id = self.add_member(lib_pou, m, format!("{owner_name}.{}", action.name.name));
            if last && self.oop.methods.contains_key(&(owner, key.clone())) {
                self.error(
                    diag::DUPLICATE,
                    action.name.span,
                    format!(
                        "{owner_name} has a method and an action named {}; rename one of them",
                        action.name.name
                    ),
                );
            }
            self.oop.methods.insert((owner, key.clone()), id);
            self.oop.names.insert(key);
        }
    }

    /// A member as a POU of the checker (FUNCTION-like: a static frame, no instance).
    fn add_member(&mut self, ast: &'a ast::Pou, m: Member<'a>, name: String) -> PouId {
        let id = self.pou_asts.len() as PouId;
        let body = m.body.unwrap_or(&ast.body);
        self.pou_asts.push(ast);
        self.pous.push(ir::Pou {
            name,
            kind: PouKind::Function,
            vars: Vec::new(),
            result: None,
            body: Vec::new(),
            span: m.span,
            runnable: matches!(body, ast::Body::St(_) | ast::Body::Il { .. }),
        });
        self.pou_state.push(crate::check::State::Todo);
        self.fb_shapes.push(Shape::default());
        self.oop.members.insert(id, m);
        id
    }

    /// The variable blocks `interface` reads for a POU: a member's own (its VAR_INST apart),
    /// none for an action or a base's body, every level's for a block that extends.
    pub(crate) fn blocks_of(&self, p: PouId) -> Vec<&'a ast::VarBlock> {
        let ast = self.pou_asts[p as usize];
        if let Some(m) = self.oop.members.get(&p) {
            return match m.kind {
                MemberKind::Action | MemberKind::BaseBody => Vec::new(),
                _ => ast
                    .var_blocks
                    .iter()
                    .filter(|b| b.kind != ast::VarKind::Inst)
                    .collect(),
            };
        }
        self.oop
            .chain(p)
            .iter()
            .flat_map(|&l| self.pou_asts[l as usize].var_blocks.iter())
            .collect()
    }

    /// Whether a FUNCTION-like POU has a result variable (a method, or a CODESYS/TwinCAT
    /// FUNCTION, without a type has none).
    pub(crate) fn has_result(&self, p: PouId) -> bool {
        self.pou_asts[p as usize].return_type.is_some()
    }

    /// After a block's own variables: its methods' and property accessors' VAR_INST (in
    /// the instance, named `LEVEL.METHOD.NAME`, `LEVEL.PROPERTY.GET.NAME`); after a
    /// member's: THIS.
    pub(crate) fn member_vars(
        &mut self,
        p: PouId,
        cx: &mut Cx,
        edges: &mut Vec<(VarId, ast::Edge)>,
    ) {
        if let Some(m) = self.oop.members.get(&p).cloned() {
            if self.is_interface(m.owner) {
                self.itf_member_vars(&m, cx);
                return;
            }
            let ty = self.types.fb(FbRef::User(m.owner));
            cx.vars.push(Var {
                name: "THIS".into(),
                ty,
                class: VarClass::InOut,
                init: None,
                constant: false,
                retain: false,
                location: None,
                span: m.span,
            });
            return;
        }
        let owner_ast = self.pou_asts[p as usize];
        let mut mine: Vec<(PouId, Member<'a>)> = self
            .oop
            .members
            .iter()
            .filter(|(_, m)| {
                m.owner == p
                    && matches!(
                        m.kind,
                        MemberKind::Method | MemberKind::Get | MemberKind::Set
                    )
            })
            .map(|(&id, m)| (id, m.clone()))
            .collect();
        mine.sort_by_key(|(id, _)| *id);
        for (id, m) in mine {
            let ast = self.pou_asts[id as usize];
            let prefix = self.inst_prefix(&m);
            for b in ast
                .var_blocks
                .iter()
                .filter(|b| b.kind == ast::VarKind::Inst)
            {
                let local = ast::VarBlock {
                    kind: ast::VarKind::Local,
                    ..b.clone()
                };
                let names = std::mem::take(&mut cx.names);
                let from = cx.vars.len();
                self.var_block(owner_ast, &local, cx, edges);
                cx.names = names;
                for (k, v) in cx.vars.iter_mut().enumerate().skip(from) {
                    v.name = format!("{prefix}{}", v.name);
                    cx.names.insert(v.name.to_ascii_uppercase(), k as VarId);
                }
            }
        }
    }

    pub(crate) fn inst_prefix(&self, m: &Member) -> String {
        let level = &self.pou_asts[m.origin as usize].name.name;
        match m.kind {
            MemberKind::Get => format!("{level}.{}.GET.", m.name),
            MemberKind::Set => format!("{level}.{}.SET.", m.name),
            _ => format!("{level}.{}.", m.name),
        }
    }

    /// The instance the code of POU `p` works on, if it is a block's, a program's or a
    /// member's.
    pub(crate) fn this_of(&mut self, p: PouId) -> Option<This> {
        if let Some(m) = self.oop.members.get(&p).cloned() {
            let this = self.pous[p as usize].vars.len().checked_sub(1)? as VarId;
            return Some(This {
                owner: m.owner,
                root: Root::Var(this),
                origin: m.origin,
                inst_prefix: matches!(
                    m.kind,
                    MemberKind::Method | MemberKind::Get | MemberKind::Set
                )
                .then(|| self.inst_prefix(&m)),
            });
        }
        let kind = self.pou_asts[p as usize].kind;
        (kind != PouKind::Function).then_some(This {
            owner: p,
            root: Root::This,
            origin: p,
            inst_prefix: None,
        })
    }

    /// The body checked for POU `p` (an action's or a base's for those members).
    pub(crate) fn body_of(&self, p: PouId) -> &'a ast::Body {
        match self.oop.members.get(&p).and_then(|m| m.body) {
            Some(b) => b,
            None => &self.pou_asts[p as usize].body,
        }
    }
}
