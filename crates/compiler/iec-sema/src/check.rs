//! The checker's driver and declarations: type declarations, POU interfaces, global
//! variables and configurations are collected here and resolved in `check/` (`resolve.rs`
//! types and values, `interface.rs` globals and interfaces, `body.rs` bodies); statements and
//! expressions are checked in `stmt.rs` and `expr.rs`.

use std::collections::{BTreeSet, HashMap, HashSet};

use petriplc_iec_syntax::ast::{self, Element, Ident, Library, PouKind};
use petriplc_iec_syntax::depth::{Depth, MAX_TYPE_DEPTH};
use petriplc_iec_syntax::diag::{self, Diagnostics};
use petriplc_iec_syntax::source::Span;

use crate::ir::{self, GlobalId, NativeSig, PouId, Var, VarId};
use crate::ops::Overflow;
use crate::stdlib;
use crate::types::{Elem, TypeId, TypeTable};
use crate::value::Value;
use crate::Options;

mod any;
mod body;
mod escape;
mod interface;
mod resolve;
mod union;

/// How many types deep a type is, and how many slots its values take (a string 1 + a slot per
/// 8 bytes, as the VM stores it; a function block instance its variables): the checker
/// keeps one per type and per function block, `limits.rs` bounds them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Shape {
    pub depth: u32,
    pub slots: u64,
}

impl Shape {
    pub(crate) const SCALAR: Shape = Shape { depth: 0, slots: 1 };
}

/// Where an expression is checked.
pub(crate) struct Cx {
    pub pou: Option<PouId>,
    pub kind: Option<PouKind>,
    pub vars: Vec<Var>,
    pub names: HashMap<String, VarId>,
    /// Loops around the statement being checked.
    pub loops: u32,
    /// FOR control variables of the loops around, which the body must not assign.
    pub for_vars: Vec<VarId>,
    /// In a declaration: only constants may be read.
    pub const_only: bool,
    /// VAR CONSTANTs of the POU being read ahead of their declaration (`later_constant`).
    pub ahead: Vec<String>,
    /// The instance the code works on, in a block's, program's or member's body (`oop.rs`).
    pub this: Option<crate::members::This>,
    /// Statements to run before the one being checked (a call given EN inside its value,
    /// `en_eno`); `None` where nothing may run first (conditions, loop bounds).
    pub pre: Option<Vec<crate::ir::Stmt>>,
}

impl Cx {
    pub fn global() -> Self {
        Cx {
            pou: None,
            kind: None,
            vars: Vec::new(),
            names: HashMap::new(),
            loops: 0,
            for_vars: Vec::new(),
            const_only: false,
            ahead: Vec::new(),
            this: None,
            pre: None,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum State {
    Todo,
    Busy,
    Done,
}

pub(crate) struct Checker<'a> {
    pub lib: &'a Library,
    pub types: TypeTable,
    pub diags: Diagnostics,
    pub(crate) type_decls: HashMap<String, &'a ast::TypeDecl>,
    type_done: HashMap<String, (TypeId, Option<Value>)>,
    type_busy: Vec<String>,
    /// Structures being resolved, by upper-case name: a reference inside one may designate
    /// it (`pNext : POINTER TO ST_NODE`).
    pub(crate) type_partial: HashMap<String, crate::types::TypeId>,
    /// Inside the target of a reference type (its type needs no size of its own).
    pub(crate) in_ref_target: u32,
    pub pou_asts: Vec<&'a ast::Pou>,
    pub pou_names: HashMap<String, PouId>,
    pub pous: Vec<ir::Pou>,
    pub(crate) pou_state: Vec<State>,
    pub natives: Vec<NativeSig>,
    pub native_names: HashMap<String, u32>,
    pub globals: Vec<Var>,
    pub global_names: HashMap<String, GlobalId>,
    /// The variables of each named global variable list (a TwinCAT GVL), by the list's name,
    /// for `LIST.x` (upper case).
    pub global_lists: HashMap<String, HashSet<String>>,
    /// Globals of a top-level VAR_GLOBAL list: visible without VAR_EXTERNAL.
    pub global_direct: Vec<bool>,
    /// Function blocks with an instance in a FUNCTION's or METHOD's frame (CODESYS,
    /// TwinCAT): their variables end with that call, so ADR of them follows a FUNCTION's
    /// rules (check/escape.rs).
    pub(crate) frame_fbs: BTreeSet<PouId>,
    /// The bodies whose frame pointers are checked once every body is (check/escape.rs).
    pub(crate) escape_todo: Vec<(PouId, ir::PouKind)>,
    /// Enumeration value names → (type, value) of every enumeration declaring them.
    pub enum_values: HashMap<String, Vec<(TypeId, i64)>>,
    /// R_EDGE / F_EDGE inputs per POU.
    edges: HashMap<PouId, Vec<(VarId, ast::Edge)>>,
    /// Calls between POUs (caller, callee, where), for recursion.
    pub calls: Vec<(Option<PouId>, PouId, Span)>,
    /// POUs on a cycle of calls through an interface (recursion.rs).
    pub(crate) guarded: BTreeSet<PouId>,
    /// Named types and function block interfaces being resolved inside each other, and
    /// their names (`limits.rs`).
    pub(crate) nesting: Depth,
    pub(crate) nest_path: Vec<String>,
    /// E116 is reported once: one cause, not a report per level.
    pub(crate) too_deep_reported: bool,
    /// Depth and size of every array and structure type.
    pub(crate) shapes: HashMap<TypeId, Shape>,
    /// Per POU: depth and size of its variables (a function block's instance).
    pub(crate) fb_shapes: Vec<Shape>,
    /// `Options::library`.
    pub(crate) library: bool,
    /// What integer overflow does (folding follows it; the project carries it to the VM).
    pub overflow: Overflow,
    /// The dialect (CODESYS and TwinCAT convert an enumeration's value to an integer).
    pub dialect: petriplc_iec_syntax::Dialect,
    /// The vendor libraries loaded (`Options::libs`).
    pub libs: Vec<String>,
    /// Methods, properties, actions and EXTENDS chains (`oop.rs`).
    pub(crate) oop: crate::members::Oop<'a>,
}

impl<'a> Checker<'a> {
    pub fn new(lib: &'a Library, options: &Options) -> Self {
        let mut natives = stdlib::standard_fbs_in(options.dialect);
        natives.extend(options.natives.iter().cloned());
        let native_names = natives
            .iter()
            .enumerate()
            .map(|(i, n)| (n.name.to_ascii_uppercase(), i as u32))
            .collect();
        Checker {
            lib,
            types: TypeTable::new(),
            diags: Diagnostics::new(),
            type_decls: HashMap::new(),
            type_done: HashMap::new(),
            type_busy: Vec::new(),
            type_partial: HashMap::new(),
            in_ref_target: 0,
            pou_asts: Vec::new(),
            pou_names: HashMap::new(),
            pous: Vec::new(),
            pou_state: Vec::new(),
            natives,
            native_names,
            globals: Vec::new(),
            global_names: HashMap::new(),
            global_lists: HashMap::new(),
            global_direct: Vec::new(),
            frame_fbs: BTreeSet::new(),
            escape_todo: Vec::new(),
            enum_values: HashMap::new(),
            edges: HashMap::new(),
            calls: Vec::new(),
            guarded: BTreeSet::new(),
            nesting: Depth::new(MAX_TYPE_DEPTH),
            nest_path: Vec::new(),
            too_deep_reported: false,
            shapes: HashMap::new(),
            fb_shapes: Vec::new(),
            library: options.library,
            overflow: options.overflow,
            dialect: options.dialect,
            libs: options.libs.clone(),
            oop: crate::members::Oop::new(),
        }
    }

    pub fn error(&mut self, code: diag::Code, span: Span, msg: impl Into<String>) {
        self.diags.error(code, span, msg);
    }

    pub fn run(mut self) -> (Option<ir::Project>, Diagnostics) {
        self.collect();
        self.collect_members();
        // Global variables first: a type's bounds may name a global constant (TwinCAT's
        // `ARRAY[1..GVL_Param.MaxN] OF …`); a global's type is resolved when it is met.
        self.collect_globals();
        // Named types, in declaration order (each resolves what it needs first).
        let names: Vec<(String, &'a ast::TypeDecl)> = self
            .lib
            .elements
            .iter()
            .filter_map(|e| match e {
                Element::Types(ds) => Some(ds),
                _ => None,
            })
            .flatten()
            .map(|d| (d.name.key(), d))
            .collect();
        for (key, d) in names {
            if self
                .type_decls
                .get(&key)
                .is_some_and(|x| std::ptr::eq(*x, d))
            {
                self.named_type(&key, d.name.span);
            }
        }
        for i in 0..self.pou_asts.len() {
            self.interface(i as PouId);
        }
        for i in 0..self.pou_asts.len() {
            self.body(i as PouId);
        }
        // Once every body is known: a pointer may go to a callee that does not keep it.
        self.all_frame_escapes();
        self.oop_rules();
        let configuration = self.configurations();
        let diags = std::mem::take(&mut self.diags).sorted();
        if diags.has_errors() {
            return (None, diags);
        }
        let project = ir::Project {
            types: self.types,
            pous: self.pous,
            natives: self.natives,
            globals: self.globals,
            configuration,
            overflow: self.overflow,
            guarded: self.guarded,
        };
        (Some(project), diags)
    }

    // ---- collection ----

    fn collect(&mut self) {
        let lib = self.lib;
        let mut seen: HashMap<String, Span> = HashMap::new();
        for el in &lib.elements {
            match el {
                Element::Types(ds) => {
                    for d in ds {
                        let key = d.name.key();
                        if Elem::from_name(&key).is_some() || key == "STRING" || key == "WSTRING" {
                            self.error(
                                diag::DUPLICATE,
                                d.name.span,
                                format!("`{}` is an elementary type and cannot be declared again; choose another name", d.name.name),
                            );
                            continue;
                        }
                        if let Some(prev) = seen.get(&key).copied() {
                            // Every source with a chart declares the same hidden chart types.
                            if !key.starts_with("__SFC_") {
                                self.duplicate(&d.name, prev);
                            }
                            continue;
                        }
                        seen.insert(key.clone(), d.name.span);
                        self.type_decls.insert(key, d);
                    }
                }
                Element::Pou(p) => {
                    let key = p.name.key();
                    if Elem::from_name(&key).is_some() || key == "STRING" || key == "WSTRING" {
                        self.error(
                            diag::DUPLICATE,
                            p.name.span,
                            format!(
                                "`{}` is an elementary type and cannot name a POU",
                                p.name.name
                            ),
                        );
                        continue;
                    }
                    if let Some(prev) = seen.get(&key).copied() {
                        self.duplicate(&p.name, prev);
                        continue;
                    }
                    seen.insert(key.clone(), p.name.span);
                    if self.native_names.contains_key(&key) || stdlib::is_standard_function(&key) {
                        self.diags.warning(
                            diag::SHADOWS_STANDARD,
                            p.name.span,
                            format!(
                                "{} {} replaces the standard {} of that name in this project",
                                p.kind.keyword(),
                                p.name.name,
                                if self.native_names.contains_key(&key) {
                                    "function block"
                                } else {
                                    "function"
                                }
                            ),
                        );
                    }
                    let id = self.pou_asts.len() as PouId;
                    self.pou_asts.push(p);
                    self.pou_names.insert(key, id);
                    self.pous.push(ir::Pou {
                        name: p.name.name.clone(),
                        kind: p.kind,
                        vars: Vec::new(),
                        result: None,
                        body: Vec::new(),
                        span: p.name.span,
                        runnable: matches!(p.body, ast::Body::St(_) | ast::Body::Il { .. }),
                    });
                    self.pou_state.push(State::Todo);
                    self.fb_shapes.push(Shape::default());
                }
                Element::Configuration(_) | Element::Globals(_) => {}
            }
        }
    }

    pub fn duplicate(&mut self, name: &Ident, prev: Span) {
        self.error(
            diag::DUPLICATE,
            name.span,
            format!(
                "`{}` is declared twice (first at byte {} of its source); rename one of them",
                name.name, prev.start
            ),
        );
    }
}
