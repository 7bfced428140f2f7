//! The standard library's names and the interfaces of the standard function blocks.
//!
//! Standard functions are typed in `expr.rs` (their rules are generic: ANY_NUM, ANY_BIT…);
//! the standard function blocks are native: the checker sees their interface here, the VM
//! runs them.

use petriplc_iec_syntax::Dialect;

use crate::ir::{NativeSig, NativeVar, NativeVarKind};
use crate::types::Elem;
use crate::value::Value;

/// The standard functions by name (conversions `*_TO_*`, `TO_*` and `TRUNC_*` are recognised
/// by their pattern).
pub const STANDARD_FUNCTIONS: &[&str] = &[
    "ABS",
    "SQRT",
    "LN",
    "LOG",
    "EXP",
    "SIN",
    "COS",
    "TAN",
    "ASIN",
    "ACOS",
    "ATAN",
    "ATAN2",
    "EXPT",
    "ADD",
    "SUB",
    "MUL",
    "DIV",
    "MOD",
    "MOVE",
    "SEL",
    "MAX",
    "MIN",
    "LIMIT",
    "MUX",
    "GT",
    "GE",
    "EQ",
    "LE",
    "LT",
    "NE",
    "SHL",
    "SHR",
    "ROL",
    "ROR",
    "AND",
    "OR",
    "XOR",
    "NOT",
    "LEN",
    "LEFT",
    "RIGHT",
    "MID",
    "CONCAT",
    "INSERT",
    "DELETE",
    "REPLACE",
    "FIND",
    "TRUNC",
    "ADD_TIME",
    "SUB_TIME",
    "MUL_TIME",
    "DIV_TIME",
    "MULTIME",
    "DIVTIME",
    "ADD_TOD_TIME",
    "ADD_DT_TIME",
    "SUB_TOD_TIME",
    "SUB_DT_TIME",
    "SUB_DATE_DATE",
    "SUB_TOD_TOD",
    "SUB_DT_DT",
    "CONCAT_DATE_TOD",
    "DT_TO_TOD",
    "DT_TO_DATE",
    "ADD_LTIME",
    "SUB_LTIME",
    "MUL_LTIME",
    "DIV_LTIME",
];

/// The overloaded standard functions that also have typed forms `F_T` (the standard's
/// "typed" functions, as matiec has them: `SHR_DWORD`, `LIMIT_INT`, `EQ_STRING`…).
const TYPED_GENERICS: &[&str] = &[
    "ABS", "SQRT", "LN", "LOG", "EXP", "SIN", "COS", "TAN", "ASIN", "ACOS", "ATAN", "ATAN2",
    "EXPT", "ADD", "SUB", "MUL", "DIV", "MOD", "MOVE", "SEL", "MAX", "MIN", "LIMIT", "MUX", "GT",
    "GE", "EQ", "LE", "LT", "NE", "SHL", "SHR", "ROL", "ROR", "AND", "OR", "XOR", "NOT",
];

/// Whether `name` is a standard function (case-insensitive), conversions and typed forms
/// included.
pub fn is_standard_function(name: &str) -> bool {
    let n = name.to_ascii_uppercase();
    // A conversion counts when it names types (`BYTE_TO_HEXSTR` of Tc2_Utilities is none).
    let ty = |t: &str| Elem::from_name(t).is_some() || t == "STRING" || t == "WSTRING";
    let conversion =
        conversion_of(&n).is_some_and(|(from, to, _)| from.as_deref().is_none_or(ty) && ty(&to));
    STANDARD_FUNCTIONS.contains(&n.as_str())
        || conversion
        || typed_form(&n).is_some()
        || bcd_conversion(&n).is_some()
}

/// A typed form `F_T` of an overloaded standard function: (F, T), T an elementary type name
/// or STRING. The names the standard lists whole (`ADD_TIME`, `SUB_DATE_DATE`…) are not
/// typed forms.
pub(crate) fn typed_form(name: &str) -> Option<(&'static str, String)> {
    let n = name.to_ascii_uppercase();
    if STANDARD_FUNCTIONS.contains(&n.as_str()) {
        return None;
    }
    let (f, t) = n.split_once('_')?;
    let generic = TYPED_GENERICS.iter().find(|g| **g == f)?;
    (Elem::from_name(t).is_some() || t == "STRING" || t == "WSTRING")
        .then(|| (*generic, t.to_string()))
}

/// A BCD conversion's name: `WORD_BCD_TO_INT` and `BCD_TO_INT` decode, `INT_TO_BCD_WORD`
/// and `INT_TO_BCD` encode (the standard's table of BCD conversions); `None` where the
/// name leaves the type to the argument or the context.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct BcdName {
    pub decode: bool,
    pub from: Option<String>,
    pub to: Option<String>,
}

pub(crate) fn bcd_conversion(name: &str) -> Option<BcdName> {
    let n = name.to_ascii_uppercase();
    let some = |s: &str| Some(s.to_string());
    let (decode, from, to) = if let Some(to) = n.strip_prefix("BCD_TO_") {
        (true, None, some(to))
    } else if let Some((from, to)) = n.split_once("_BCD_TO_") {
        (true, some(from), some(to))
    } else if let Some(from) = n.strip_suffix("_TO_BCD") {
        (false, some(from), None)
    } else if let Some((from, to)) = n.split_once("_TO_BCD_") {
        (false, some(from), some(to))
    } else {
        return None;
    };
    Some(BcdName { decode, from, to })
}

/// Whether the parameter at `index` of the typed form of `generic` has the form's type
/// (the others keep theirs: a shift's N, SEL's G, MUX's K, EXPT's exponent).
pub(crate) fn typed_param(generic: &str, index: usize) -> bool {
    match generic {
        "SHL" | "SHR" | "ROL" | "ROR" | "EXPT" => index == 0,
        "SEL" | "MUX" => index >= 1,
        _ => true,
    }
}

/// The target of a conversion function name: `INT_TO_REAL` → (Some(INT), "REAL"),
/// `TO_REAL` → (None, "REAL"), `TRUNC_INT`/`REAL_TRUNC_INT` → truncations.
pub(crate) fn conversion_of(name: &str) -> Option<(Option<String>, String, bool)> {
    let n = name.to_ascii_uppercase();
    // CODESYS's ANY_TO_<type> and ANY_NUM_TO_<type> are the standard's TO_<type>.
    for generic in ["TO_", "ANY_TO_", "ANY_NUM_TO_"] {
        if let Some(rest) = n.strip_prefix(generic) {
            return Some((None, rest.to_string(), false));
        }
    }
    if let Some(rest) = n.strip_prefix("TRUNC_") {
        return Some((None, rest.to_string(), true));
    }
    if let Some((from, to)) = n.split_once("_TRUNC_") {
        return Some((Some(from.to_string()), to.to_string(), true));
    }
    // DATE_AND_TIME and TIME_OF_DAY contain `_`; split at every `_TO_` and accept the one
    // that names two types (the checker validates them).
    let mut start = 0;
    while let Some(i) = n[start..].find("_TO_") {
        let at = start + i;
        let (from, to) = (&n[..at], &n[at + 4..]);
        if !from.is_empty() && !to.is_empty() && !from.ends_with("_BCD") {
            return Some((Some(from.to_string()), to.to_string(), false));
        }
        start = at + 1;
    }
    None
}

fn var(name: &str, ty: Elem, kind: NativeVarKind) -> NativeVar {
    let init = Value::Int(0);
    NativeVar {
        name: name.to_string(),
        ty,
        kind,
        init,
    }
}

/// The standard function blocks: timers, edge detectors, counters (with the typed counters
/// of the third edition) and bistables.
pub fn standard_fbs() -> Vec<NativeSig> {
    use NativeVarKind::{Input as I, Output as O, State as S};
    let mut fbs = Vec::new();
    for name in ["TON", "TOF", "TP"] {
        fbs.push(NativeSig {
            name: name.into(),
            vars: vec![
                var("IN", Elem::Bool, I),
                var("PT", Elem::Time, I),
                var("Q", Elem::Bool, O),
                var("ET", Elem::Time, O),
                var("running", Elem::Bool, S),
                var("start", Elem::Time, S),
                var("prev", Elem::Bool, S),
            ],
        });
    }
    for name in ["R_TRIG", "F_TRIG"] {
        fbs.push(NativeSig {
            name: name.into(),
            vars: vec![
                var("CLK", Elem::Bool, I),
                var("Q", Elem::Bool, O),
                var("M", Elem::Bool, S),
            ],
        });
    }
    for (suffix, ty) in [
        ("", Elem::Int),
        ("_DINT", Elem::Dint),
        ("_LINT", Elem::Lint),
        ("_UDINT", Elem::Udint),
        ("_ULINT", Elem::Ulint),
    ] {
        fbs.push(NativeSig {
            name: format!("CTU{suffix}"),
            vars: vec![
                var("CU", Elem::Bool, I),
                var("R", Elem::Bool, I),
                var("PV", ty, I),
                var("Q", Elem::Bool, O),
                var("CV", ty, O),
                var("prev_cu", Elem::Bool, S),
            ],
        });
        fbs.push(NativeSig {
            name: format!("CTD{suffix}"),
            vars: vec![
                var("CD", Elem::Bool, I),
                var("LD", Elem::Bool, I),
                var("PV", ty, I),
                var("Q", Elem::Bool, O),
                var("CV", ty, O),
                var("prev_cd", Elem::Bool, S),
            ],
        });
        fbs.push(NativeSig {
            name: format!("CTUD{suffix}"),
            vars: vec![
                var("CU", Elem::Bool, I),
                var("CD", Elem::Bool, I),
                var("R", Elem::Bool, I),
                var("LD", Elem::Bool, I),
                var("PV", ty, I),
                var("QU", Elem::Bool, O),
                var("QD", Elem::Bool, O),
                var("CV", ty, O),
                var("prev_cu", Elem::Bool, S),
                var("prev_cd", Elem::Bool, S),
            ],
        });
    }
    fbs.push(NativeSig {
        name: "SR".into(),
        vars: vec![
            var("S1", Elem::Bool, I),
            var("R", Elem::Bool, I),
            var("Q1", Elem::Bool, O),
        ],
    });
    fbs.push(NativeSig {
        name: "RS".into(),
        vars: vec![
            var("S", Elem::Bool, I),
            var("R1", Elem::Bool, I),
            var("Q1", Elem::Bool, O),
        ],
    });
    fbs
}

/// The standard function blocks as a dialect names their inputs: CODESYS's and TwinCAT's
/// counters (Standard library: CTU's CU, RESET, PV; CTD's CD, LOAD, PV; CTUD's CU, CD,
/// RESET, LOAD, PV) call the standard's `R` `RESET` and `LD` `LOAD`. Same variables in the
/// same order: only the names programs write differ.
pub fn standard_fbs_in(dialect: Dialect) -> Vec<NativeSig> {
    let mut fbs = standard_fbs();
    if dialect.is_codesys_family() {
        for fb in fbs.iter_mut().filter(|f| f.name.starts_with("CT")) {
            for v in &mut fb.vars {
                match v.name.as_str() {
                    "R" => v.name = "RESET".into(),
                    "LD" => v.name = "LOAD".into(),
                    _ => {}
                }
            }
        }
    }
    fbs
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codesys_counters_name_reset_and_load() {
        let inputs = |d: Dialect, name: &str| -> Vec<String> {
            let fbs = standard_fbs_in(d);
            let fb = fbs.iter().find(|f| f.name == name).unwrap();
            fb.vars
                .iter()
                .filter(|v| v.kind == NativeVarKind::Input)
                .map(|v| v.name.clone())
                .collect()
        };
        assert_eq!(inputs(Dialect::Iec, "CTUD"), ["CU", "CD", "R", "LD", "PV"]);
        assert_eq!(inputs(Dialect::Pcworx, "CTU"), ["CU", "R", "PV"]);
        for d in [Dialect::Codesys, Dialect::Twincat] {
            assert_eq!(inputs(d, "CTU_DINT"), ["CU", "RESET", "PV"]);
            assert_eq!(inputs(d, "CTD"), ["CD", "LOAD", "PV"]);
            assert_eq!(inputs(d, "CTUD"), ["CU", "CD", "RESET", "LOAD", "PV"]);
            // The bistables keep their R, R1, S, S1.
            assert_eq!(inputs(d, "SR"), ["S1", "R"]);
        }
    }

    #[test]
    fn conversion_names() {
        assert_eq!(
            conversion_of("INT_TO_REAL"),
            Some((Some("INT".into()), "REAL".into(), false))
        );
        assert_eq!(
            conversion_of("DATE_AND_TIME_TO_TIME_OF_DAY"),
            Some((Some("DATE_AND_TIME".into()), "TIME_OF_DAY".into(), false))
        );
        assert_eq!(
            conversion_of("to_lreal"),
            Some((None, "LREAL".into(), false))
        );
        assert_eq!(
            conversion_of("REAL_TRUNC_INT"),
            Some((Some("REAL".into()), "INT".into(), true))
        );
        assert_eq!(conversion_of("MAX"), None);
        assert!(is_standard_function("limit"));
        assert!(is_standard_function("WORD_TO_BOOL"));
    }

    #[test]
    fn typed_and_bcd_names() {
        assert_eq!(typed_form("shr_dword"), Some(("SHR", "DWORD".into())));
        assert_eq!(typed_form("SEL_STRING"), Some(("SEL", "STRING".into())));
        assert_eq!(
            typed_form("LIMIT_TIME_OF_DAY"),
            Some(("LIMIT", "TIME_OF_DAY".into()))
        );
        // Whole names of the standard, and names that are not a function and a type.
        assert_eq!(typed_form("ADD_TIME"), None);
        assert_eq!(typed_form("SUB_DATE_DATE"), None);
        assert_eq!(typed_form("SHR_FOO"), None);
        assert_eq!(typed_form("LEFT_STRING"), None);
        assert!(is_standard_function("eq_string"));
        let bcd = |decode, from: Option<&str>, to: Option<&str>| {
            Some(BcdName {
                decode,
                from: from.map(str::to_string),
                to: to.map(str::to_string),
            })
        };
        assert_eq!(
            bcd_conversion("WORD_BCD_TO_UINT"),
            bcd(true, Some("WORD"), Some("UINT"))
        );
        assert_eq!(bcd_conversion("bcd_to_int"), bcd(true, None, Some("INT")));
        assert_eq!(bcd_conversion("INT_TO_BCD"), bcd(false, Some("INT"), None));
        assert_eq!(
            bcd_conversion("UDINT_TO_BCD_DWORD"),
            bcd(false, Some("UDINT"), Some("DWORD"))
        );
        assert_eq!(bcd_conversion("INT_TO_WORD"), None);
        assert!(is_standard_function("BYTE_BCD_TO_USINT"));
    }
}
