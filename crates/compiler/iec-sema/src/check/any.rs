//! CODESYS's and TwinCAT's ANY inputs: three inputs of the callee (`x.pValue`, `x.diSize`,
//! `x.TypeClass`, the fields of `__SYSTEM.AnyType`) that a call gives from its argument
//! (expr/call.rs, `bind_any`), and, where the library declares AnyType (twincat), the input
//! whole as a value of that structure (`x` passed to a `T_Generic` input, assigned, passed on
//! to another ANY input).

use petriplc_iec_syntax::ast::{self, PouKind, VarKind};
use petriplc_iec_syntax::source::Span;

use crate::ir::{self, PouId, Var, VarClass, VarId};
use crate::types::{ids, Type, TypeId};

use super::{Checker, Cx};

/// The three fields of AnyType, in its order, as the inputs are named after them.
const ANY_FIELDS: [&str; 3] = ["pValue", "diSize", "TypeClass"];

impl Checker<'_> {
    /// CODESYS's and TwinCAT's `VAR_INPUT x : ANY` (TcUnit's `AssertEquals(Expected : ANY;
    /// …)`): an input of any type, which the callee reads through the fields of
    /// `__SYSTEM.AnyType` (`x.pValue`, `x.diSize`, `x.TypeClass`). Each field is an input of
    /// its own, named `x.FIELD` (a name no declaration can take); the call gives the three
    /// from its argument (`Checker::bind_any`). Whether `d` was one.
    pub(super) fn any_input(
        &mut self,
        pou: &ast::Pou,
        b: &ast::VarBlock,
        d: &ast::VarDecl,
        cx: &mut Cx,
    ) -> bool {
        let ast::TypeSpec::Named(t) = &d.ty else {
            return false;
        };
        if !t.is("ANY") || b.kind != VarKind::Input || !self.dialect.is_codesys_family() {
            return false;
        }
        if pou.kind == PouKind::Program {
            return false;
        }
        let fields = self.any_fields(t.span);
        for n in &d.names {
            if cx.names.contains_key(&format!("{}.PVALUE", n.key()))
                || cx.names.contains_key(&n.key())
            {
                let first = cx.vars[cx.names.get(&n.key()).copied().unwrap_or(0) as usize].span;
                self.duplicate(n, first);
                continue;
            }
            for (f, ty) in fields {
                let name = format!("{}.{f}", n.name);
                cx.names
                    .insert(name.to_ascii_uppercase(), cx.vars.len() as VarId);
                cx.vars.push(Var {
                    class: VarClass::Input,
                    ..Var::hidden(name, ty, n.span)
                });
            }
        }
        true
    }

    /// The three inputs an ANY input is, by the field of AnyType each holds, with their
    /// types: POINTER TO BYTE, DINT and the type class (`any_class_ty`).
    pub(crate) fn any_fields(&mut self, span: Span) -> [(&'static str, TypeId); 3] {
        let [value, size, class] = ANY_FIELDS;
        [
            (
                value,
                self.types.reference(ast::RefKind::PointerTo, ids::BYTE),
            ),
            (size, ids::DINT),
            (class, self.any_class_ty(span)),
        ]
    }

    /// The type of an ANY input's `TypeClass`: the library's TYPE_CLASS when it is loaded
    /// (twincat), else its number.
    pub(crate) fn any_class_ty(&mut self, span: Span) -> TypeId {
        match self.type_decls.contains_key("TYPE_CLASS") {
            true => self.type_by_name(&ast::Ident::new("TYPE_CLASS", span)).0,
            false => ids::UDINT,
        }
    }

    /// For each ANY input `x` of a POU whose dialect's library declares `AnyType`: a
    /// VAR_TEMP `x` of that type, which the body's prologue fills from the three inputs
    /// ([`Checker::any_prologue`]), so that `x` names the input whole.
    pub(super) fn any_whole_vars(&mut self, cx: &mut Cx) {
        if !self.type_decls.contains_key("ANYTYPE") {
            return;
        }
        let bases: Vec<(String, Span)> = cx
            .vars
            .iter()
            .filter(|v| v.class == VarClass::Input)
            .filter_map(|v| Some((v.name.strip_suffix(".pValue")?.to_string(), v.span)))
            .collect();
        if bases.is_empty() {
            return;
        }
        let (ty, _) = self.type_by_name(&ast::Ident::new("AnyType", Span::default()));
        for (name, span) in bases {
            if cx.names.contains_key(&name.to_ascii_uppercase()) {
                continue;
            }
            cx.names
                .insert(name.to_ascii_uppercase(), cx.vars.len() as VarId);
            cx.vars.push(Var {
                class: VarClass::Temp,
                ..Var::hidden(name, ty, span)
            });
        }
    }

    /// `x.pValue := <input x.pValue>; …` for each ANY input's whole value (`any_whole_vars`).
    pub(super) fn any_prologue(&self, p: PouId, span: Span) -> Vec<ir::Stmt> {
        let vars = &self.pous[p as usize].vars;
        let mut out = Vec::new();
        for (w, whole) in vars.iter().enumerate() {
            if whole.class != VarClass::Temp {
                continue;
            }
            let Type::Struct { fields, .. } = self.types.get(whole.ty) else {
                continue;
            };
            for (k, f) in ANY_FIELDS.iter().enumerate() {
                let part = format!("{}.{f}", whole.name);
                let Some(src) = vars
                    .iter()
                    .position(|v| v.class == VarClass::Input && v.name == part)
                else {
                    break;
                };
                let Some(field) = fields.get(k).filter(|x| x.name.eq_ignore_ascii_case(f)) else {
                    break;
                };
                let ty = vars[src].ty;
                if field.ty != ty {
                    break;
                }
                out.push(ir::Stmt {
                    kind: ir::StmtKind::Assign {
                        target: ir::Place {
                            root: ir::Root::Var(w as VarId),
                            path: vec![ir::Step::Field(k as u32)],
                            ty,
                            span,
                        },
                        value: ir::Expr {
                            kind: ir::ExprKind::Load(ir::Place {
                                root: ir::Root::Var(src as VarId),
                                path: Vec::new(),
                                ty,
                                span,
                            }),
                            ty,
                            span,
                        },
                    },
                    span,
                });
            }
        }
        out
    }
}
