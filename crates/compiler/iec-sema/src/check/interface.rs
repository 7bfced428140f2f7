//! Global variables and POU interfaces: variable blocks resolved, recursive FB containment found.

use petriplc_iec_syntax::ast::{self, Element, PouKind, VarKind};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::ir::{GlobalId, PouId, Var, VarClass, VarId};
use crate::types::{ids, FbRef, Type};

use super::{Checker, Cx, State};

impl<'a> Checker<'a> {
    pub(super) fn collect_globals(&mut self) {
        let lib = self.lib;
        let mut blocks: Vec<(&ast::VarBlock, bool)> = Vec::new();
        for el in &lib.elements {
            match el {
                Element::Globals(b) => {
                    if let Some(l) = &b.list {
                        let vars = b.vars.iter().flat_map(|d| d.names.iter().map(|n| n.key()));
                        self.global_lists.entry(l.key()).or_default().extend(vars);
                    }
                    blocks.push((b, true))
                }
                Element::Configuration(c) => {
                    blocks.extend(c.globals.iter().map(|b| (b, false)));
                    for r in &c.resources {
                        blocks.extend(r.globals.iter().map(|b| (b, false)));
                    }
                }
                _ => {}
            }
        }
        // Constants first: other globals' types may use them (`ARRAY[1..MaxN] OF …`).
        blocks.sort_by_key(|(b, _)| !b.constant);
        let mut cx = Cx::global();
        for (b, direct) in blocks {
            if b.kind != VarKind::Global {
                self.error(
                    diag::UNSUPPORTED,
                    b.span,
                    format!(
                        "{} blocks are not supported in a configuration; use VAR_GLOBAL",
                        b.kind.keyword()
                    ),
                );
                continue;
            }
            for d in &b.vars {
                let (ty, def) = self.resolve_spec(&d.ty, &mut cx);
                let first = d.names.first().map_or("", |n| n.name.as_str());
                let ty = self.var_type_fits(ty, first, d.span);
                let init = match &d.init {
                    Some(i) => self.initial_value(i, ty, &mut cx),
                    None => def,
                };
                if b.constant && d.init.is_none() {
                    self.constant_without_value(d.span);
                }
                for n in &d.names {
                    let key = n.key();
                    if let Some(&g) = self.global_names.get(&key) {
                        let prev = self.globals[g as usize].span;
                        self.duplicate(n, prev);
                        continue;
                    }
                    if b.retain == ast::Retain::Retain && self.contains_reference(ty) {
                        self.retained_reference(n);
                    }
                    if d.location.is_some() && self.contains_reference(ty) {
                        self.located_reference(n);
                    }
                    let g = self.globals.len() as GlobalId;
                    self.globals.push(Var {
                        name: n.name.clone(),
                        ty,
                        class: VarClass::Global,
                        init: init.clone(),
                        constant: b.constant,
                        retain: b.retain == ast::Retain::Retain,
                        location: d.location.as_ref().map(|l| l.text.clone()),
                        span: n.span,
                    });
                    self.global_direct.push(direct);
                    self.global_names.insert(key, g);
                }
            }
        }
        if let Some(at) = self.globals.first().map(|g| g.span) {
            let vars = std::mem::take(&mut self.globals);
            self.frame_shape(&vars, "the global variables", at);
            self.globals = vars;
        }
    }

    /// The hidden global of a POU's (or a member's) `VAR_STAT` variable.
    pub(crate) fn static_name(&self, p: PouId, var: &str) -> String {
        let owner = match self.oop.members.get(&p) {
            Some(m) => self.inst_prefix(m),
            None => format!("{}.", self.pou_asts[p as usize].name.name),
        };
        format!("{owner}$stat.{var}")
    }

    /// The user function blocks whose instances a variable of type `ty` holds (itself, the
    /// elements of an array, a structure's fields).
    pub(super) fn blocks_in(&self, ty: crate::types::TypeId) -> Vec<PouId> {
        match self.types.get(ty) {
            Type::Fb(FbRef::User(q)) => vec![*q],
            Type::Array { elem, .. } => self.blocks_in(*elem),
            Type::Struct { fields, .. } => {
                fields.iter().flat_map(|f| self.blocks_in(f.ty)).collect()
            }
            _ => Vec::new(),
        }
    }

    /// A CONSTANT declared without a value holds its type's initial value (a structure's
    /// field defaults, 0…). CODESYS and TwinCAT accept it with a warning (C0228, which
    /// OSCAT's global constants switch off); so does petriplc.
    fn constant_without_value(&mut self, span: Span) {
        self.diags.warning(
            diag::CONSTANT_WITHOUT_VALUE,
            span,
            "a CONSTANT without a value holds its type's initial value; write `name : TYPE := value;` to give it one",
        );
    }

    // ---- POU interfaces ----

    /// Resolves a POU's variables (once; detects function blocks that contain themselves).
    pub fn interface(&mut self, p: PouId) {
        match self.pou_state[p as usize] {
            State::Done => return,
            State::Busy => {
                let name = self.pou_asts[p as usize].name.clone();
                self.error(
                    diag::RECURSION,
                    name.span,
                    format!("function block {} contains an instance of itself (directly or through another function block)", name.name),
                );
                return;
            }
            State::Todo => {}
        }
        let ast = self.pou_asts[p as usize];
        if !self.enter_type(&ast.name.name, ast.name.span) {
            return;
        }
        self.pou_state[p as usize] = State::Busy;
        let mut cx = Cx::global();
        cx.pou = Some(p);
        cx.kind = Some(ast.kind);
        cx.const_only = true;
        let mut result = None;
        let order = [
            VarKind::Input,
            VarKind::InOut,
            VarKind::Output,
            VarKind::Local,
            VarKind::Temp,
            VarKind::External,
            VarKind::Global,
            VarKind::Other,
            VarKind::Inst,
            VarKind::Stat,
        ];
        let member = self.oop.members.contains_key(&p);
        if ast.kind == PouKind::Function
            && !member
            && ast.return_type.is_none()
            && !self.dialect.is_codesys_family()
        {
            self.error(
                diag::SYNTAX,
                ast.name.span,
                format!(
                    "a FUNCTION declares its result type: FUNCTION {} : INT (CODESYS and TwinCAT take one without, called as a statement: --dialect codesys or twincat)",
                    ast.name.name
                ),
            );
        }
        if ast.kind == PouKind::Function && self.has_result(p) {
            let ty = match &ast.return_type {
                Some(t) => self.resolve_spec(t, &mut cx).0,
                None => ids::ERROR,
            };
            // CODESYS and TwinCAT return a copy of an instance (TcUnit's `METHOD
            // GetTestByPosition : FB_Test`): the result is an instance in the call's frame.
            if let Type::Fb(f) = *self.types.get(ty) {
                if !self.dialect.is_codesys_family() {
                    self.error(
                        diag::BAD_DECLARATION,
                        ast.name.span,
                        "a function cannot return a function block instance (CODESYS and TwinCAT return a copy of one: --dialect codesys or twincat)",
                    );
                } else if let FbRef::User(q) = f {
                    self.frame_fbs.insert(q);
                }
            }
            result = Some(0);
            cx.vars.push(Var {
                name: ast.name.name.clone(),
                ty,
                class: VarClass::Result,
                init: None,
                constant: false,
                retain: false,
                location: None,
                span: ast.name.span,
            });
            cx.names.insert(ast.name.key(), 0);
        }
        let mut edges: Vec<(VarId, ast::Edge)> = Vec::new();
        // Parameters in declaration order (positional arguments follow it), then the rest.
        let param = |k: VarKind| matches!(k, VarKind::Input | VarKind::InOut | VarKind::Output);
        let blocks = self.blocks_of(p);
        for b in blocks.iter().filter(|b| param(b.kind)) {
            self.var_block(ast, b, &mut cx, &mut edges);
        }
        for v in crate::en_eno::implicit_vars(ast) {
            cx.names.insert(v.name.clone(), cx.vars.len() as VarId);
            cx.vars.push(v);
        }
        for kind in order.into_iter().filter(|k| !param(*k)) {
            for b in blocks.iter().filter(|b| b.kind == kind) {
                self.var_block(ast, b, &mut cx, &mut edges);
            }
        }
        self.any_whole_vars(&mut cx);
        self.member_vars(p, &mut cx, &mut edges);
        let mut vars = std::mem::take(&mut cx.vars);
        // R_EDGE / F_EDGE inputs keep their previous raw value (and a copy of the raw one).
        for (v, _) in &edges {
            for suffix in ["$prev", "$raw"] {
                let name = format!("{}{suffix}", vars[*v as usize].name);
                let span = vars[*v as usize].span;
                vars.push(Var::hidden(name, ids::BOOL, span));
            }
        }
        let what = format!("{} {}", ast.kind.keyword(), ast.name.name);
        let (shape, _) = self.frame_shape(&vars, &what, ast.name.span);
        self.fb_shapes[p as usize] = shape;
        let pou = &mut self.pous[p as usize];
        pou.vars = vars;
        pou.result = result;
        self.pou_state[p as usize] = State::Done;
        self.edges.insert(p, edges);
        self.leave_type();
    }

    pub(crate) fn var_block(
        &mut self,
        pou: &ast::Pou,
        b: &ast::VarBlock,
        cx: &mut Cx,
        edges: &mut Vec<(VarId, ast::Edge)>,
    ) {
        let allowed = match pou.kind {
            PouKind::Program | PouKind::FunctionBlock => {
                !matches!(b.kind, VarKind::Global | VarKind::Other | VarKind::Inst)
            }
            PouKind::Function => matches!(
                b.kind,
                VarKind::Input
                    | VarKind::Output
                    | VarKind::InOut
                    | VarKind::Local
                    | VarKind::Temp
                    | VarKind::External
                    | VarKind::Stat
            ),
        };
        if !allowed {
            self.error(
                diag::BAD_DECLARATION,
                b.span,
                format!(
                    "{} is not allowed in a {}; {}",
                    b.kind.keyword(),
                    pou.kind.keyword(),
                    if b.kind == VarKind::Inst {
                        "VAR_INST belongs in a METHOD of a FUNCTION_BLOCK (its variables kept in the instance); use VAR here"
                    } else if b.kind == VarKind::Global {
                        "declare global variables in the CONFIGURATION (or a top-level VAR_GLOBAL list) and use VAR_EXTERNAL here"
                    } else {
                        "use VAR, VAR_INPUT, VAR_OUTPUT, VAR_IN_OUT or VAR_TEMP"
                    }
                ),
            );
            return;
        }
        if b.retain == ast::Retain::Retain
            && (matches!(b.kind, VarKind::Temp | VarKind::InOut | VarKind::External)
                || pou.kind == PouKind::Function)
        {
            self.error(
                diag::BAD_DECLARATION,
                b.span,
                "RETAIN applies to VAR, VAR_INPUT, VAR_OUTPUT and VAR_GLOBAL of programs and function blocks",
            );
        }
        // VAR_INPUT CONSTANT (CODESYS, TwinCAT: an input shown as a parameter in CFC, "no
        // distinction in text editors") and VAR_IN_OUT CONSTANT (TwinCAT) are read as VAR_INPUT
        // and VAR_IN_OUT: their value comes from the caller, so it is no compile-time constant.
        let constant = b.constant && !matches!(b.kind, VarKind::Input | VarKind::InOut);
        if constant
            && !matches!(
                b.kind,
                VarKind::Local | VarKind::External | VarKind::Global | VarKind::Stat
            )
        {
            self.error(
                diag::BAD_DECLARATION,
                b.span,
                "CONSTANT applies to VAR, VAR_INPUT, VAR_IN_OUT, VAR_EXTERNAL and VAR_GLOBAL blocks",
            );
        }
        // CODESYS and TwinCAT let a FUNCTION or METHOD hold instances, new at every call
        // (their frame is initialised at each call); a VAR_IN_OUT is the caller's instance.
        let instance_here = pou.kind != PouKind::Function
            || b.kind == VarKind::InOut
            || (self.dialect.is_codesys_family()
                && matches!(b.kind, VarKind::Local | VarKind::Temp));
        for d in &b.vars {
            if self.any_input(pou, b, d, cx) {
                continue;
            }
            let (ty, def) = if b.kind == VarKind::InOut {
                self.resolve_in_out_spec(&d.ty, cx, pou.kind != PouKind::Program)
            } else {
                self.resolve_spec(&d.ty, cx)
            };
            if pou.kind == PouKind::Function && b.kind != VarKind::InOut {
                let fbs = self.blocks_in(ty);
                self.frame_fbs.extend(fbs);
            }
            if let Type::Fb(FbRef::User(q)) = *self.types.get(ty) {
                self.interface(q);
                if !instance_here {
                    self.error(
                        diag::BAD_DECLARATION,
                        d.span,
                        "a FUNCTION has no memory between calls and cannot hold a function block instance; make it a FUNCTION_BLOCK (CODESYS and TwinCAT create one anew at every call: --dialect codesys or twincat)",
                    );
                }
            } else if matches!(self.types.get(ty), Type::Fb(_)) && !instance_here {
                self.error(
                    diag::BAD_DECLARATION,
                    d.span,
                    "a FUNCTION has no memory between calls and cannot hold a function block instance; make it a FUNCTION_BLOCK (CODESYS and TwinCAT create one anew at every call: --dialect codesys or twincat)",
                );
            }
            // A reference (VAR_EXTERNAL, VAR_IN_OUT) takes no storage of its own.
            let ty = if matches!(b.kind, VarKind::External | VarKind::InOut) {
                ty
            } else {
                let first = d.names.first().map_or("", |n| n.name.as_str());
                self.var_type_fits(ty, first, d.span)
            };
            let init = match &d.init {
                Some(i) => {
                    if b.kind == VarKind::InOut {
                        // PCWorx accepts it (OSCAT BUILDING's DIMM_2): the in-out is the
                        // caller's variable, which has its own value.
                        self.diags.warning(
                            diag::IN_OUT_INITIAL,
                            i.span(),
                            "a VAR_IN_OUT takes no initial value: it is the caller's variable, with the caller's value; this one is ignored (PCWorx accepts it so)",
                        );
                        None
                    } else if b.kind == VarKind::External {
                        self.error(
                            diag::BAD_DECLARATION,
                            i.span(),
                            format!("{} variables take no initial value: they refer to another variable", b.kind.keyword()),
                        );
                        None
                    } else {
                        self.initial_value(i, ty, cx)
                    }
                }
                None => def,
            };
            if let Some(edge) = d.edge {
                if ty != ids::BOOL || b.kind != VarKind::Input {
                    self.error(
                        diag::BAD_DECLARATION,
                        d.span,
                        "R_EDGE and F_EDGE apply to BOOL inputs (VAR_INPUT x : BOOL R_EDGE;)",
                    );
                } else if pou.kind == PouKind::Function {
                    self.error(
                        diag::BAD_DECLARATION,
                        d.span,
                        "a FUNCTION has no memory to detect edges; use a FUNCTION_BLOCK",
                    );
                } else {
                    for k in 0..d.names.len() {
                        edges.push(((cx.vars.len() + k) as VarId, edge));
                    }
                }
            }
            if constant && d.init.is_none() && matches!(b.kind, VarKind::Local | VarKind::Stat) {
                self.constant_without_value(d.span);
            }
            // TwinCAT's `AT %I*`, `%Q*`, `%M*` (an address the I/O configuration gives each
            // instance): nothing here maps it, so the variable is an ordinary one.
            let incomplete = d.location.as_ref().is_some_and(|l| l.text.ends_with('*'))
                && pou.kind != PouKind::Program
                && matches!(b.kind, VarKind::Local | VarKind::Input | VarKind::Output);
            if incomplete {
                self.diags.warning(
                    diag::LOCATION_IGNORED,
                    d.span,
                    "TwinCAT's `AT %I*`/`%Q*` is mapped by its I/O configuration, which petriplc does not read: this is an ordinary variable (on the soft PLC, bind `instance.variable` to a point with a `map` row)",
                );
            }
            let location = d.location.as_ref().filter(|_| !incomplete);
            if location.is_some() && !matches!(b.kind, VarKind::Local | VarKind::Global) {
                self.error(
                    diag::BAD_DECLARATION,
                    d.span,
                    "only VAR and VAR_GLOBAL variables can be located with AT",
                );
            }
            if location.is_some() && pou.kind != PouKind::Program {
                self.error(
                    diag::BAD_DECLARATION,
                    d.span,
                    "located variables (AT) belong in programs and configurations",
                );
            }
            for (k, n) in d.names.iter().enumerate() {
                let key = n.key();
                if cx.names.contains_key(&key) {
                    let first = cx.vars[cx.names[&key] as usize].span;
                    self.duplicate(n, first);
                    let _ = k;
                    edges.clear();
                    continue;
                }
                let class = match b.kind {
                    VarKind::Input => VarClass::Input,
                    VarKind::Output => VarClass::Output,
                    VarKind::InOut => VarClass::InOut,
                    VarKind::Temp => VarClass::Temp,
                    VarKind::External => match self.global_names.get(&key) {
                        Some(&g) => {
                            let gv = &self.globals[g as usize];
                            if gv.ty != ty && ty != ids::ERROR && gv.ty != ids::ERROR {
                                let (a, bn) = (self.types.name(ty), self.types.name(gv.ty));
                                self.error(
                                    diag::EXTERNAL_MISMATCH,
                                    n.span,
                                    format!("VAR_EXTERNAL {} is {a} but the global variable is {bn}; declare it with the global's type", n.name),
                                );
                            } else if gv.constant && !b.constant {
                                self.error(
                                    diag::EXTERNAL_MISMATCH,
                                    n.span,
                                    format!("global {} is CONSTANT; declare it in VAR_EXTERNAL CONSTANT", n.name),
                                );
                            }
                            VarClass::External(g)
                        }
                        None if self.library => {
                            // Checked as a local: nothing runs without the global (E106).
                            self.diags.warning(
                                diag::EXTERNAL_WITHOUT_GLOBAL,
                                n.span,
                                format!("VAR_EXTERNAL {} has no VAR_GLOBAL of that name among these sources; a program that uses this POU must declare `{} : {}` in a VAR_GLOBAL", n.name, n.name, self.types.name(ty)),
                            );
                            VarClass::Local
                        }
                        None => {
                            self.error(
                                diag::EXTERNAL_MISMATCH,
                                n.span,
                                format!("VAR_EXTERNAL {} has no VAR_GLOBAL of that name; declare `{} : {}` in the CONFIGURATION's VAR_GLOBAL", n.name, n.name, self.types.name(ty)),
                            );
                            VarClass::Local
                        }
                    },
                    VarKind::Stat => {
                        // One variable for every call and instance, as CODESYS and TwinCAT
                        // keep it: a hidden global named `POU.$stat.NAME`, which no
                        // identifier can name, so it clashes with nothing.
                        let p = cx.pou.expect("VAR_STAT is read in a POU");
                        let name = self.static_name(p, &n.name);
                        let g = self.globals.len() as GlobalId;
                        self.global_names.insert(name.to_ascii_uppercase(), g);
                        self.globals.push(Var {
                            name,
                            ty,
                            class: VarClass::Global,
                            init: init.clone(),
                            constant,
                            retain: b.retain == ast::Retain::Retain,
                            location: None,
                            span: n.span,
                        });
                        self.global_direct.push(false);
                        VarClass::External(g)
                    }
                    _ => VarClass::Local,
                };
                let constant = constant
                    || matches!(class, VarClass::External(g) if self.globals[g as usize].constant);
                let init = if let VarClass::External(g) = class {
                    self.globals[g as usize].init.clone()
                } else {
                    init.clone()
                };
                if b.retain == ast::Retain::Retain && self.contains_reference(ty) {
                    self.retained_reference(n);
                }
                if d.location.is_some() && self.contains_reference(ty) {
                    self.located_reference(n);
                }
                let id = cx.vars.len() as VarId;
                cx.vars.push(Var {
                    name: n.name.clone(),
                    ty,
                    class,
                    init,
                    constant,
                    retain: b.retain == ast::Retain::Retain,
                    location: location.map(|l| l.text.clone()),
                    span: n.span,
                });
                cx.names.insert(key, id);
            }
        }
    }

    fn retained_reference(&mut self, n: &ast::Ident) {
        self.error(
            diag::RETAINED_REFERENCE,
            n.span,
            format!(
                "`{}` holds a reference, which cannot be RETAIN: an address of this build means nothing after a restart; declare it without RETAIN",
                n.name
            ),
        );
    }

    fn located_reference(&mut self, n: &ast::Ident) {
        self.error(
            diag::RETAINED_REFERENCE,
            n.span,
            format!(
                "`{}` holds a reference, which cannot be located (AT %…): the process image would write addresses into it; declare it without AT",
                n.name
            ),
        );
    }
}
