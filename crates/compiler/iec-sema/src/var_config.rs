//! VAR_CONFIG (IEC 61131-3 2nd edition's instance-specific initialisation): a
//! configuration gives a program instance's variable, or a variable of a function block
//! instance or structure inside it, its initial value by path
//! (`resource.instance.fb.var : TYPE := value;`). The engine writes the values into the
//! instances' initial memory (`petriplc_iec_vm`, `Engine::new`).

use petriplc_iec_syntax::ast;
use petriplc_iec_syntax::diag;

use crate::check::{Checker, Cx};
use crate::ir;
use crate::types::{FbRef, Type};

impl Checker<'_> {
    /// The VAR_CONFIG entries of `c`, resolved against the program instances `programs`.
    pub(crate) fn var_config(
        &mut self,
        c: &ast::Configuration,
        programs: &[ir::ProgramInstance],
        cx: &mut Cx,
    ) -> Vec<ir::VarConfig> {
        let mut out = Vec::new();
        for item in &c.var_config {
            if let Some(v) = self.var_config_item(c, item, programs, cx) {
                out.push(v);
            }
        }
        out
    }

    fn var_config_item(
        &mut self,
        c: &ast::Configuration,
        item: &ast::VarConfigItem,
        programs: &[ir::ProgramInstance],
        cx: &mut Cx,
    ) -> Option<ir::VarConfig> {
        if let Some(l) = &item.location {
            self.error(
                diag::UNSUPPORTED,
                l.span,
                "a location in VAR_CONFIG is not supported; write it on the variable's declaration (name AT %QB1 : BYTE;)",
            );
            return None;
        }
        // The path starts with the resource's name (the standard's form); the instance's
        // name alone is taken too, when no resource is named so.
        let mut path = item.path.as_slice();
        if path.len() > 2 && c.resources.iter().any(|r| r.name.is(&path[0].name)) {
            path = &path[1..];
        }
        let (inst, rest) = path.split_first()?;
        let Some(p) = programs.iter().find(|p| inst.is(&p.name)) else {
            self.error(
                diag::CONFIG,
                inst.span,
                format!(
                    "no program instance {} in this configuration; a VAR_CONFIG path is resource.instance.variable",
                    inst.name
                ),
            );
            return None;
        };
        if rest.is_empty() {
            self.error(
                diag::CONFIG,
                inst.span,
                "a VAR_CONFIG path names a variable of the instance: resource.instance.variable",
            );
            return None;
        }
        let mut vars: Vec<(String, crate::types::TypeId)> = self.pous[p.pou as usize]
            .vars
            .iter()
            .map(|v| (v.name.clone(), v.ty))
            .collect();
        let mut ty = None;
        let mut names = vec![p.name.clone()];
        for (k, seg) in rest.iter().enumerate() {
            let Some((name, t)) = vars
                .iter()
                .find(|(n, _)| n.eq_ignore_ascii_case(&seg.name))
                .cloned()
            else {
                self.error(
                    diag::UNDECLARED,
                    seg.span,
                    format!("`{}` is not a variable of {}", seg.name, names.join(".")),
                );
                return None;
            };
            names.push(name);
            ty = Some(t);
            if k + 1 < rest.len() {
                vars = match self.types.get(t).clone() {
                    Type::Fb(FbRef::User(q)) => {
                        self.interface(q);
                        self.pous[q as usize]
                            .vars
                            .iter()
                            .map(|v| (v.name.clone(), v.ty))
                            .collect()
                    }
                    Type::Struct { fields, .. } => {
                        fields.iter().map(|f| (f.name.clone(), f.ty)).collect()
                    }
                    _ => Vec::new(),
                };
            }
        }
        let ty = ty?;
        let (declared, _) = self.resolve_spec(&item.ty, cx);
        if declared != ty && declared != crate::types::ids::ERROR {
            let (want, got) = (self.types.name(ty), self.types.name(declared));
            self.error(
                diag::TYPE_MISMATCH,
                item.span,
                format!(
                    "{} is {want}; VAR_CONFIG declares it {got}: write its type",
                    names.join(".")
                ),
            );
            return None;
        }
        if !matches!(
            self.types.get(ty),
            Type::Elem(_) | Type::Enum { .. } | Type::Subrange { .. } | Type::Str { .. }
        ) {
            self.error(
                diag::UNSUPPORTED,
                item.span,
                format!(
                    "VAR_CONFIG sets elementary variables here; {} is {}: set its members one by one",
                    names.join("."),
                    self.types.name(ty)
                ),
            );
            return None;
        }
        let init = item.init.as_ref()?;
        let value = self.initial_value(init, ty, cx)?;
        Some(ir::VarConfig {
            path: names.join("."),
            ty,
            value,
            span: item.span,
        })
    }
}
