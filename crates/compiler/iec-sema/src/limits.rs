//! How deep and how large declared types may be. Types resolve inside each other (a STRUCT's
//! fields, an ARRAY's elements, a function block's instances, a name standing for another
//! type), and every later pass — default values, the VM's layout, variables looked up by
//! path — walks them recursively: a type more than [`MAX_TYPE_DEPTH`] levels deep is refused
//! (`E116`), as is one whose values take more than [`MAX_SLOTS`] slots (`E109`), so that no
//! declaration can overflow the stack or ask for unbounded memory.
//!
//! Both are checked twice: while names resolve (the chain of types being resolved inside each
//! other, which follows the order of declaration) and on every finished type (its depth
//! counted from the leaves, whatever the order).

use petriplc_iec_syntax::depth::MAX_TYPE_DEPTH;
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Shape};
use crate::ir::{Var, VarClass};
use crate::types::{FbRef, Type, TypeId};

/// The most slots (64-bit words) a value of one type, a POU's variables or the global
/// variables may take.
pub const MAX_SLOTS: u64 = 100_000_000;

impl Checker<'_> {
    /// The shape of a resolved type (a function block's once its interface is resolved).
    pub(crate) fn shape(&self, ty: TypeId) -> Shape {
        match self.types.get(ty) {
            Type::Str { len, wide } => Shape {
                depth: 0,
                slots: 1 + (u64::from(*len) * if *wide { 2 } else { 1 }).div_ceil(8),
            },
            Type::Array { .. } | Type::Struct { .. } => {
                self.shapes.get(&ty).copied().unwrap_or(Shape::SCALAR)
            }
            Type::Fb(FbRef::User(p)) => {
                self.fb_shapes.get(*p as usize).copied().unwrap_or_default()
            }
            Type::Fb(FbRef::Native(k)) => Shape {
                depth: 1,
                slots: self.natives[*k as usize].vars.len() as u64,
            },
            _ => Shape::SCALAR,
        }
    }

    /// One level deeper into the types being resolved (a named type, a function block's
    /// interface); `false`, after the one report, when that is too deep. `name` is what is
    /// being resolved, `at` where it is used.
    pub(crate) fn enter_type(&mut self, name: &str, at: Span) -> bool {
        if self.nesting.enter() {
            self.nest_path.push(name.to_string());
            return true;
        }
        let outer = self.nest_path.first().cloned().unwrap_or_default();
        self.too_deep(
            at,
            format!(
                "`{name}` is used more than {MAX_TYPE_DEPTH} levels deep inside other types \
                 (from `{outer}` down); flatten the declarations: STRUCT fields, ARRAY elements \
                 and function block instances inside each other"
            ),
        );
        false
    }

    pub(crate) fn leave_type(&mut self) {
        self.nesting.leave();
        self.nest_path.pop();
    }

    /// E116, once per check: every level past the first adds nothing.
    fn too_deep(&mut self, at: Span, msg: String) {
        if !self.too_deep_reported {
            self.too_deep_reported = true;
            self.error(diag::TYPE_TOO_DEEP, at, msg);
        }
    }

    /// Records an array or structure's shape from its parts; `false` (reported at `at`) when
    /// it is too deep or too large, and the type must not be used.
    pub(crate) fn record_shape(
        &mut self,
        ty: TypeId,
        parts: &[TypeId],
        count: u64,
        what: &str,
        at: Span,
    ) -> bool {
        let mut depth = 0;
        let mut slots: u64 = 0;
        for &p in parts {
            let s = self.shape(p);
            depth = depth.max(s.depth);
            slots = slots.saturating_add(s.slots);
        }
        let shape = Shape {
            depth: depth + 1,
            slots: slots.saturating_mul(count),
        };
        self.shapes.insert(ty, shape);
        self.shape_fits(shape, what, at)
    }

    /// Whether a shape is within the limits (reported at `at` when not).
    fn shape_fits(&mut self, shape: Shape, what: &str, at: Span) -> bool {
        if shape.depth as usize > MAX_TYPE_DEPTH {
            self.too_deep(
                at,
                format!(
                    "{what} holds types more than {MAX_TYPE_DEPTH} levels deep (STRUCT fields, \
                     ARRAY elements and function block instances inside each other); flatten \
                     the declarations"
                ),
            );
            return false;
        }
        if shape.slots > MAX_SLOTS {
            self.error(
                diag::BAD_DECLARATION,
                at,
                format!(
                    "{what} takes {} values, more than the {MAX_SLOTS} a type or a POU's \
                     variables may take; make the arrays smaller",
                    shape.slots
                ),
            );
            return false;
        }
        true
    }

    /// A variable's type, or ERROR when it is too deep or too large (reported at `at`).
    pub(crate) fn var_type_fits(&mut self, ty: TypeId, name: &str, at: Span) -> TypeId {
        let shape = self.shape(ty);
        if self.shape_fits(shape, &format!("variable `{name}`"), at) {
            ty
        } else {
            crate::types::ids::ERROR
        }
    }

    /// The shape of variables stored together (a POU's frame, the globals): one level more
    /// than the deepest, their slots added. `false` (reported) when too large.
    pub(crate) fn frame_shape(&mut self, vars: &[Var], what: &str, at: Span) -> (Shape, bool) {
        let mut shape = Shape::default();
        for v in vars {
            let s = match v.class {
                VarClass::External(_) => continue,
                VarClass::InOut => Shape::SCALAR,
                _ => self.shape(v.ty),
            };
            shape.depth = shape.depth.max(s.depth);
            shape.slots = shape.slots.saturating_add(s.slots);
        }
        shape.depth += 1;
        // The frame itself is not a variable: only its size is checked here, the depth of
        // each variable was.
        let fits = self.shape_fits(
            Shape {
                depth: 0,
                slots: shape.slots,
            },
            what,
            at,
        );
        (shape, fits)
    }
}

#[cfg(test)]
mod tests {
    use petriplc_iec_syntax::{parser, SourceMap};

    use crate::{check, Options};

    /// The rendered diagnostics of `src` (none: the project was made).
    fn diags(src: &str) -> String {
        let mut map = SourceMap::new();
        let f = map.add("t.st", src);
        let mut d = petriplc_iec_syntax::Diagnostics::new();
        let lib = parser::parse(f, src, &mut d);
        assert!(!d.has_errors(), "syntax: {}", d.render(&map));
        let (p, diags) = check(&lib, &Options::default());
        assert_eq!(p.is_none(), diags.has_errors());
        diags.render(&map)
    }

    /// One E116, at `line`.
    fn too_deep(src: &str, line: usize) {
        let d = diags(src);
        let lines: Vec<&str> = d.lines().collect();
        assert_eq!(lines.len(), 1, "{}", lines[..lines.len().min(5)].join("\n"));
        assert!(
            lines[0].starts_with(&format!("t.st:{line}:")) && lines[0].contains("error[E116]"),
            "{d}"
        );
    }

    const MAIN: &str = "PROGRAM main VAR v : T0; END_VAR END_PROGRAM\n";

    /// `T0 … T{n-1}`, each holding the next through `holds`, declared outermost first or
    /// innermost first; the innermost holds an INT.
    fn chain(n: usize, outer_first: bool, decl: impl Fn(usize, &str) -> String) -> String {
        let mut decls: Vec<String> = (0..n)
            .map(|i| {
                let inner = if i + 1 == n {
                    "INT".to_string()
                } else {
                    format!("T{}", i + 1)
                };
                decl(i, &inner)
            })
            .collect();
        if !outer_first {
            decls.reverse();
        }
        decls.join("\n")
    }

    #[test]
    fn nesting_of_declared_types_is_bounded_in_either_order() {
        let n = 20_000;
        let structs =
            |i: usize, inner: &str| format!("TYPE T{i} : STRUCT s : {inner}; END_STRUCT; END_TYPE");
        let arrays =
            |i: usize, inner: &str| format!("TYPE T{i} : ARRAY[0..0] OF {inner}; END_TYPE");
        let aliases = |i: usize, inner: &str| format!("TYPE T{i} : {inner}; END_TYPE");
        let fbs = |i: usize, inner: &str| {
            if inner == "INT" {
                format!("FUNCTION_BLOCK T{i} VAR x : INT; END_VAR END_FUNCTION_BLOCK")
            } else {
                format!("FUNCTION_BLOCK T{i} VAR c : {inner}; END_VAR END_FUNCTION_BLOCK")
            }
        };
        // Outermost first: the chain being resolved passes the limit at the 101st.
        too_deep(&format!("{}\n{MAIN}", chain(n, true, structs)), 100);
        too_deep(&format!("{}\n{MAIN}", chain(n, true, arrays)), 100);
        too_deep(&format!("{}\n{MAIN}", chain(n, true, aliases)), 100);
        // (a function block's at its own name, where its interface is being resolved)
        too_deep(&format!("{}\n{MAIN}", chain(n, true, fbs)), 101);
        // Innermost first: each resolves at once, the depth counted from the leaves.
        too_deep(&format!("{}\n{MAIN}", chain(n, false, structs)), 101);
        too_deep(&format!("{}\n{MAIN}", chain(n, false, arrays)), 101);
        too_deep(&format!("{}\n{MAIN}", chain(n, false, fbs)), 102);
        // A long chain of names standing for one another is no nesting of storage, but it
        // is of resolution: declared innermost first, it resolves one level at a time.
        assert_eq!(diags(&format!("{}\n{MAIN}", chain(n, false, aliases))), "");
        // 100 levels are accepted.
        assert_eq!(diags(&format!("{}\n{MAIN}", chain(99, true, structs))), "");
        assert_eq!(diags(&format!("{}\n{MAIN}", chain(99, false, fbs))), "");
    }

    #[test]
    fn types_too_large_are_refused_not_laid_out() {
        let d = diags(
            "PROGRAM main VAR v : ARRAY[0..9999] OF ARRAY[0..9999] OF ARRAY[0..9999] OF INT; END_VAR END_PROGRAM",
        );
        assert!(
            d.contains(
                "error[E109]: this array takes 1000000000000 values, more than the 100000000"
            ),
            "{d}"
        );
        let d = diags(
            "TYPE S : STRUCT a, b : ARRAY[0..99999999] OF INT; END_STRUCT; END_TYPE\n\
             PROGRAM main VAR v : S; END_VAR END_PROGRAM",
        );
        assert!(
            d.contains("t.st:1:6: error[E109]: type S takes 200000000 values"),
            "{d}"
        );
        let d = diags("PROGRAM main VAR a, b : ARRAY[0..59999999] OF INT; END_VAR END_PROGRAM");
        assert!(
            d.contains("error[E109]: PROGRAM main takes 120000000 values"),
            "{d}"
        );
    }
}
