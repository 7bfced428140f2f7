//! The rules of object orientation checked once every interface is known: an ABSTRACT block
//! is not instantiated, a FINAL method is not overridden, an override keeps its method's
//! signature, a concrete block has no ABSTRACT method left, IMPLEMENTS (`itf.rs`).

use petriplc_iec_syntax::diag;

use crate::check::Checker;
use crate::ir::{PouId, VarClass};
use crate::types::{FbRef, Type};

impl<'a> Checker<'a> {
    /// `new` overrides `prev` (both members of one block): a FINAL method stays as it is.
    pub(crate) fn overriding(&mut self, prev: PouId, new: PouId) {
        let p = &self.oop.members[&prev];
        if p.modifiers.is_final {
            let (name, span) = (p.name.clone(), self.oop.members[&new].span);
            let base = self.pou_asts[p.origin as usize].name.name.clone();
            self.error(
                diag::OOP_MODIFIER,
                span,
                format!("{name} is FINAL in {base} and cannot be overridden; rename this method or remove FINAL there"),
            );
        }
        self.oop.overrides.push((prev, new));
    }

    pub(crate) fn oop_rules(&mut self) {
        self.signatures();
        let n = self.pou_asts.len();
        for p in 0..n as PouId {
            if self.oop.members.contains_key(&p) || self.oop.query_of.contains_key(&p) {
                continue;
            }
            let ast = self.pou_asts[p as usize];
            self.implements_rules(p);
            if ast.kind == petriplc_iec_syntax::ast::PouKind::FunctionBlock
                && !ast.oop.modifiers.is_abstract
                && !ast.oop.interface
            {
                let mut left: Vec<(PouId, String)> = self
                    .oop
                    .methods
                    .iter()
                    .filter(|((o, _), m)| *o == p && self.oop.members[*m].modifiers.is_abstract)
                    .map(|(_, &m)| (m, self.oop.members[&m].name.clone()))
                    .collect();
                left.sort();
                for (_, name) in left {
                    self.error(
                        diag::OOP_MODIFIER,
                        ast.name.span,
                        format!("{} is not ABSTRACT but has the ABSTRACT method {name} without an implementation; implement {name} or declare FUNCTION_BLOCK ABSTRACT {}", ast.name.name, ast.name.name),
                    );
                }
            }
            for v in self.pous[p as usize].vars.clone() {
                if v.class == VarClass::InOut {
                    continue;
                }
                let Type::Fb(FbRef::User(q)) = *self.types.get(v.ty) else {
                    continue;
                };
                let qa = self.pou_asts[q as usize];
                if qa.oop.modifiers.is_abstract {
                    self.error(
                        diag::OOP_MODIFIER,
                        v.span,
                        format!("{} is ABSTRACT and cannot be instantiated; declare an instance of a block that extends it", qa.name.name),
                    );
                }
            }
        }
    }

    /// A member's parameters (upper-case names, kinds, type names) and result type, THIS
    /// left out: what an override and an interface's implementation keep.
    pub(crate) fn member_sig(&self, m: PouId) -> Vec<(String, VarClass, String)> {
        self.pous[m as usize]
            .vars
            .iter()
            .filter(|v| {
                matches!(
                    v.class,
                    VarClass::Input | VarClass::Output | VarClass::InOut | VarClass::Result
                ) && !v.name.eq_ignore_ascii_case("THIS")
            })
            .map(|v| {
                let name = if v.class == VarClass::Result {
                    String::new()
                } else {
                    v.name.to_ascii_uppercase()
                };
                (name, v.class, self.types.name(v.ty))
            })
            .collect()
    }

    pub(crate) fn show_sig(s: &[(String, VarClass, String)]) -> String {
        s.iter()
            .map(|(n, c, t)| match c {
                VarClass::Result => format!("result {t}"),
                _ => format!("{n} : {t}"),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// An override has its method's parameters (names, kinds, types) and result type.
    fn signatures(&mut self) {
        for (prev, new) in std::mem::take(&mut self.oop.overrides) {
            let (a, b) = (self.member_sig(prev), self.member_sig(new));
            if a != b {
                let m = &self.oop.members[&new];
                let (name, span) = (m.name.clone(), m.span);
                let base = self.pou_asts[self.oop.members[&prev].origin as usize]
                    .name
                    .name
                    .clone();
                self.error(
                    diag::OOP_SIGNATURE,
                    span,
                    format!(
                        "{name} overrides {base}'s {name} with other parameters: ({}) instead of ({}); give it the same inputs, outputs, in-outs and result type",
                        Self::show_sig(&b),
                        Self::show_sig(&a)
                    ),
                );
            }
        }
    }
}
