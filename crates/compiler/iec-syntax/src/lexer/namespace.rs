//! Library namespaces written before a name, as TwinCAT 3 and CODESYS 3 allow it:
//! `Tc2_System.T_MaxString`, `Tc2_Utilities.LEN2(…)`, `Tc2_Standard.TON`,
//! `__SYSTEM.TYPE_CLASS.TYPE_BOOL`, `SysFile.SysTypes.RTS_IEC_HANDLE`. A library's names are
//! also visible unqualified (unless the library is marked `qualified_only`, which petriplc
//! does not model), so the qualifier only says where a name comes from: it is dropped here,
//! after lexing, and the parser and checker see the name alone (docs/iec.md, "Vendor
//! libraries"). Only the namespaces of the libraries TwinCAT and CODESYS ship are known:
//! a qualifier that is a variable (`fb.out`, `GVL.x`, `E_Color.Red`) is left as written.

use super::{Tok, Token};

/// The namespaces of the libraries TwinCAT 3 and CODESYS 3 ship whose names petriplc knows
/// (compared case-insensitively), besides every `Tc2_…` and `Tc3_…` library of Beckhoff's.
const NAMESPACES: &[&str] = &[
    "__SYSTEM",
    "SysFile",
    "SysDir",
    "SysTypes",
    "SysMem",
    "CmpErrors",
    "IBaseLibrary",
];

/// Whether `name` is the namespace of a vendor library.
pub fn is_library_namespace(name: &str) -> bool {
    let upper = name.to_ascii_uppercase();
    ((upper.starts_with("TC2_") || upper.starts_with("TC3_")) && upper.len() > 4)
        || NAMESPACES.iter().any(|n| n.eq_ignore_ascii_case(name))
}

/// Drops every `NAMESPACE .` before a name: the namespace token and its dot, when the
/// namespace is not itself a field (`a.Tc2_System` stays) and a name follows the dot.
pub(super) fn unqualify(text: &str, tokens: Vec<Token>) -> Vec<Token> {
    let mut out: Vec<Token> = Vec::with_capacity(tokens.len());
    let mut i = 0;
    while i < tokens.len() {
        let t = &tokens[i];
        let after_dot = out.last().is_some_and(|p| p.tok == Tok::Dot);
        let qualifies = t.tok == Tok::Ident
            && !after_dot
            && tokens.get(i + 1).is_some_and(|d| d.tok == Tok::Dot)
            && tokens.get(i + 2).is_some_and(|n| n.tok == Tok::Ident)
            && text
                .get(t.span.start as usize..t.span.end as usize)
                .is_some_and(is_library_namespace);
        if qualifies {
            i += 2;
            continue;
        }
        out.push(t.clone());
        i += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use crate::diag::Diagnostics;
    use crate::lexer::{lex, Tok};
    use crate::source::FileId;

    /// The tokens' texts after lexing `src`.
    fn words(src: &str) -> Vec<String> {
        let mut d = Diagnostics::default();
        lex(FileId(0), src, &mut d)
            .into_iter()
            .filter(|t| t.tok != Tok::Eof)
            .map(|t| src[t.span.start as usize..t.span.end as usize].to_string())
            .collect()
    }

    #[test]
    fn library_namespaces_are_dropped() {
        assert_eq!(words("Tc2_System.T_MaxString"), ["T_MaxString"]);
        assert_eq!(words("tc2_utilities.LEN2(x)"), ["LEN2", "(", "x", ")"]);
        assert_eq!(
            words("__SYSTEM.TYPE_CLASS.TYPE_BOOL"),
            ["TYPE_CLASS", ".", "TYPE_BOOL"]
        );
        assert_eq!(words("SysFile.SysTypes.RTS_IEC_HANDLE"), ["RTS_IEC_HANDLE"]);
    }

    #[test]
    fn other_qualifiers_stay() {
        assert_eq!(words("GVL.x"), ["GVL", ".", "x"]);
        assert_eq!(words("a.SysFile.x"), ["a", ".", "SysFile", ".", "x"]);
        // Not followed by a name: left for the parser to report.
        assert_eq!(words("Tc2_System.;"), ["Tc2_System", ".", ";"]);
        assert_eq!(words("Tc2_"), ["Tc2_"]);
    }
}
