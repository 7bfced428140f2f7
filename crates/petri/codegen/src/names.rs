//! Identifiers for generated code: valid IEC 61131-3 names (and valid C names), unique
//! whatever the case, with invalid or clashing names mangled deterministically.
//!
//! IEC 61131-3 identifiers are case-insensitive (`Motor` and `MOTOR` are one name), start with
//! a letter or one underscore, never hold two underscores in a row nor end with one, and must
//! not be keywords. A name that breaks a rule is rewritten; a name already taken (compared in
//! upper case) gets a numeric suffix. Every rewrite is recorded so generated files can list
//! them in a comment.

use std::collections::HashSet;

/// Words no generated identifier may be: IEC 61131-3 keywords, data types, standard
/// functions and function blocks, IL operators, and C99 keywords and names the generated C
/// uses (compared case-insensitively, so C's case-sensitive names are covered too).
const RESERVED: &[&str] = &[
    // IEC 61131-3 keywords
    "ACTION",
    "END_ACTION",
    "ARRAY",
    "OF",
    "AT",
    "CASE",
    "END_CASE",
    "CONFIGURATION",
    "END_CONFIGURATION",
    "CONSTANT",
    "DO",
    "ELSE",
    "ELSIF",
    "END_IF",
    "EXIT",
    "FOR",
    "END_FOR",
    "FROM",
    "FUNCTION",
    "END_FUNCTION",
    "FUNCTION_BLOCK",
    "END_FUNCTION_BLOCK",
    "IF",
    "INITIAL_STEP",
    "INTERVAL",
    "NON_RETAIN",
    "ON",
    "PRIORITY",
    "PROGRAM",
    "END_PROGRAM",
    "READ_ONLY",
    "READ_WRITE",
    "REPEAT",
    "END_REPEAT",
    "RESOURCE",
    "END_RESOURCE",
    "RETAIN",
    "RETURN",
    "SINGLE",
    "STEP",
    "END_STEP",
    "STRUCT",
    "END_STRUCT",
    "TASK",
    "THEN",
    "TO",
    "TRANSITION",
    "END_TRANSITION",
    "TYPE",
    "END_TYPE",
    "UNTIL",
    "VAR",
    "END_VAR",
    "VAR_ACCESS",
    "VAR_CONFIG",
    "VAR_EXTERNAL",
    "VAR_GLOBAL",
    "VAR_INPUT",
    "VAR_IN_OUT",
    "VAR_OUTPUT",
    "VAR_TEMP",
    "WHILE",
    "END_WHILE",
    "WITH",
    "BY",
    "EN",
    "ENO",
    "R_EDGE",
    "F_EDGE",
    "TRUE",
    "FALSE",
    "AND",
    "OR",
    "XOR",
    "NOT",
    "MOD",
    "METHOD",
    "END_METHOD",
    "INTERFACE",
    "END_INTERFACE",
    "CLASS",
    "END_CLASS",
    "THIS",
    "SUPER",
    "ABSTRACT",
    "FINAL",
    "EXTENDS",
    "IMPLEMENTS",
    "PUBLIC",
    "PRIVATE",
    "PROTECTED",
    "INTERNAL",
    "OVERRIDE",
    "REF",
    "REF_TO",
    "NULL",
    "NAMESPACE",
    "END_NAMESPACE",
    "USING",
    "CONTINUE",
    // data types
    "BOOL",
    "SINT",
    "INT",
    "DINT",
    "LINT",
    "USINT",
    "UINT",
    "UDINT",
    "ULINT",
    "REAL",
    "LREAL",
    "TIME",
    "DATE",
    "TIME_OF_DAY",
    "TOD",
    "DATE_AND_TIME",
    "DT",
    "STRING",
    "WSTRING",
    "BYTE",
    "WORD",
    "DWORD",
    "LWORD",
    "ANY",
    "CHAR",
    "WCHAR",
    "LTIME",
    "LDATE",
    "LTOD",
    "LDT",
    // standard function blocks and functions the code uses or an IDE knows
    "TON",
    "TOF",
    "TP",
    "CTU",
    "CTD",
    "CTUD",
    "R_TRIG",
    "F_TRIG",
    "SR",
    "RS",
    "SEMA",
    "MIN",
    "MAX",
    "LIMIT",
    "SEL",
    "MUX",
    "ABS",
    "SQRT",
    "MOVE",
    "ADD",
    "SUB",
    "MUL",
    "DIV",
    "EXPT",
    "SHL",
    "SHR",
    "ROL",
    "ROR",
    "GT",
    "GE",
    "EQ",
    "LE",
    "LT",
    "NE",
    "LEN",
    "LEFT",
    "RIGHT",
    "MID",
    "CONCAT",
    "INSERT",
    "DELETE",
    "REPLACE",
    "FIND",
    "IN",
    "PT",
    "Q",
    "ET",
    "CU",
    "CD",
    "PV",
    "CV",
    "QU",
    "QD",
    "CLK",
    "S1",
    "R1",
    // IL operators
    "LD",
    "LDN",
    "ST",
    "STN",
    "S",
    "R",
    "ANDN",
    "ORN",
    "XORN",
    "JMP",
    "JMPC",
    "JMPCN",
    "CAL",
    "CALC",
    "CALCN",
    "RET",
    "RETC",
    "RETCN",
    "N",
    // C99 keywords and names the generated C defines or includes
    "AUTO",
    "BREAK",
    "CONST",
    "DEFAULT",
    "DOUBLE",
    "ENUM",
    "EXTERN",
    "FLOAT",
    "GOTO",
    "INLINE",
    "LONG",
    "REGISTER",
    "RESTRICT",
    "SHORT",
    "SIGNED",
    "SIZEOF",
    "STATIC",
    "SWITCH",
    "TYPEDEF",
    "UNION",
    "UNSIGNED",
    "VOID",
    "VOLATILE",
    "MAIN",
    "STEP",
    "INPUTS",
    "OUTPUTS",
    "STATE",
    "PRINTF",
    "FPRINTF",
    "STDERR",
    "STDOUT",
    "EXIT",
    "MALLOC",
    "FREE",
    "ERRNO",
    "ASSERT",
    "SIZE_T",
    "UINT8_T",
    "UINT32_T",
    "UINT64_T",
    "INT64_T",
    "BOOL_T",
    "FILE",
    "EOF",
];

/// Hands out identifiers and remembers which names were rewritten.
#[derive(Clone, Debug, Default)]
pub struct Names {
    taken: HashSet<String>,
    renamed: Vec<(String, String)>,
}

impl Names {
    pub fn new() -> Self {
        Names {
            taken: RESERVED.iter().map(|w| w.to_string()).collect(),
            renamed: Vec::new(),
        }
    }

    /// A fresh identifier for `wanted`: `wanted` itself when it is a valid, free IEC name;
    /// otherwise its mangled form, with `_2`, `_3`, … until free. Rewrites of a name the
    /// user wrote (`user = true`) are recorded for [`Names::renamed`].
    pub fn claim(&mut self, wanted: &str, user: bool) -> String {
        let base = mangle(wanted);
        let mut candidate = base.clone();
        let mut n = 2u32;
        while self.taken.contains(&candidate.to_ascii_uppercase()) {
            candidate = format!("{base}_{n}");
            n += 1;
        }
        self.taken.insert(candidate.to_ascii_uppercase());
        if user && candidate != wanted {
            self.renamed.push((wanted.to_string(), candidate.clone()));
        }
        candidate
    }

    /// Whether `name` (compared case-insensitively) is already used or reserved.
    pub fn is_taken(&self, name: &str) -> bool {
        self.taken.contains(&name.to_ascii_uppercase())
    }

    /// Every user-visible name that had to change, as (original, identifier), in the order
    /// they were claimed.
    pub fn renamed(&self) -> &[(String, String)] {
        &self.renamed
    }
}

/// `name` as a syntactically valid IEC 61131-3 identifier (not yet checked against keywords
/// or other names): characters other than ASCII letters and digits become `_`, runs of `_`
/// shrink to one, a trailing `_` goes, and a leading digit gets an `x` in front.
pub fn mangle(name: &str) -> String {
    let mut out = String::with_capacity(name.len() + 1);
    for c in name.chars() {
        let c = if c.is_ascii_alphanumeric() { c } else { '_' };
        if c == '_' && out.ends_with('_') {
            continue;
        }
        out.push(c);
    }
    while out.ends_with('_') {
        out.pop();
    }
    if out.is_empty() {
        out.push('x');
    } else if out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, 'x');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(wanted: &[&str], expect: &[&str]) {
        let mut names = Names::new();
        let got: Vec<String> = wanted.iter().map(|w| names.claim(w, true)).collect();
        assert_eq!(got, expect);
    }

    #[test]
    fn valid_free_names_are_kept() {
        check(&["B1", "L1Local", "_x1"], &["B1", "L1Local", "_x1"]);
    }

    #[test]
    fn names_differing_only_in_case_are_one_name() {
        check(
            &["motor", "Motor", "MOTOR"],
            &["motor", "Motor_2", "MOTOR_3"],
        );
    }

    #[test]
    fn keywords_and_standard_names_are_avoided() {
        check(
            &["IF", "ton", "Step", "int"],
            &["IF_2", "ton_2", "Step_2", "int_2"],
        );
    }

    #[test]
    fn invalid_names_are_mangled() {
        check(
            &["!N3", "a b", "1st", "x__y_", "", "ä"],
            &["_N3", "a_b", "x1st", "x_y", "x", "x_2"],
        );
    }

    #[test]
    fn a_mangled_name_does_not_take_an_existing_one() {
        check(&["a_b", "a b", "a-b"], &["a_b", "a_b_2", "a_b_3"]);
    }

    #[test]
    fn rewrites_are_recorded() {
        let mut names = Names::new();
        names.claim("ok", true);
        names.claim("not ok", true);
        names.claim("Helper", false);
        names.claim("helper", false);
        assert_eq!(
            names.renamed(),
            &[("not ok".to_string(), "not_ok".to_string())]
        );
    }
}
