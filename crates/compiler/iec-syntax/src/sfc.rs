//! Sequential Function Charts as one small model, whatever they were written in (PLCopen XML's
//! `<SFC>` body, or the standard's text form `INITIAL_STEP … TRANSITION … ACTION` in an ST
//! POU), and the one lowering of that model to ST statements with hidden variables
//! ([`lower`]), so that both forms mean exactly the same.

use std::collections::HashSet;

use crate::ast::*;
use crate::build::{boolean, decl, name};
use crate::source::Span;

mod lower;

pub(crate) use lower::lower;

/// The hidden structure type of steps (`S.X`, `S.T`).
pub(crate) const STEP_TYPE: &str = "__SFC_STEP";

/// The hidden structure type of named actions (`A.Q`).
pub(crate) const ACTION_TYPE: &str = "__SFC_ACTION";

/// The declarations of [`STEP_TYPE`] (`X : BOOL; T : TIME;`) and [`ACTION_TYPE`]
/// (`Q : BOOL;`), added once to a source whose POUs have a chart.
pub(crate) fn types(span: Span) -> Vec<TypeDecl> {
    let ty = |n: &str, fields: &[(&str, &str)]| TypeDecl {
        name: Ident::new(n, span),
        spec: TypeSpec::Struct {
            base: None,
            fields: fields.iter().map(|(f, t)| decl(f, t, None, span)).collect(),
            span,
        },
        init: None,
        span,
    };
    vec![
        ty(STEP_TYPE, &[("X", "BOOL"), ("T", "TIME")]),
        ty(ACTION_TYPE, &[("Q", "BOOL")]),
    ]
}

/// One chart: steps, transitions in the order they are judged, actions and their
/// associations with steps.
#[derive(Default)]
pub(crate) struct Chart {
    pub steps: Vec<Step>,
    /// In the order they are judged: in a selection divergence the first that can clear
    /// does (by priority, then as the form orders them).
    pub transitions: Vec<Transition>,
    pub actions: Vec<Action>,
    pub assocs: Vec<Assoc>,
    /// Statements run after the conditions and before the evolution (networks drawn in a
    /// graphical chart that feed no condition).
    pub networks: Vec<Stmt>,
}

pub(crate) struct Step {
    pub name: Ident,
    pub initial: bool,
}

pub(crate) struct Transition {
    /// What names the transition's hidden variable (`__t<key>`).
    pub key: String,
    /// Indices into [`Chart::steps`], sorted, each once.
    pub from: Vec<usize>,
    pub to: Vec<usize>,
    /// Statements computing the condition (a transition body assigning its name, a network),
    /// run just before it is judged.
    pub prelude: Vec<Stmt>,
    pub cond: Expr,
    pub span: Span,
}

pub(crate) struct Action {
    /// A named action (an `ACTION` block, a PLCopen `<action>`): its state `name.Q` is a
    /// variable of [`ACTION_TYPE`].
    pub name: Option<Ident>,
    pub target: Target,
    pub span: Span,
}

pub(crate) enum Target {
    /// A BOOL variable set to the action's state.
    Variable(Expr),
    /// Statements run while the action is active.
    Body(Vec<Stmt>),
}

pub(crate) struct Assoc {
    /// Index into [`Chart::steps`].
    pub step: usize,
    pub qualifier: Qualifier,
    /// The duration of a timed qualifier (L, D, SD, DS, SL).
    pub duration: Option<Expr>,
    /// Index into [`Chart::actions`].
    pub action: usize,
}

/// The action qualifiers of IEC 61131-3 (table 52 of the 3rd edition).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Qualifier {
    N,
    R,
    S,
    L,
    D,
    P,
    P0,
    P1,
    Sd,
    Ds,
    Sl,
}

impl Qualifier {
    /// The qualifier of a name, in any case (`None`: not a qualifier).
    pub(crate) fn parse(s: &str) -> Option<Qualifier> {
        Some(match s.trim().to_ascii_uppercase().as_str() {
            "N" => Qualifier::N,
            "R" => Qualifier::R,
            "S" => Qualifier::S,
            "L" => Qualifier::L,
            "D" => Qualifier::D,
            "P" => Qualifier::P,
            "P0" => Qualifier::P0,
            "P1" => Qualifier::P1,
            "SD" => Qualifier::Sd,
            "DS" => Qualifier::Ds,
            "SL" => Qualifier::Sl,
            _ => return None,
        })
    }

    /// Whether the qualifier needs a duration.
    pub(crate) fn timed(self) -> bool {
        matches!(
            self,
            Qualifier::L | Qualifier::D | Qualifier::Sd | Qualifier::Ds | Qualifier::Sl
        )
    }
}

/// The qualifiers, as messages list them.
pub(crate) const QUALIFIERS: &str = "N, R, S, L, D, P, P0, P1, SD, DS or SL";

/// The hidden variables of a POU being lowered: declared once each by upper-case name.
pub(crate) struct Hidden<'h> {
    pub vars: &'h mut Vec<VarDecl>,
    pub declared: &'h mut HashSet<String>,
}

impl Hidden<'_> {
    pub(crate) fn var(&mut self, n: &str, ty: &str, init: Option<Init>, span: Span) -> Expr {
        if self.declared.insert(n.to_ascii_uppercase()) {
            self.vars.push(decl(n, ty, init, span));
        }
        name(n, span)
    }

    /// A variable of a step or action structure, `field := TRUE` initially when `set`.
    pub(crate) fn structure(&mut self, n: &Ident, ty: &str, set: Option<&str>) -> Expr {
        let span = n.span;
        let init = set.map(|f| Init::Struct {
            fields: vec![(Ident::new(f, span), Init::Expr(boolean(true, span)))],
            span,
        });
        self.var(&n.name, ty, init, span)
    }
}

/// Adds the chart types ([`types`]) to a source whose POUs have chart variables.
pub(crate) fn add_types(lib: &mut Library) {
    let first = lib.elements.iter().find_map(|e| match e {
        Element::Pou(p) => p
            .var_blocks
            .iter()
            .flat_map(|b| &b.vars)
            .find(|d| matches!(&d.ty, TypeSpec::Named(t) if t.name == STEP_TYPE))
            .map(|d| d.span),
        _ => None,
    });
    if let Some(span) = first {
        lib.elements.push(Element::Types(types(span)));
    }
}
