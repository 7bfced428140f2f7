//! Literals typed by their context, and names: variables, enumeration values, constants.

use petriplc_iec_syntax::ast::{self, Literal};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::lexer::TimeKind;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{Expr, ExprKind, Place, Root, VarClass};
use crate::stdlib;
use crate::types::{fits, ids, Elem, Type, TypeId, TypeTable, MAX_STRING_LEN};
use crate::value::{self, Value};

use super::{err, konst};

impl<'a> Checker<'a> {
    pub(super) fn literal(&mut self, l: &Literal, span: Span) -> Expr {
        match l {
            Literal::Int { value, ty: None } => konst(Value::Int(*value), ids::INT_LIT, span),
            Literal::Real { value, ty: None } => konst(Value::Real(*value), ids::REAL_LIT, span),
            Literal::Bool { value, ty: None } => konst(Value::Int(*value as i128), ids::BOOL, span),
            Literal::Int { value, ty: Some(t) } => {
                let Some(e) = Elem::from_name(&t.name) else {
                    return self.bad_prefix(t);
                };
                if e.is_char() {
                    let (n, q, code) = if e == Elem::Char {
                        ("CHAR", "'A'", "BYTE")
                    } else {
                        ("WCHAR", "\"A\"", "WORD")
                    };
                    self.error(
                        diag::TYPE_MISMATCH,
                        span,
                        format!("{n}# types a character: write {n}#{q}; a code converts with {code}_TO_{n}({value})"),
                    );
                    return err(span);
                }
                if e.is_real() {
                    let v = *value as f64;
                    let v = if e == Elem::Real {
                        value::to_real(v)
                    } else {
                        v
                    };
                    return konst(Value::Real(v), TypeTable::elem_id(e), span);
                }
                if !e.is_integral() || e.is_duration() || e.is_date() {
                    return self.bad_prefix(t);
                }
                if !fits(*value, e) {
                    self.error(
                        diag::OUT_OF_RANGE,
                        span,
                        format!(
                            "{value} does not fit {} ({}..{})",
                            e.name(),
                            e.range().0,
                            e.range().1
                        ),
                    );
                    return err(span);
                }
                konst(Value::Int(*value), TypeTable::elem_id(e), span)
            }
            Literal::Real { value, ty: Some(t) } => match Elem::from_name(&t.name) {
                Some(Elem::Real) => konst(Value::Real(value::to_real(*value)), ids::REAL, span),
                Some(Elem::Lreal) => konst(Value::Real(*value), ids::LREAL, span),
                _ => {
                    self.error(
                        diag::TYPE_MISMATCH,
                        span,
                        format!(
                            "{}# takes an integer; a real literal is typed REAL# or LREAL#",
                            t.name
                        ),
                    );
                    err(span)
                }
            },
            Literal::Bool { value, ty: Some(t) } => match Elem::from_name(&t.name) {
                Some(Elem::Bool) => konst(Value::Int(*value as i128), ids::BOOL, span),
                _ => self.bad_prefix(t),
            },
            Literal::String { bytes, wide, ty } => self.string_literal(bytes, *wide, ty, span),
            Literal::Time { kind, nanos } => {
                let ty = match kind {
                    TimeKind::Time => ids::TIME,
                    TimeKind::LTime => ids::LTIME,
                    TimeKind::Date => ids::DATE,
                    TimeKind::Tod => ids::TOD,
                    TimeKind::Dt => ids::DT,
                };
                konst(Value::Int(*nanos), ty, span)
            }
            Literal::Enum { ty, value } => {
                let (t, _) = self.type_by_name(ty);
                match self.types.get(t).clone() {
                    Type::Enum { values, name } => {
                        match values
                            .iter()
                            .find(|(n, _)| n.eq_ignore_ascii_case(&value.name))
                        {
                            Some((_, v)) => konst(Value::Int(*v as i128), t, span),
                            None => {
                                self.error(
                                    diag::UNDECLARED,
                                    value.span,
                                    format!(
                                        "enumeration {name} has no value `{}`; its values are {}",
                                        value.name,
                                        values
                                            .iter()
                                            .map(|v| v.0.as_str())
                                            .collect::<Vec<_>>()
                                            .join(", ")
                                    ),
                                );
                                err(span)
                            }
                        }
                    }
                    Type::Error => err(span),
                    _ => {
                        self.error(
                            diag::TYPE_MISMATCH,
                            ty.span,
                            format!(
                                "`{}#{}`: {} is not an enumeration",
                                ty.name, value.name, ty.name
                            ),
                        );
                        err(span)
                    }
                }
            }
        }
    }

    /// `'…'` is a STRING, `"…"` a WSTRING (its UTF-8 text as UTF-16 units); a prefix must
    /// agree with the quotes (`STRING#'…'`, `WSTRING#"…"`).
    fn string_literal(
        &mut self,
        bytes: &[u8],
        wide: bool,
        ty: &Option<ast::Ident>,
        span: Span,
    ) -> Expr {
        if let Some(t) = ty {
            if t.is("CHAR") || t.is("WCHAR") {
                return self.char_literal(bytes, wide, t, span);
            }
            let named = if t.is("STRING") {
                Some(false)
            } else if t.is("WSTRING") {
                Some(true)
            } else {
                None
            };
            match named {
                Some(w) if w != wide => {
                    let fix = if w {
                        "a WSTRING literal is in double quotes: WSTRING#\"…\""
                    } else {
                        "a STRING literal is in single quotes: STRING#'…'"
                    };
                    self.error(
                        diag::TYPE_MISMATCH,
                        span,
                        format!("`{}#` does not type this literal; {fix}", t.name),
                    );
                    return err(span);
                }
                Some(_) => {}
                // A prefix naming no string type (`INT#'5'`) was never accepted by the
                // standard; other names are kept as before (a string type's alias).
                None if Elem::from_name(&t.name).is_some() => return self.bad_prefix(t),
                None => {}
            }
        }
        if wide {
            let units: Vec<u16> = String::from_utf8_lossy(bytes).encode_utf16().collect();
            let len = (units.len() as u32).clamp(1, MAX_STRING_LEN);
            let ty = self.types.wstring(len);
            return konst(Value::WStr(units), ty, span);
        }
        let len = (bytes.len() as u32).clamp(1, MAX_STRING_LEN);
        let ty = self.types.string(len);
        konst(Value::Str(bytes.to_vec()), ty, span)
    }

    /// `CHAR#'a'` and `WCHAR#"a"`: one character, in the quotes of its string type.
    fn char_literal(&mut self, bytes: &[u8], wide: bool, t: &ast::Ident, span: Span) -> Expr {
        let e = if t.is("CHAR") {
            Elem::Char
        } else {
            Elem::Wchar
        };
        let units: Vec<u16> = if wide {
            String::from_utf8_lossy(bytes).encode_utf16().collect()
        } else {
            bytes.iter().map(|&b| u16::from(b)).collect()
        };
        if wide != (e == Elem::Wchar) || units.len() != 1 {
            let form = if e == Elem::Char {
                "CHAR#'a' (one character in single quotes)"
            } else {
                "WCHAR#\"a\" (one character in double quotes)"
            };
            self.error(
                diag::TYPE_MISMATCH,
                span,
                format!("`{}#` types one character: write {form}", t.name),
            );
            return err(span);
        }
        konst(
            Value::Int(i128::from(units[0])),
            TypeTable::elem_id(e),
            span,
        )
    }

    fn bad_prefix(&mut self, t: &ast::Ident) -> Expr {
        self.error(
            diag::TYPE_MISMATCH,
            t.span,
            format!(
                "`{}#` cannot type this literal; write e.g. INT#5, REAL#1.5, BOOL#TRUE, WORD#16#FF",
                t.name
            ),
        );
        err(t.span)
    }

    /// A name in an expression: a variable, a constant of an enumeration, or an error.
    pub(super) fn name(&mut self, id: &ast::Ident, cx: &mut Cx, expected: Option<TypeId>) -> Expr {
        // CODESYS's THIS is a pointer to the instance (`p := THIS;`, TcUnit's FB_init
        // keeping its suite's address): where a pointer is wanted, it is ADR(THIS^).
        let wants_pointer = expected.is_some_and(|t| {
            matches!(
                self.types.get(t),
                Type::Ref {
                    kind: ast::RefKind::PointerTo,
                    ..
                }
            )
        });
        if wants_pointer && id.is("THIS") && cx.this.is_some() {
            if let Some(p) = self.this_place(cx, id.span) {
                let ty = self.types.reference(ast::RefKind::PointerTo, p.ty);
                return Expr {
                    kind: ExprKind::Ref(p),
                    ty,
                    span: id.span,
                };
            }
        }
        if let Some(place) = self.var_place(id, cx) {
            let var = self.var_of(&place, cx).clone();
            if cx.const_only {
                if !var.constant {
                    self.error(
                        diag::CONSTANT_REQUIRED,
                        id.span,
                        format!("`{}` is a variable; only constants (VAR CONSTANT, literals) can be used here", id.name),
                    );
                    return err(id.span);
                }
                let v = var
                    .init
                    .clone()
                    .unwrap_or_else(|| self.default_value(var.ty));
                return konst(v, var.ty, id.span);
            }
            if matches!(self.types.get(place.ty), Type::Fb(_)) {
                // Loading an instance is only meaningful as a place (member access).
            }
            let place = self.through_reference(place);
            return Expr {
                ty: place.ty,
                kind: ExprKind::Load(place),
                span: id.span,
            };
        }
        // An enumeration value, resolved by the expected type when several enums have it.
        if let Some(cands) = self.enum_values.get(&id.key()).cloned() {
            let pick = match expected.and_then(|t| cands.iter().find(|(ct, _)| *ct == t)) {
                Some(c) => Some(*c),
                None if cands.len() == 1 => Some(cands[0]),
                None => None,
            };
            return match pick {
                Some((t, v)) => konst(Value::Int(v as i128), t, id.span),
                None => {
                    let names: Vec<String> =
                        cands.iter().map(|(t, _)| self.types.name(*t)).collect();
                    self.error(
                        diag::UNDECLARED,
                        id.span,
                        format!(
                            "`{}` is a value of several enumerations ({}); write TYPE#{}",
                            id.name,
                            names.join(", "),
                            id.name
                        ),
                    );
                    err(id.span)
                }
            };
        }
        if cx.const_only {
            if let Some(x) = self.later_constant(id, cx) {
                return x;
            }
        }
        if id.is("NULL") {
            return self.null(id.span);
        }
        self.undeclared(id, cx);
        err(id.span)
    }

    /// A VAR CONSTANT of the POU being declared, read in a declaration above its own (an
    /// array bound: `fifo : ARRAY[0..n] OF DWORD;` before `VAR CONSTANT n : INT := 16;`), as
    /// CODESYS and TwinCAT resolve it. Its value is computed here without reporting; its own
    /// declaration reports any problem once. A constant defined through itself stays
    /// undeclared.
    fn later_constant(&mut self, id: &ast::Ident, cx: &mut Cx) -> Option<Expr> {
        let pou: &'a ast::Pou = self.pou_asts[cx.pou? as usize];
        let key = id.key();
        let decl = pou
            .var_blocks
            .iter()
            .filter(|b| b.constant && b.kind == ast::VarKind::Local)
            .flat_map(|b| &b.vars)
            .find(|d| d.names.iter().any(|n| n.key() == key))?;
        let init = decl.init.as_ref()?;
        if cx.ahead.contains(&key) {
            return None;
        }
        cx.ahead.push(key);
        let mark = self.diags.items.len();
        let (ty, _) = self.resolve_spec(&decl.ty, cx);
        let v = self.initial_value(init, ty, cx);
        self.diags.items.truncate(mark);
        cx.ahead.pop();
        Some(konst(v?, ty, id.span))
    }

    pub(super) fn undeclared(&mut self, id: &ast::Ident, cx: &Cx) {
        let key = id.key();
        let hint = if self.global_names.contains_key(&key) && cx.pou.is_some() {
            format!(
                "; it is a global variable: declare it in the POU's VAR_EXTERNAL (`{} : {};`)",
                id.name,
                self.types
                    .name(self.globals[self.global_names[&key] as usize].ty)
            )
        } else if self.pou_names.contains_key(&key) || stdlib::is_standard_function(&key) {
            "; it is a POU: call it with (…)".to_string()
        } else {
            "; declare it in VAR … END_VAR".to_string()
        };
        self.error(
            diag::UNDECLARED,
            id.span,
            format!("`{}` is not declared{hint}", id.name),
        );
    }

    /// The place a plain name denotes, if it is a variable.
    /// The type of the variable `id` names, if it names one (nothing reported).
    pub(crate) fn plain_var_type(&mut self, id: &ast::Ident, cx: &Cx) -> Option<TypeId> {
        self.var_place(id, cx).map(|p| p.ty)
    }

    pub(super) fn var_place(&mut self, id: &ast::Ident, cx: &Cx) -> Option<Place> {
        let key = id.key();
        if let Some(&v) = cx.names.get(&key) {
            let var = &cx.vars[v as usize];
            let root = match var.class {
                VarClass::External(g) => Root::Global(g),
                _ => Root::Var(v),
            };
            return Some(Place {
                root,
                path: Vec::new(),
                ty: var.ty,
                span: id.span,
            });
        }
        if let Some(p) = self.this_member_place(id, cx) {
            return Some(p);
        }
        if let Some(&g) = self.global_names.get(&key) {
            // Inside a POU only globals of a top-level VAR_GLOBAL list are visible without
            // VAR_EXTERNAL; configurations see every global.
            if cx.pou.is_none() || self.global_direct[g as usize] {
                return Some(Place {
                    root: Root::Global(g),
                    path: Vec::new(),
                    ty: self.globals[g as usize].ty,
                    span: id.span,
                });
            }
        }
        None
    }

    /// The declaration a place's root refers to (the POU's own, for an external its
    /// VAR_EXTERNAL with its constness).
    pub fn var_of<'c>(&'c self, p: &Place, cx: &'c Cx) -> &'c crate::ir::Var {
        match p.root {
            Root::Var(v) => &cx.vars[v as usize],
            Root::This | Root::Value => &self.oop.this_var,
            Root::Global(g) => {
                if let Some(v) = cx.vars.iter().find(|v| v.class == VarClass::External(g)) {
                    return v;
                }
                &self.globals[g as usize]
            }
        }
    }
}
