//! The tables of object orientation the checker keeps (`oop.rs` fills and uses them): each
//! member's owner, level and kind, the methods, versions and properties of every block, and
//! the instance code works on.

use std::collections::{HashMap, HashSet};

use petriplc_iec_syntax::ast::{self, Modifiers};
use petriplc_iec_syntax::source::Span;

use crate::ir::{PouId, Root, Var, VarClass};
use crate::types::ids;

/// What kind of member a POU of the checker is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum MemberKind {
    Method,
    Get,
    Set,
    Action,
    /// A base's body as a member of the derived block (`SUPER^()`).
    BaseBody,
}

#[derive(Clone, Debug)]
pub(crate) struct Member<'a> {
    /// The block (or program) whose instance the member works on.
    pub owner: PouId,
    /// The level of the EXTENDS chain it was written in.
    pub origin: PouId,
    pub kind: MemberKind,
    pub name: String,
    pub modifiers: Modifiers,
    /// An action's body, a base's body (the others have their own POU).
    pub body: Option<&'a ast::Body>,
    pub span: Span,
}

#[derive(Clone, Debug, Default)]
pub(crate) struct Prop {
    pub get: Option<PouId>,
    pub set: Option<PouId>,
}

/// The members of every block, found when the sources are collected.
#[derive(Debug)]
pub(crate) struct Oop<'a> {
    pub members: HashMap<PouId, Member<'a>>,
    /// (owner, NAME) → the method (or action) a call by that name runs.
    pub methods: HashMap<(PouId, String), PouId>,
    /// (owner, level, NAME) → the method as written at that level (`SUPER^.M()`).
    pub versions: HashMap<(PouId, PouId, String), PouId>,
    /// (owner, level) → that base's body as a member of the owner.
    pub bodies: HashMap<(PouId, PouId), PouId>,
    pub props: HashMap<(PouId, String), Prop>,
    /// A block's EXTENDS chain, its root first and itself last (blocks that extend).
    pub chains: HashMap<PouId, Vec<PouId>>,
    /// Every member's name, upper case: a name not here needs no lookup.
    pub names: HashSet<String>,
    /// (overridden, override) pairs, compared once their interfaces are known.
    pub overrides: Vec<(PouId, PouId)>,
    /// INTERFACE → the type of its variables (`oop/itf.rs`), and back.
    pub itf_types: HashMap<PouId, crate::types::TypeId>,
    pub itf_of: HashMap<crate::types::TypeId, PouId>,
    /// INTERFACE → its `__QUERYINTERFACE` function (`oop/query.rs`), and back.
    pub queries: HashMap<PouId, PouId>,
    pub query_of: HashMap<PouId, PouId>,
    /// What `var_of` gives for `Root::This` (the instance) and `Root::Value` (what a computed
    /// reference designates): not constant, not an input.
    pub this_var: Var,
}

impl Oop<'_> {
    pub fn new() -> Self {
        Oop {
            members: HashMap::new(),
            methods: HashMap::new(),
            versions: HashMap::new(),
            bodies: HashMap::new(),
            props: HashMap::new(),
            chains: HashMap::new(),
            names: HashSet::new(),
            overrides: Vec::new(),
            itf_types: HashMap::new(),
            itf_of: HashMap::new(),
            queries: HashMap::new(),
            query_of: HashMap::new(),
            this_var: Var {
                name: "THIS".into(),
                ty: ids::ERROR,
                class: VarClass::Local,
                init: None,
                constant: false,
                retain: false,
                location: None,
                span: Span::default(),
            },
        }
    }

    /// The levels of a block's chain (itself alone when it extends nothing).
    pub fn chain(&self, p: PouId) -> Vec<PouId> {
        self.chains.get(&p).cloned().unwrap_or_else(|| vec![p])
    }
}

/// Where the code being checked works on an instance: a block's own body or a member's.
#[derive(Clone, Debug)]
pub(crate) struct This {
    pub owner: PouId,
    /// `Root::This` in the block's own body, the THIS variable in a member.
    pub root: Root,
    /// The level the code was written in (`SUPER^` is the level above it).
    pub origin: PouId,
    /// In a method: `LEVEL.METHOD.`, the prefix of its VAR_INST in the instance.
    pub inst_prefix: Option<String>,
}
