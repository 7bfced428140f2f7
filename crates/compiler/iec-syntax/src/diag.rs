//! Diagnostics of every stage (lexer, parser, PLCopen reader, checker) under stable codes:
//! `E0xx` syntax, `E05x` PLCopen XML, `E1xx` names and declarations, `E2xx` types, `E3xx`
//! statements and calls, `E4xx` configurations, `E9xx` what the engine does not support yet;
//! `Wxxx` warnings. [`CODES`] lists them all with a title, for the documentation.

use crate::source::{SourceMap, Span};

pub use petriplc_diag::{shorten, Code, Label, Severity, MAX_SHOWN};

/// One problem, where it is (a byte span, turned into a line and column by the
/// [`SourceMap`] when rendered), and what to write instead.
pub type Diagnostic = petriplc_diag::Diagnostic<Span>;

macro_rules! codes {
    ($($name:ident = $code:literal : $title:literal,)*) => {
        $(#[doc = $title] pub const $name: Code = Code($code);)*
        /// Every code with its title.
        pub const CODES: &[(Code, &str)] = &[$(($name, $title),)*];
    };
}

codes! {
    BAD_CHAR = "E001": "a character that cannot start a token",
    UNTERMINATED_COMMENT = "E002": "a comment without its end",
    UNTERMINATED_STRING = "E003": "a string literal without its closing quote",
    BAD_NUMBER = "E004": "a malformed or too large number literal",
    BAD_TIME = "E005": "a malformed TIME, DATE, TIME_OF_DAY or DATE_AND_TIME literal",
    BAD_ESCAPE = "E006": "an unknown `$` escape in a string literal",
    SYNTAX = "E010": "a token the grammar does not allow here",
    MISSING_END = "E011": "a block without its END_ keyword",
    MISSING_SEMI = "E012": "a statement or declaration without its `;`",
    EMPTY_SOURCE = "E013": "a source without any declaration",
    TOO_DEEP = "E014": "statements, expressions, ARRAY types, initial values or IL parenthesised operations nested deeper than the engine reads (100 levels; an expression's tree 1000)",
    IL_SYNTAX = "E020": "an Instruction List line that is not an instruction: an unknown operator, a missing or extra operand, a modifier the operator does not take",
    IL_PARENS = "E021": "a `)` without its deferred operation, or a deferred operation without its `)`",
    XML = "E050": "malformed XML",
    NOT_PLCOPEN = "E051": "an XML file that is not a PLCopen TC6 project",
    PLCOPEN_STRUCTURE = "E052": "a PLCopen element missing a required part or attribute",
    PLCOPEN_TYPE = "E053": "a PLCopen type element the reader does not know",
    GRAPHICAL = "E054": "an LD or SFC element that is not connected as its language requires",
    UNDECLARED = "E100": "a name that is not declared",
    UNKNOWN_TYPE = "E101": "a type name that is not declared",
    UNKNOWN_POU = "E102": "a function or function block that is not declared",
    DUPLICATE = "E103": "a name declared twice in one scope",
    NOT_A_VARIABLE = "E104": "a name used as a variable that is something else",
    NO_FIELD = "E105": "a field or member that the structure or instance does not have",
    EXTERNAL_MISMATCH = "E106": "a VAR_EXTERNAL without a matching VAR_GLOBAL",
    RECURSION = "E107": "a POU that calls or contains itself",
    CONSTANT_REQUIRED = "E108": "a value that must be a constant expression",
    BAD_DECLARATION = "E109": "a declaration the standard does not allow here",
    TYPE_MISMATCH = "E110": "a value of the wrong type for its place",
    OPERAND_TYPE = "E111": "an operator applied to operands of types it does not take",
    NOT_BOOL = "E112": "a condition that is not BOOL",
    OUT_OF_RANGE = "E113": "a constant outside the range of its type",
    BAD_INDEX = "E114": "an index or subscript that does not fit the array",
    BAD_INITIAL = "E115": "an initial value that does not fit its variable",
    TYPE_TOO_DEEP = "E116": "types inside types (STRUCT fields, ARRAY elements, function block instances, type names) more than 100 levels deep",
    NOT_ASSIGNABLE = "E120": "an assignment to something that cannot be written",
    ASSIGN_CONSTANT = "E121": "an assignment to a CONSTANT",
    ASSIGN_INPUT = "E122": "an assignment to an input of the POU",
    ASSIGN_LOOP_VAR = "E123": "an assignment to a FOR loop's control variable in its body",
    BAD_ARGUMENTS = "E130": "a call whose arguments do not match the parameters",
    NOT_CALLABLE = "E131": "a call of something that is not a function or an instance",
    UNREACHABLE_CASE = "E140": "a CASE label that can never be chosen",
    CASE_LABEL = "E141": "a CASE label that is not a constant of the selector's type",
    MISPLACED = "E142": "EXIT or CONTINUE outside a loop",
    BAD_FOR = "E143": "a FOR loop whose variable or bounds are not integers",
    CONFIG = "E150": "a CONFIGURATION, RESOURCE, TASK or program instance problem",
    NO_PROGRAM = "E151": "no program to run, or several without a choice",
    IL_LABEL = "E160": "a jump to a label that is not defined, or a label defined twice",
    IL_NO_RESULT = "E161": "an IL instruction that needs the current result where there is none",
    IL_NESTING = "E162": "a label, jump or return inside a parenthesised IL operation",
    UNSUPPORTED = "E190": "something the engine does not support yet",
    SHADOWS_STANDARD = "W001": "a declaration that replaces a standard function or function block",
    NOT_CHECKED = "W002": "a POU whose body language the engine does not run yet",
    UNUSED_RESULT = "W003": "a function call whose result is thrown away",
}

/// Diagnostics collected by a stage, in the order found.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Diagnostics {
    pub items: Vec<Diagnostic>,
}

impl Diagnostics {
    pub fn new() -> Self {
        Diagnostics::default()
    }

    pub fn error(&mut self, code: Code, span: Span, message: impl Into<String>) {
        self.items.push(Diagnostic::error(code, span, message));
    }

    pub fn warning(&mut self, code: Code, span: Span, message: impl Into<String>) {
        self.items.push(Diagnostic::warning(code, span, message));
    }

    pub fn push(&mut self, d: Diagnostic) {
        self.items.push(d);
    }

    pub fn extend(&mut self, other: Diagnostics) {
        self.items.extend(other.items);
    }

    pub fn has_errors(&self) -> bool {
        self.items.iter().any(|d| d.severity == Severity::Error)
    }

    pub fn errors(&self) -> impl Iterator<Item = &Diagnostic> {
        self.items.iter().filter(|d| d.severity == Severity::Error)
    }

    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Sorted by file and position, duplicates (same code and place) dropped.
    pub fn sorted(mut self) -> Self {
        self.items
            .sort_by_key(|d| (d.span.file, d.span.start, d.severity, d.code));
        self.items
            .dedup_by(|a, b| a.code == b.code && a.span == b.span && a.message == b.message);
        self
    }

    /// One rendered line per diagnostic (and one per secondary label or help).
    pub fn render(&self, map: &SourceMap) -> String {
        let mut out = String::new();
        for d in &self.items {
            out.push_str(&d.render(map));
            out.push('\n');
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_unique_and_well_formed() {
        let mut seen = std::collections::BTreeSet::new();
        for (code, title) in CODES {
            assert!(seen.insert(code.0), "{code} twice");
            assert!(code.0.len() == 4 && (code.0.starts_with('E') || code.0.starts_with('W')));
            assert!(!title.is_empty());
        }
    }

    #[test]
    fn renders_file_line_col() {
        let mut map = SourceMap::new();
        let f = map.add("a.st", "x\n  y := 1;");
        let d = Diagnostic::error(UNDECLARED, Span::new(f, 4, 5), "`y` is not declared");
        assert_eq!(d.render(&map), "a.st:2:3: error[E100]: `y` is not declared");
    }
}
