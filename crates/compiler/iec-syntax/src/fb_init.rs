//! CODESYS's and TwinCAT's implicit `FB_init` calls written out as statements: the
//! declaration `fb : FB_X(10);` and every instance of a block with an `FB_init` method run
//! that method once, before the first statement of the program that holds them
//! (docs/iec.md, "FB_init").
//!
//! The lowering is on the tree, so the checker and the engine see ordinary method calls:
//! - a function block whose instance members need initialising gets a method
//!   `__FB_INIT_MEMBERS` calling, member by member, the member's own `__FB_INIT_MEMBERS`
//!   (the contained instances first, as TwinCAT orders them) and then its `FB_init`;
//! - a PROGRAM runs those calls for its own instances under a hidden flag `__FB_INIT_DONE`,
//!   once when it first runs; a FUNCTION or METHOD, whose variables are new at each call,
//!   runs them at the start of every call, as TwinCAT does.
//!
//! `FB_init` is called with `bInitRetains := FALSE, bInCopyCode := FALSE` (a start, not an
//! online change), then the declaration's arguments.

use std::collections::{BTreeMap, BTreeSet};

use crate::ast::*;
use crate::build;
use crate::diag::{self, Diagnostics};
use crate::source::Span;

/// The hidden method that initialises a block's instance members.
pub const MEMBERS_METHOD: &str = "__FB_INIT_MEMBERS";
/// A PROGRAM's flag: its instances were initialised.
pub const DONE_FLAG: &str = "__FB_INIT_DONE";

/// The library with the implicit `FB_init` calls written out; `None` when nothing calls one
/// (the tree is used as it is). Instances whose FB_init is not called yet (array elements,
/// globals) are reported (W049).
pub fn lower(lib: &Library, diags: &mut Diagnostics) -> Option<Library> {
    let blocks = Blocks::of(lib);
    if !blocks.any_init
        && !has_init_args(lib)
        && !has_runtime_init(lib, &blocks)
        && !has_inst_this(lib)
    {
        return None;
    }
    not_called(lib, &blocks, diags);
    let mut out = lib.clone();
    for el in &mut out.elements {
        let Element::Pou(p) = el else { continue };
        lower_pou(p, &blocks);
        for b in bodies_of(p) {
            lower_new(b, &blocks);
        }
        for m in members_of(p) {
            lower_inst_this(m);
        }
    }
    Some(out)
}

/// W049 for the instances with an FB_init that nothing calls (an array's elements, globals);
/// E237 for FB_init arguments given to a block without FB_init.
fn not_called(lib: &Library, blocks: &Blocks, diags: &mut Diagnostics) {
    let report = |diags: &mut Diagnostics, d: &VarDecl, what: &str| {
        diags.warning(
            diag::FB_INIT_NOT_CALLED,
            d.span,
            format!("petriplc does not call FB_init for {what} yet: the declared initial values stand; call an initialising method of your own on the first scan"),
        );
    };
    let globals = lib.elements.iter().flat_map(|el| match el {
        Element::Globals(b) => vec![b],
        Element::Configuration(c) => c
            .globals
            .iter()
            .chain(c.resources.iter().flat_map(|r| &r.globals))
            .collect(),
        _ => Vec::new(),
    });
    for b in globals {
        for d in &b.vars {
            if let TypeSpec::Named(t) = &d.ty {
                if d.fb_init.is_some() || blocks.needs(&t.key()) {
                    report(diags, d, "an instance in VAR_GLOBAL");
                }
            }
        }
    }
    let pous = lib.elements.iter().flat_map(|el| match el {
        Element::Pou(p) => std::iter::once(p)
            .chain(p.oop.methods.iter().map(|m| &m.pou))
            .collect(),
        _ => Vec::new(),
    });
    for d in pous.flat_map(|p| &p.var_blocks).flat_map(|b| &b.vars) {
        let mut ty = &d.ty;
        let mut array = false;
        while let TypeSpec::Array { elem, .. } = ty {
            ty = elem;
            array = true;
        }
        if let (true, TypeSpec::Named(t)) = (array, ty) {
            if blocks.needs(&t.key()) {
                report(diags, d, "the elements of an array");
            }
        }
        if let (Some(_), TypeSpec::Named(t)) = (&d.fb_init, &d.ty) {
            if !blocks.has_fb_init(&t.key()) {
                diags.error(
                    diag::FB_INIT_ARGUMENTS,
                    d.span,
                    format!("`{}(…)` passes arguments to FB_init, but {} is no FUNCTION_BLOCK with an FB_init method; declare `METHOD FB_init : BOOL` with VAR_INPUT bInitRetains, bInCopyCode and the parameters, or drop the parentheses", t.name, t.name),
                );
            }
        }
    }
}

fn has_runtime_init(lib: &Library, blocks: &Blocks) -> bool {
    lib.elements.iter().any(|el| match el {
        Element::Pou(p) => std::iter::once(p)
            .chain(p.oop.methods.iter().map(|m| &m.pou))
            .flat_map(|p| &p.var_blocks)
            .flat_map(|b| &b.vars)
            .any(|d| blocks.runtime_init(d).is_some()),
        _ => false,
    })
}

fn has_init_args(lib: &Library) -> bool {
    lib.elements.iter().any(|el| match el {
        Element::Pou(p) => std::iter::once(p)
            .chain(p.oop.methods.iter().map(|m| &m.pou))
            .flat_map(|p| &p.var_blocks)
            .flat_map(|b| &b.vars)
            .any(|d| d.fb_init.is_some()),
        _ => false,
    })
}

/// What the lowering knows of the project's function blocks, by upper-case name.
struct Blocks<'a> {
    fbs: BTreeMap<String, &'a Pou>,
    interfaces: BTreeSet<String>,
    any_init: bool,
}

impl<'a> Blocks<'a> {
    fn of(lib: &'a Library) -> Self {
        let mut fbs = BTreeMap::new();
        let mut interfaces = BTreeSet::new();
        for el in &lib.elements {
            if let Element::Pou(p) = el {
                if p.oop.interface {
                    interfaces.insert(p.name.key());
                } else if p.kind == PouKind::FunctionBlock {
                    fbs.entry(p.name.key()).or_insert(p);
                }
            }
        }
        let any_init = fbs.values().any(|p| own_fb_init(p));
        Blocks {
            fbs,
            interfaces,
            any_init,
        }
    }

    /// The block and its bases, most derived first (a circle stops the walk).
    fn chain(&self, key: &str) -> Vec<&'a Pou> {
        let mut out: Vec<&'a Pou> = Vec::new();
        let mut seen = BTreeSet::new();
        let mut k = key.to_string();
        while let Some(p) = self.fbs.get(&k) {
            if !seen.insert(k.clone()) {
                break;
            }
            out.push(p);
            match &p.oop.extends {
                Some(b) => k = b.key(),
                None => break,
            }
        }
        out
    }

    /// The initial value of a declaration that is computed when the program starts rather
    /// than a constant: `ADR(x)`, `REF(x)`, or an instance given to an interface variable
    /// (`log : I_Logger := fbLog;`).
    fn runtime_init<'d>(&self, d: &'d VarDecl) -> Option<&'d Expr> {
        let Some(Init::Expr(e)) = &d.init else {
            return None;
        };
        let reference = matches!(&e.kind, ExprKind::Call(c)
            if matches!(&c.callee.kind, ExprKind::Name(n) if n.is("ADR") || n.is("REF")));
        let itf = matches!(&d.ty, TypeSpec::Named(t) if self.interfaces.contains(&t.key()))
            && match &e.kind {
                ExprKind::Name(n) => !n.is("NULL"),
                ExprKind::Field(..) | ExprKind::Index(..) => true,
                _ => false,
            };
        // A METHOD's VAR computed from its instance or through a pointer (`pCurrent :
        // POINTER TO T := THIS^.pRoot;`, `pY : POINTER TO T := pX^.pRight;`).
        (reference || itf || expr_uses_this(e)).then_some(e)
    }

    /// An instance of the block needs initialising (its FB_init, or its members').
    fn needs(&self, key: &str) -> bool {
        self.fbs.contains_key(key)
            && (self.has_fb_init(key) || !self.members(key, &mut BTreeSet::new()).is_empty())
    }

    /// The block (or a base) declares FB_init.
    fn has_fb_init(&self, key: &str) -> bool {
        self.chain(key).iter().any(|p| own_fb_init(p))
    }

    /// The block's instance members (every level's) that need initialising.
    fn members(&self, key: &str, seen: &mut BTreeSet<String>) -> Vec<Init1> {
        if !seen.insert(key.to_string()) {
            return Vec::new();
        }
        let blocks: Vec<&VarBlock> = self
            .chain(key)
            .into_iter()
            .rev()
            .flat_map(|p| &p.var_blocks)
            .collect();
        let out = self.inits_of(&blocks, INSTANCE, seen);
        seen.remove(key);
        out
    }

    /// The initialisations the declarations in `blocks` need, in declaration order.
    fn inits_of(
        &self,
        blocks: &[&VarBlock],
        kinds: &[VarKind],
        seen: &mut BTreeSet<String>,
    ) -> Vec<Init1> {
        let mut out = Vec::new();
        for b in blocks {
            if !kinds.contains(&b.kind) {
                continue;
            }
            for d in &b.vars {
                if let Some(e) = self.runtime_init(d) {
                    for n in &d.names {
                        out.push(Init1 {
                            name: n.clone(),
                            nested: false,
                            fb_init: None,
                            assign: Some(e.clone()),
                            span: d.span,
                        });
                    }
                    continue;
                }
                let TypeSpec::Named(ty) = &d.ty else { continue };
                let key = ty.key();
                let fb = self.fbs.contains_key(&key);
                let nested = fb && !self.members(&key, seen).is_empty();
                // Arguments for a block without FB_init are E237 (`not_called`).
                let init = fb && self.has_fb_init(&key);
                if !nested && !init {
                    continue;
                }
                for n in &d.names {
                    out.push(Init1 {
                        name: n.clone(),
                        nested,
                        fb_init: init.then(|| d.fb_init.clone().unwrap_or_default()),
                        assign: None,
                        span: d.span,
                    });
                }
            }
        }
        out
    }
}

/// The variables an instance keeps (a PROGRAM's, a FUNCTION_BLOCK's).
const INSTANCE: &[VarKind] = &[VarKind::Local, VarKind::Input, VarKind::Output];
/// The variables a FUNCTION or METHOD has anew at each call.
const PER_CALL: &[VarKind] = &[VarKind::Local, VarKind::Temp];

/// One variable to initialise: an instance (whether its members need it, FB_init's
/// arguments) or a variable whose initial value is computed (`assign`).
struct Init1 {
    name: Ident,
    nested: bool,
    fb_init: Option<Vec<Arg>>,
    assign: Option<Expr>,
    span: Span,
}

fn own_fb_init(p: &Pou) -> bool {
    p.oop.methods.iter().any(|m| m.pou.name.is("FB_init"))
}

/// The statements that initialise `inits`: the computed initial values (as the other
/// initial values, before any FB_init), then the instances, the contained ones first.
fn calls(inits: &[Init1]) -> Vec<Stmt> {
    let mut out = Vec::new();
    for i in inits {
        if let Some(e) = &i.assign {
            out.push(build::assign(build::name(&i.name.name, i.span), e.clone()));
        }
    }
    for i in inits {
        let inst = build::name(&i.name.name, i.span);
        out.extend(init_calls(inst, i.nested, i.fb_init.as_deref(), i.span));
    }
    out
}

/// The calls that initialise the instance `inst`: its members' (`nested`), then its FB_init
/// with `bInitRetains := FALSE, bInCopyCode := FALSE` and `args` (when it has one).
fn init_calls(inst: Expr, nested: bool, fb_init: Option<&[Arg]>, span: Span) -> Vec<Stmt> {
    let mut out = Vec::new();
    if nested {
        let c = build::call(build::field(inst.clone(), MEMBERS_METHOD), Vec::new());
        out.push(call_stmt(c));
    }
    if let Some(args) = fb_init {
        let named = args.iter().any(|a| a.name.is_some());
        let flag = |n: &str| {
            let v = build::boolean(false, span);
            if named {
                build::arg(n, v)
            } else {
                Arg {
                    name: None,
                    output: false,
                    negated: false,
                    value: Some(v),
                    span,
                }
            }
        };
        let mut all = vec![flag("bInitRetains"), flag("bInCopyCode")];
        all.extend(args.iter().cloned());
        let c = build::call(build::field(inst, "FB_init"), all);
        out.push(call_stmt(c));
    }
    out
}

/// `p := __NEW(FB_X(args));` (or `__NEW(FB_X)` of a block that needs initialising), as
/// TwinCAT runs it: the new instance's members and its FB_init are initialised right after
/// it is made, `p := __NEW(FB_X); IF p <> 0 THEN p^.FB_init(FALSE, FALSE, args); END_IF`.
fn lower_new(stmts: &mut Vec<Stmt>, blocks: &Blocks) {
    let mut out = Vec::with_capacity(stmts.len());
    for mut st in std::mem::take(stmts) {
        match &mut st.kind {
            StmtKind::If {
                branches,
                else_body,
            } => {
                for (_, b) in branches {
                    lower_new(b, blocks);
                }
                if let Some(b) = else_body {
                    lower_new(b, blocks);
                }
            }
            StmtKind::Case {
                arms, else_body, ..
            } => {
                for a in arms {
                    lower_new(&mut a.body, blocks);
                }
                if let Some(b) = else_body {
                    lower_new(b, blocks);
                }
            }
            StmtKind::For { body, .. }
            | StmtKind::While { body, .. }
            | StmtKind::Repeat { body, .. } => lower_new(body, blocks),
            StmtKind::Assign { target, value } => {
                if let Some((ty, args)) = new_of_block(value, blocks) {
                    let span = st.span;
                    let key = ty.key();
                    let nested = !blocks.members(&key, &mut BTreeSet::new()).is_empty();
                    let init = blocks.has_fb_init(&key).then(|| args.unwrap_or_default());
                    let inst = Expr {
                        kind: ExprKind::Deref(Box::new(target.clone())),
                        span: target.span,
                    };
                    let calls = init_calls(inst, nested, init.as_deref(), span);
                    let made = build::bin(
                        BinaryOp::Ne,
                        target.clone(),
                        Expr {
                            kind: ExprKind::Literal(Literal::Int { value: 0, ty: None }),
                            span,
                        },
                    );
                    if let ExprKind::Call(c) = &mut value.kind {
                        c.args[0].value = Some(build::name(&ty.name, ty.span));
                    }
                    out.push(st);
                    if !calls.is_empty() {
                        out.push(build::when(made, calls));
                    }
                    continue;
                }
            }
            _ => {}
        }
        out.push(st);
    }
    *stmts = out;
}

/// `__NEW(T(args))` or `__NEW(T)` of a block `T` that needs initialising: `T`, and the
/// arguments when given.
fn new_of_block(e: &Expr, blocks: &Blocks) -> Option<(Ident, Option<Vec<Arg>>)> {
    let ExprKind::Call(c) = &e.kind else {
        return None;
    };
    if !matches!(&c.callee.kind, ExprKind::Name(n) if n.is("__NEW")) || c.args.len() != 1 {
        return None;
    }
    let (ty, args) = match &c.args[0].value.as_ref()?.kind {
        ExprKind::Name(t) => (t.clone(), None),
        ExprKind::Call(inner) => match &inner.callee.kind {
            ExprKind::Name(t) if blocks.fbs.contains_key(&t.key()) => {
                (t.clone(), Some(inner.args.clone()))
            }
            _ => return None,
        },
        _ => return None,
    };
    (blocks.needs(&ty.key()) || args.is_some()).then_some((ty, args))
}

/// The flag of a member whose VAR_INST initial values need THIS: they were set.
pub const INST_DONE_FLAG: &str = "__VAR_INST_DONE";

/// Whether a METHOD's or accessor's VAR_INST has an initial value computed from THIS.
fn has_inst_this(lib: &Library) -> bool {
    let uses = |m: &Pou| {
        m.var_blocks.iter().any(|b| {
            b.kind == VarKind::Inst
                && b.vars
                    .iter()
                    .any(|d| d.init.as_ref().is_some_and(init_uses_this))
        })
    };
    lib.elements.iter().any(|el| match el {
        Element::Pou(p) => {
            p.oop.methods.iter().any(|m| uses(&m.pou))
                || p.oop
                    .properties
                    .iter()
                    .flat_map(|pr| [&pr.get, &pr.set])
                    .flatten()
                    .any(uses)
        }
        _ => false,
    })
}

/// The methods and property accessors of the POU.
fn members_of(p: &mut Pou) -> Vec<&mut Pou> {
    let mut out: Vec<&mut Pou> = p.oop.methods.iter_mut().map(|m| &mut m.pou).collect();
    for pr in &mut p.oop.properties {
        out.extend([&mut pr.get, &mut pr.set].into_iter().flatten());
    }
    out
}

fn init_uses_this(i: &Init) -> bool {
    match i {
        Init::Expr(e) => expr_uses_this(e),
        Init::Struct { fields, .. } => fields.iter().any(|(_, i)| init_uses_this(i)),
        Init::Array { items, .. } => items
            .iter()
            .any(|it| it.value.as_ref().is_some_and(init_uses_this)),
    }
}

/// Whether an initial value reads THIS or through a pointer: it is computed where the
/// variable begins (a member's call, an instance's first run), not laid out beforehand.
fn expr_uses_this(e: &Expr) -> bool {
    match &e.kind {
        ExprKind::Name(n) => n.is("THIS"),
        // What a pointer designates is known only when the code runs (`pX^.pRight`).
        ExprKind::Deref(_) => true,
        ExprKind::Field(b, _)
        | ExprKind::Bit(b, _)
        | ExprKind::Part(b, ..)
        | ExprKind::Unary(_, b)
        | ExprKind::Paren(b) => expr_uses_this(b),
        ExprKind::Index(b, ix) => expr_uses_this(b) || ix.iter().any(expr_uses_this),
        ExprKind::Binary(_, a, b) => expr_uses_this(a) || expr_uses_this(b),
        ExprKind::Call(c) => {
            expr_uses_this(&c.callee)
                || c.args
                    .iter()
                    .any(|a| a.value.as_ref().is_some_and(expr_uses_this))
        }
        ExprKind::Literal(_) | ExprKind::Direct(_) | ExprKind::Error => false,
    }
}

/// A member's VAR_INST whose initial value needs THIS (TwinCAT-Dynamic-Collections'
/// `fbList_View : FB_View := (ipList := THIS^.fbList);`): the instance is not known when
/// the values are laid out, so they are set when the member first runs on the instance,
/// under a hidden VAR_INST flag (before any other statement of it).
fn lower_inst_this(m: &mut Pou) {
    let mut sets = Vec::new();
    for b in m.var_blocks.iter_mut().filter(|b| b.kind == VarKind::Inst) {
        for d in &mut b.vars {
            let Some(init) = d.init.take() else { continue };
            let kept = match init {
                Init::Expr(e) if expr_uses_this(&e) => {
                    for n in &d.names {
                        sets.push(build::assign(build::name(&n.name, n.span), e.clone()));
                    }
                    None
                }
                Init::Struct { fields, span } if fields.iter().any(|(_, i)| init_uses_this(i)) => {
                    let mut rest = Vec::new();
                    for (f, i) in fields {
                        match i {
                            Init::Expr(e) if expr_uses_this(&e) => {
                                for n in &d.names {
                                    let target =
                                        build::field(build::name(&n.name, n.span), &f.name);
                                    sets.push(build::assign(target, e.clone()));
                                }
                            }
                            i => rest.push((f, i)),
                        }
                    }
                    (!rest.is_empty()).then_some(Init::Struct { fields: rest, span })
                }
                other => Some(other),
            };
            d.init = kept;
        }
    }
    if sets.is_empty() {
        return;
    }
    let span = m.name.span;
    let flag = build::name(INST_DONE_FLAG, span);
    let mut body = vec![build::assign(flag.clone(), build::boolean(true, span))];
    body.extend(sets);
    m.var_blocks.push(VarBlock {
        kind: VarKind::Inst,
        constant: false,
        retain: Retain::NonRetain,
        vars: vec![build::decl(INST_DONE_FLAG, "BOOL", None, span)],
        list: None,
        span,
    });
    prepend(&mut m.body, vec![build::when(build::not(flag), body)]);
}

/// Every statement list of the POU: its body, its members'.
fn bodies_of(p: &mut Pou) -> Vec<&mut Vec<Stmt>> {
    let mut out = Vec::new();
    if let Body::St(b) = &mut p.body {
        out.push(b);
    }
    for m in &mut p.oop.methods {
        if let Body::St(b) = &mut m.pou.body {
            out.push(b);
        }
    }
    for pr in &mut p.oop.properties {
        for acc in [&mut pr.get, &mut pr.set].into_iter().flatten() {
            if let Body::St(b) = &mut acc.body {
                out.push(b);
            }
        }
    }
    for a in &mut p.oop.actions {
        if let Body::St(b) = &mut a.body {
            out.push(b);
        }
    }
    out
}

fn call_stmt(c: Call) -> Stmt {
    let span = c.span;
    Stmt {
        kind: StmtKind::Call(c),
        span,
    }
}

fn prepend(body: &mut Body, stmts: Vec<Stmt>) {
    if let Body::St(b) = body {
        b.splice(0..0, stmts);
    }
}

/// Drops the computed initial values of `kinds` blocks (their assignments are in the
/// initialisation written out).
fn strip_runtime_inits(blocks_of: &mut [VarBlock], kinds: &[VarKind], blocks: &Blocks) {
    for b in blocks_of.iter_mut().filter(|b| kinds.contains(&b.kind)) {
        for d in &mut b.vars {
            if blocks.runtime_init(d).is_some() {
                d.init = None;
            }
        }
    }
}

fn lower_pou(p: &mut Pou, blocks: &Blocks) {
    let mut seen = BTreeSet::new();
    match p.kind {
        PouKind::FunctionBlock if !p.oop.interface => {
            let members = blocks.members(&p.name.key(), &mut seen);
            if !members.is_empty() {
                let span = p.name.span;
                let body = calls(&members);
                p.oop.methods.push(Method {
                    modifiers: Modifiers::default(),
                    pou: Pou {
                        kind: PouKind::Function,
                        name: Ident::new(MEMBERS_METHOD, span),
                        return_type: None,
                        var_blocks: Vec::new(),
                        body: Body::St(body),
                        span,
                        oop: Box::default(),
                    },
                });
            }
        }
        PouKind::Program => {
            let own: Vec<&VarBlock> = p.var_blocks.iter().collect();
            let inits = blocks.inits_of(&own, INSTANCE, &mut seen);
            if !inits.is_empty() && matches!(p.body, Body::St(_)) {
                let span = p.name.span;
                let flag = build::name(DONE_FLAG, span);
                let mut body = vec![build::assign(flag.clone(), build::boolean(true, span))];
                body.extend(calls(&inits));
                p.var_blocks.push(VarBlock {
                    kind: VarKind::Local,
                    constant: false,
                    retain: Retain::NonRetain,
                    vars: vec![build::decl(DONE_FLAG, "BOOL", None, span)],
                    list: None,
                    span,
                });
                prepend(&mut p.body, vec![build::when(build::not(flag), body)]);
            }
        }
        PouKind::Function => {
            let own: Vec<&VarBlock> = p.var_blocks.iter().collect();
            let inits = blocks.inits_of(&own, PER_CALL, &mut seen);
            prepend(&mut p.body, calls(&inits));
        }
        PouKind::FunctionBlock => {}
    }
    for m in &mut p.oop.methods {
        if m.pou.name.is(MEMBERS_METHOD) {
            continue;
        }
        let own: Vec<&VarBlock> = m.pou.var_blocks.iter().collect();
        let inits = blocks.inits_of(&own, PER_CALL, &mut BTreeSet::new());
        prepend(&mut m.pou.body, calls(&inits));
        strip_runtime_inits(&mut m.pou.var_blocks, PER_CALL, blocks);
    }
    // A body the statements cannot be put before (IL, a chart read elsewhere) keeps its
    // initial values, which the checker then reports.
    if matches!(p.body, Body::St(_)) || p.kind == PouKind::FunctionBlock {
        let kinds = match p.kind {
            PouKind::Function => PER_CALL,
            _ => INSTANCE,
        };
        strip_runtime_inits(&mut p.var_blocks, kinds, blocks);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::SourceMap;

    /// Lowers `src` and prints each POU's statements (`calls`), or `-` when nothing is
    /// lowered, and the diagnostics after.
    fn check(src: &str, expect: &str) {
        let mut map = SourceMap::new();
        let f = map.add("t.st", src);
        let mut d = Diagnostics::new();
        let lib = crate::parse(f, src, &mut d);
        assert!(!d.has_errors(), "{}", d.render(&map));
        let got = match lower(&lib, &mut d) {
            None => "-\n".to_string(),
            Some(out) => {
                let mut s = String::new();
                for el in &out.elements {
                    let Element::Pou(p) = el else { continue };
                    for q in std::iter::once(p).chain(p.oop.methods.iter().map(|m| &m.pou)) {
                        let Body::St(b) = &q.body else { continue };
                        s.push_str(&format!("{}: {}\n", q.name.name, shape(b, src)));
                    }
                }
                s
            }
        };
        let got = got + &d.render(&map);
        assert_eq!(got.trim_end(), expect.trim_end(), "{src}");
    }

    fn shape(b: &[Stmt], src: &str) -> String {
        let text = |e: &Expr| match &e.kind {
            ExprKind::Field(base, f) => format!("{}.{}", text_of(base), f.name),
            _ => text_of(e),
        };
        fn text_of(e: &Expr) -> String {
            match &e.kind {
                ExprKind::Name(i) => i.name.clone(),
                ExprKind::Literal(Literal::Bool { value, .. }) => value.to_string(),
                _ => "…".into(),
            }
        }
        let _ = src;
        b.iter()
            .map(|s| match &s.kind {
                StmtKind::Call(c) => {
                    let args: Vec<String> = c
                        .args
                        .iter()
                        .map(|a| {
                            let v = a.value.as_ref().map_or("?".into(), text_of);
                            match &a.name {
                                Some(n) => format!("{}:={v}", n.name),
                                None => v,
                            }
                        })
                        .collect();
                    format!("{}({})", text(&c.callee), args.join(","))
                }
                StmtKind::If { branches, .. } => {
                    format!("IF[{}]", shape(&branches[0].1, src))
                }
                StmtKind::Assign { target, .. } => format!("{} :=", text(target)),
                _ => "stmt".into(),
            })
            .collect::<Vec<_>>()
            .join("; ")
    }

    const INNER: &str = "FUNCTION_BLOCK I\nVAR n : INT; END_VAR\nMETHOD FB_init : BOOL\n\
                         VAR_INPUT bInitRetains : BOOL; bInCopyCode : BOOL; k : INT; END_VAR\n\
                         n := k;\nEND_METHOD\nEND_FUNCTION_BLOCK\n";

    #[test]
    fn nothing_is_lowered_without_fb_init() {
        check(
            "FUNCTION_BLOCK A\nEND_FUNCTION_BLOCK\nPROGRAM p\nVAR a : A; END_VAR\nEND_PROGRAM",
            "-",
        );
    }

    #[test]
    fn a_program_initialises_its_instances_once_inner_first() {
        let src = format!(
            "{INNER}FUNCTION_BLOCK O\nVAR x : I(1); y : I(k := 2); t : INT; END_VAR\n\
             END_FUNCTION_BLOCK\nPROGRAM p\nVAR o : O; i : I(3); END_VAR\nEND_PROGRAM"
        );
        check(
            &src,
            "I: \n\
             FB_init: n :=\n\
             O: \n\
             __FB_INIT_MEMBERS: x.FB_init(false,false,…); y.FB_init(bInitRetains:=false,bInCopyCode:=false,k:=…)\n\
             p: IF[__FB_INIT_DONE :=; o.__FB_INIT_MEMBERS(); i.FB_init(false,false,…)]",
        );
    }

    #[test]
    fn a_function_initialises_its_instances_at_every_call() {
        let src =
            format!("{INNER}FUNCTION f : INT\nVAR i : I(4); END_VAR\nf := i.n;\nEND_FUNCTION");
        check(
            &src,
            "I: \nFB_init: n :=\nf: i.FB_init(false,false,…); f :=",
        );
    }

    #[test]
    fn what_is_not_called_is_reported() {
        let src = format!(
            "{INNER}FUNCTION_BLOCK B\nEND_FUNCTION_BLOCK\nVAR_GLOBAL g : I; END_VAR\n\
             PROGRAM p\nVAR a : ARRAY[1..2] OF I; b : B(1); END_VAR\nEND_PROGRAM"
        );
        check(
            &src,
            "I: \nFB_init: n :=\nB: \np: \n\
             t.st:10:12: warning[W049]: petriplc does not call FB_init for an instance in VAR_GLOBAL yet: the declared initial values stand; call an initialising method of your own on the first scan\n\
             t.st:12:5: warning[W049]: petriplc does not call FB_init for the elements of an array yet: the declared initial values stand; call an initialising method of your own on the first scan\n\
             t.st:12:27: error[E237]: `B(…)` passes arguments to FB_init, but B is no FUNCTION_BLOCK with an FB_init method; declare `METHOD FB_init : BOOL` with VAR_INPUT bInitRetains, bInCopyCode and the parameters, or drop the parentheses",
        );
    }

    #[test]
    fn computed_initial_values_are_set_before_fb_init() {
        let src = format!(
            "{INNER}INTERFACE I_X\nEND_INTERFACE\n\
             PROGRAM p\nVAR c : INT; i : I(1); r : REF_TO INT := REF(c); x : I_X := i; \
             n : I_X := NULL; END_VAR\nEND_PROGRAM"
        );
        check(
            &src,
            "I: \nFB_init: n :=\n\
             I_X: \n\
             p: IF[__FB_INIT_DONE :=; r :=; x :=; i.FB_init(false,false,…)]",
        );
    }
}
