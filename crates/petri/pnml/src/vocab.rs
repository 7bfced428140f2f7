//! The names both directions agree on: PNML net types, petriplc's toolspecific vocabulary
//! per element kind, and the limits that keep guard parsing within the stack.

/// The PNML 2009 namespace.
pub const PNML_NS: &str = "http://www.pnml.org/version-2009/grammar/pnml";
/// The net type written for nets with normal arcs only.
pub const PTNET: &str = "http://www.pnml.org/version-2009/grammar/ptnet";
/// The net type written for nets with inhibitor or read arcs.
pub const INHIBITOR_PTNET: &str = "http://www.pnml.org/version-2009/extensions/inhibitorptnet";

/// The `tool` attribute of petriplc's `<toolspecific>` elements.
pub const TOOL: &str = "petriplc";
/// The `version` attribute petriplc writes and reads.
pub const VERSION: &str = "1";

/// petriplc elements allowed in the net's toolspecific block.
pub const NET_ITEMS: &[&str] = &["step", "evolve", "signal"];
/// petriplc elements allowed in a place's toolspecific block.
pub const PLACE_ITEMS: &[&str] = &["output", "input", "capacity"];
/// petriplc elements allowed in a transition's toolspecific block.
pub const TRANSITION_ITEMS: &[&str] = &["guard", "deadline"];
/// petriplc elements allowed in an arc's toolspecific block.
pub const ARC_ITEMS: &[&str] = &["delay", "type"];
/// Attributes of a `<signal>` declaration.
pub const SIGNAL_ATTRS: &[&str] = &["name", "direction", "type"];

/// Parentheses and NOTs in one guard: the guard parser recurses on each, so a bound keeps a
/// hostile file from overflowing the stack. Real guards nest a handful deep.
pub const MAX_GUARD_NESTING: usize = 64;
/// Operators in one guard: each adds a level to the expression tree that later walks recurse
/// over.
pub const MAX_GUARD_OPERATORS: usize = 512;

/// Whether a net type URI names a place/transition net (`…/ptnet`, `…/inhibitorptnet`,
/// `…/resetinhibitorptnet`, …).
pub fn is_pt_net_type(uri: &str) -> bool {
    uri.trim().to_ascii_lowercase().ends_with("ptnet")
}

/// Why a guard is too complex to parse safely, if it is. Nesting counts open parentheses
/// and the NOTs in front of them and in front of the current operand, as the parser recurses
/// on each.
pub fn guard_too_complex(text: &str) -> Option<String> {
    // The NOT chain in front of each open parenthesis.
    let mut open: Vec<usize> = Vec::new();
    // Open parentheses plus the NOTs in front of them.
    let mut open_depth = 0usize;
    let mut chain = 0usize;
    let mut deepest = 0usize;
    let mut operators = 0usize;
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        let mut word = String::new();
        if c.is_ascii_alphanumeric() || c == '_' {
            word.push(c);
            while let Some(&d) = chars
                .peek()
                .filter(|d| d.is_ascii_alphanumeric() || **d == '_')
            {
                word.push(d);
                chars.next();
            }
        }
        let is = |kw: &str| word.eq_ignore_ascii_case(kw);
        if is("NOT") || (c == '!' && chars.peek() != Some(&'=')) {
            chain += 1;
        } else if c == '(' {
            open.push(chain);
            open_depth += 1 + chain;
            chain = 0;
        } else if c == ')' {
            open_depth -= open.pop().map_or(0, |nots| 1 + nots);
            chain = 0;
        } else if is("AND") || is("OR") || is("XOR") || "&|<>=!".contains(c) {
            operators += 1;
            chain = 0;
        } else if !c.is_whitespace() {
            chain = 0;
        }
        deepest = deepest.max(open_depth + chain);
        if deepest > MAX_GUARD_NESTING {
            break;
        }
    }
    if deepest > MAX_GUARD_NESTING {
        Some(format!(
            "it nests more than {MAX_GUARD_NESTING} parentheses and NOTs; simplify it"
        ))
    } else if deepest + operators > MAX_GUARD_OPERATORS {
        Some(format!(
            "it has more than {MAX_GUARD_OPERATORS} operators; simplify it"
        ))
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(input: &str, expect: Option<&str>) {
        assert_eq!(guard_too_complex(input).as_deref(), expect, "{input:.40}");
    }

    #[test]
    fn bounds_nesting_and_operators() {
        check("B1 AND NOT (N2 OR x != 3)", None);
        check(&"(".repeat(64), None);
        check(
            &"(".repeat(65),
            Some("it nests more than 64 parentheses and NOTs; simplify it"),
        );
        check(
            &"NOT ".repeat(65),
            Some("it nests more than 64 parentheses and NOTs; simplify it"),
        );
        check(
            &"!".repeat(65),
            Some("it nests more than 64 parentheses and NOTs; simplify it"),
        );
        check(&"a != 1 AND ".repeat(100), None);
        check(&"NOT a AND ".repeat(200), None);
        check(&format!("{}a{}", "NOT (".repeat(32), ")".repeat(32)), None);
        check(
            &format!("{}a{}", "NOT (".repeat(33), ")".repeat(33)),
            Some("it nests more than 64 parentheses and NOTs; simplify it"),
        );
        check(&format!("{}a", "(a) AND ".repeat(100)), None);
        check(
            &"a AND ".repeat(513),
            Some("it has more than 512 operators; simplify it"),
        );
    }

    #[test]
    fn recognises_pt_net_types() {
        for t in [
            PTNET,
            INHIBITOR_PTNET,
            " http://x/extensions/resetinhibitorptnet ",
            "PTNet",
        ] {
            assert!(is_pt_net_type(t), "{t}");
        }
        for t in [
            "http://www.pnml.org/version-2009/grammar/symmetricnet",
            "",
            "ptnets",
        ] {
            assert!(!is_pt_net_type(t), "{t}");
        }
    }
}
