//! Diagnostics of every stage (lexer, parser, PLCopen reader, checker) under stable codes:
//! `E0xx` syntax, `E05x` PLCopen XML, `E1xx` names and declarations, `E2xx` types, `E3xx`
//! statements and calls, `E4xx` configurations, `E9xx` what the engine does not support yet;
//! `Wxxx` warnings. `codes.rs` documents each one (title, example, fix).

use crate::source::{SourceMap, Span};

pub use petriplc_diag::{shorten, Code, Label, Severity, MAX_SHOWN};

/// One problem, where it is (a byte span, turned into a line and column by the
/// [`SourceMap`] when rendered), and what to write instead.
pub type Diagnostic = petriplc_diag::Diagnostic<Span>;

/// The code constants; `codes.rs` says what each means.
macro_rules! codes {
    ($($name:ident = $code:literal,)*) => {
        $(pub const $name: Code = Code($code);)*
    };
}

codes! {
    BAD_CHAR = "E001",
    UNTERMINATED_COMMENT = "E002",
    UNTERMINATED_STRING = "E003",
    BAD_NUMBER = "E004",
    BAD_TIME = "E005",
    BAD_ESCAPE = "E006",
    NOT_LATIN1 = "E009",
    SYNTAX = "E010",
    MISSING_END = "E011",
    MISSING_SEMI = "E012",
    EMPTY_SOURCE = "E013",
    TOO_DEEP = "E014",
    PRAGMA_ERROR = "E015",
    IL_SYNTAX = "E020",
    IL_PARENS = "E021",
    SFC_STRUCTURE = "E030",
    SFC_MIXED = "E031",
    XML = "E050",
    NOT_PLCOPEN = "E051",
    PLCOPEN_STRUCTURE = "E052",
    PLCOPEN_TYPE = "E053",
    GRAPHICAL = "E054",
    TWINCAT_STRUCTURE = "E055",
    PROJECT_FILE = "E056",
    UNDECLARED = "E100",
    UNKNOWN_TYPE = "E101",
    UNKNOWN_POU = "E102",
    DUPLICATE = "E103",
    // E104 (a name used as a variable that is something else) is never emitted: E100 and
    // E120 say it; the number stays unused.
    NO_FIELD = "E105",
    EXTERNAL_MISMATCH = "E106",
    RECURSION = "E107",
    CONSTANT_REQUIRED = "E108",
    BAD_DECLARATION = "E109",
    TYPE_MISMATCH = "E110",
    OPERAND_TYPE = "E111",
    NOT_BOOL = "E112",
    OUT_OF_RANGE = "E113",
    BAD_INDEX = "E114",
    BAD_INITIAL = "E115",
    TYPE_TOO_DEEP = "E116",
    NOT_ASSIGNABLE = "E120",
    ASSIGN_CONSTANT = "E121",
    // E122 (an assignment to an input of the POU) became the warning W020: the number
    // stays unused.
    // E123 (an assignment to a FOR loop's control variable) became the warning W031: the
    // number stays unused.
    BAD_ARGUMENTS = "E130",
    NOT_CALLABLE = "E131",
    UNREACHABLE_CASE = "E140",
    CASE_LABEL = "E141",
    MISPLACED = "E142",
    BAD_FOR = "E143",
    CONFIG = "E150",
    NO_PROGRAM = "E151",
    IL_LABEL = "E160",
    IL_NO_RESULT = "E161",
    IL_NESTING = "E162",
    VENDOR_NOT_LOADED = "E180",
    VENDOR_ARGUMENT = "E181",
    UNSUPPORTED = "E190",
    NOT_A_REFERENCE = "E200",
    NO_ADDRESS = "E201",
    RETAINED_REFERENCE = "E202",
    OOP_DECLARATION = "E210",
    OOP_MEMBER = "E211",
    OOP_MODIFIER = "E212",
    OOP_ACCESS = "E213",
    OOP_SIGNATURE = "E214",
    ITF_MISSING = "E215",
    ITF_SIGNATURE = "E216",
    ITF_NOT_INTERFACE = "E217",
    ITF_MISUSE = "E218",
    ITF_NOT_IMPLEMENTED = "E219",
    REF_ASSIGN = "E220",
    UNION_MEMBER = "E221",
    UNION_ACCESS = "E222",
    UNION_INITIAL = "E223",
    ARRAY_STAR_PLACE = "E228",
    ARRAY_BOUND = "E229",
    ARRAY_STAR_WHOLE = "E230",
    FB_INIT_ARGUMENTS = "E237",
    SHADOWS_STANDARD = "W001",
    NOT_CHECKED = "W002",
    UNUSED_RESULT = "W003",
    PRAGMA_IGNORED = "W010",
    PRAGMA_WARNING = "W011",
    CONSTANT_WITHOUT_VALUE = "W012",
    ASSIGN_INPUT = "W020",
    EXTERNAL_WITHOUT_GLOBAL = "W021",
    IMPLICIT_BITS_TO_NUMBER = "W022",
    INSTANCE_INTERNAL = "W030",
    ASSIGN_LOOP_VAR = "W031",
    IN_OUT_INITIAL = "W032",
    LOCATION_IGNORED = "W013",
    SFC_NEVER = "W033",
    REFERENCE_CARET = "W040",
    COMMENT_NOT_NESTED = "W045",
    REPLACEMENT_CHAR = "W043",
    FB_INIT_NOT_CALLED = "W049",
    RECURSION_THROUGH_INTERFACE = "W050",
    IMPLICIT_NARROWING = "W051",
    VOID_ASSIGNED = "W052",
    NO_POINTER_FROM_TEXT = "W053",
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
    fn renders_file_line_col() {
        let mut map = SourceMap::new();
        let f = map.add("a.st", "x\n  y := 1;");
        let d = Diagnostic::error(UNDECLARED, Span::new(f, 4, 5), "`y` is not declared");
        assert_eq!(d.render(&map), "a.st:2:3: error[E100]: `y` is not declared");
    }
}
