//! The syntax tree of IEC 61131-3 library elements as written: data types, POUs,
//! configurations. Names keep their spelling; the checker compares them case-insensitively.
//!
//! A POU's [`Body`] is Structured Text or Instruction List (both lowered by the checker);
//! graphical bodies (LD, FBD, SFC from PLCopen XML) are kept as read, for their front ends to
//! lower into the same checked form (issue 17).

use crate::source::Span;

/// A name as written, with its place.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ident {
    pub name: String,
    pub span: Span,
}

impl Ident {
    pub fn new(name: impl Into<String>, span: Span) -> Self {
        Ident {
            name: name.into(),
            span,
        }
    }

    /// The name in upper case, the form names are compared in.
    pub fn key(&self) -> String {
        self.name.to_ascii_uppercase()
    }

    pub fn is(&self, other: &str) -> bool {
        self.name.eq_ignore_ascii_case(other)
    }
}

/// Everything read from one or more sources.
#[derive(Clone, Debug, Default)]
pub struct Library {
    pub elements: Vec<Element>,
}

// A library holds a few elements, most of them POUs: the size of the others matters less than
// the readers' simple `Element::Pou(p)`.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Element {
    Types(Vec<TypeDecl>),
    Pou(Pou),
    Configuration(Configuration),
    /// A `VAR_GLOBAL` block outside any configuration (a global variable list, as CODESYS and
    /// TwinCAT write them).
    Globals(VarBlock),
}

/// `NAME : spec [:= init];` inside `TYPE … END_TYPE`.
#[derive(Clone, Debug)]
pub struct TypeDecl {
    pub name: Ident,
    pub spec: TypeSpec,
    pub init: Option<Init>,
    pub span: Span,
}

/// A type as written in a declaration.
#[derive(Clone, Debug)]
pub enum TypeSpec {
    /// An elementary, derived or function block type by name (`INT`, `Color`, `TON`).
    Named(Ident),
    /// `STRING`, `STRING[20]`, `WSTRING(10)`.
    String {
        wide: bool,
        len: Option<Box<Expr>>,
        span: Span,
    },
    /// `ARRAY [lo..hi, …] OF elem`.
    Array {
        ranges: Vec<(Expr, Expr)>,
        elem: Box<TypeSpec>,
        span: Span,
    },
    /// `ARRAY [*, …] OF elem` (IEC 61131-3 3rd edition): an array of any bounds, `dims`
    /// dimensions; only a VAR_IN_OUT's type (the checker says so elsewhere).
    ArrayStar {
        dims: u32,
        elem: Box<TypeSpec>,
        span: Span,
    },
    Struct {
        /// CODESYS's and TwinCAT's `TYPE name EXTENDS base : STRUCT`: the base structure's
        /// fields come first.
        base: Option<Ident>,
        fields: Vec<VarDecl>,
        span: Span,
    },
    /// CODESYS's and TwinCAT's `UNION … END_UNION`: members overlaying the same bytes.
    Union { members: Vec<VarDecl>, span: Span },
    /// `(A, B := 5, C)`, optionally typed `INT (A := 1, B := 2)`.
    Enum {
        base: Option<Ident>,
        values: Vec<(Ident, Option<Expr>)>,
        span: Span,
    },
    /// `INT (0..100)`.
    Subrange {
        base: Ident,
        lo: Box<Expr>,
        hi: Box<Expr>,
        span: Span,
    },
    /// `REF_TO T` (the standard's reference), `POINTER TO T` (CODESYS), `REFERENCE TO T`.
    Ref {
        kind: RefKind,
        target: Box<TypeSpec>,
        span: Span,
    },
    /// Forms the engine does not support (reported by the checker with `what`, the whole
    /// message: `UNION`).
    Unsupported { what: String, span: Span },
}

impl TypeSpec {
    pub fn span(&self) -> Span {
        match self {
            TypeSpec::Named(i) => i.span,
            TypeSpec::String { span, .. }
            | TypeSpec::Array { span, .. }
            | TypeSpec::ArrayStar { span, .. }
            | TypeSpec::Struct { span, .. }
            | TypeSpec::Union { span, .. }
            | TypeSpec::Enum { span, .. }
            | TypeSpec::Subrange { span, .. }
            | TypeSpec::Ref { span, .. }
            | TypeSpec::Unsupported { span, .. } => *span,
        }
    }
}

/// How a reference type was written: they share one representation (docs/iec.md,
/// "References and pointers").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RefKind {
    /// `REF_TO T` (IEC 61131-3 third edition).
    RefTo,
    /// `POINTER TO T` (CODESYS, TwinCAT).
    PointerTo,
    /// `REFERENCE TO T` (CODESYS, TwinCAT: dereferenced implicitly; refused for now).
    ReferenceTo,
    /// A variable of an INTERFACE type: a handle to the instance of a block implementing
    /// it, never written as a reference (docs/iec.md, "Interfaces").
    Interface,
}

impl RefKind {
    pub fn text(self) -> &'static str {
        match self {
            RefKind::RefTo => "REF_TO",
            RefKind::PointerTo => "POINTER TO",
            RefKind::ReferenceTo => "REFERENCE TO",
            RefKind::Interface => "INTERFACE",
        }
    }
}

/// An initial value: an expression, an array list `[1, 2, 3(0)]` or a structure
/// `(x := 1, y := 2)`.
#[derive(Clone, Debug)]
pub enum Init {
    Expr(Expr),
    Array {
        items: Vec<ArrayInitItem>,
        span: Span,
    },
    Struct {
        fields: Vec<(Ident, Init)>,
        span: Span,
    },
}

impl Init {
    pub fn span(&self) -> Span {
        match self {
            Init::Expr(e) => e.span,
            Init::Array { span, .. } | Init::Struct { span, .. } => *span,
        }
    }
}

/// `value`, `n(value)` or `n()` in an array initialiser.
#[derive(Clone, Debug)]
pub struct ArrayInitItem {
    pub repeat: Option<Expr>,
    pub value: Option<Init>,
    pub span: Span,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PouKind {
    Program,
    FunctionBlock,
    Function,
}

impl PouKind {
    pub fn keyword(self) -> &'static str {
        match self {
            PouKind::Program => "PROGRAM",
            PouKind::FunctionBlock => "FUNCTION_BLOCK",
            PouKind::Function => "FUNCTION",
        }
    }
}

#[derive(Clone, Debug)]
pub struct Pou {
    pub kind: PouKind,
    pub name: Ident,
    /// A FUNCTION's result type.
    pub return_type: Option<TypeSpec>,
    pub var_blocks: Vec<VarBlock>,
    pub body: Body,
    pub span: Span,
    /// Object orientation (docs/iec.md, "Object orientation"): what a FUNCTION_BLOCK
    /// extends and implements, its methods and properties, a PROGRAM's or FB's actions.
    pub oop: Box<PouOop>,
}

/// The object-oriented parts of a POU (all empty for a POU of the standard's second edition).
#[derive(Clone, Debug, Default)]
pub struct PouOop {
    /// `ABSTRACT`, `FINAL` and the access specifier written before the name.
    pub modifiers: Modifiers,
    /// `EXTENDS base`.
    pub extends: Option<Ident>,
    /// `IMPLEMENTS I1, I2`; for an INTERFACE, the interfaces it EXTENDS.
    pub implements: Vec<Ident>,
    /// The POU is an `INTERFACE … END_INTERFACE` (read as a FUNCTION_BLOCK without variables
    /// or body whose methods and properties have no body): docs/iec.md, "Interfaces".
    pub interface: bool,
    pub methods: Vec<Method>,
    pub properties: Vec<Property>,
    pub actions: Vec<Action>,
}

impl PouOop {
    pub fn is_empty(&self) -> bool {
        self.extends.is_none()
            && self.implements.is_empty()
            && self.methods.is_empty()
            && self.properties.is_empty()
            && self.actions.is_empty()
            && !self.interface
    }
}

/// `PUBLIC`, `PRIVATE`, `PROTECTED`, `INTERNAL` (PUBLIC when none is written).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Access {
    #[default]
    Public,
    Private,
    Protected,
    Internal,
}

impl Access {
    pub fn from_word(w: &str) -> Option<Access> {
        Some(match w.to_ascii_uppercase().as_str() {
            "PUBLIC" => Access::Public,
            "PRIVATE" => Access::Private,
            "PROTECTED" => Access::Protected,
            "INTERNAL" => Access::Internal,
            _ => return None,
        })
    }

    pub fn keyword(self) -> &'static str {
        match self {
            Access::Public => "PUBLIC",
            Access::Private => "PRIVATE",
            Access::Protected => "PROTECTED",
            Access::Internal => "INTERNAL",
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Modifiers {
    pub access: Access,
    pub is_abstract: bool,
    pub is_final: bool,
}

/// `METHOD [access] name [: type] … END_METHOD`: `pou` is its interface and body, a
/// FUNCTION-like POU (`return_type` optional) whose `VAR_INST` blocks live in the instance.
#[derive(Clone, Debug)]
pub struct Method {
    pub modifiers: Modifiers,
    pub pou: Pou,
}

/// `PROPERTY [access] name : type`, with a `GET` and/or a `SET` accessor (each a method-like
/// POU: the getter returns the property's type, the setter reads it as an input of that
/// property's name).
#[derive(Clone, Debug)]
pub struct Property {
    pub modifiers: Modifiers,
    pub name: Ident,
    pub ty: TypeSpec,
    pub get: Option<Pou>,
    pub set: Option<Pou>,
    pub span: Span,
}

/// `ACTION name: … END_ACTION` of a PROGRAM or FUNCTION_BLOCK: a body that works on the
/// POU's own variables (TwinCAT's `<Action>`, CODESYS's actions).
#[derive(Clone, Debug)]
pub struct Action {
    pub name: Ident,
    pub body: Body,
    pub span: Span,
}

/// A POU body in the language it was written in.
#[derive(Clone, Debug)]
pub enum Body {
    St(Vec<Stmt>),
    /// Instruction List: the instructions as read (from a `.il` source or a PLCopen `<IL>`
    /// body), lowered by the checker like any other body.
    Il {
        code: Vec<IlInstr>,
        span: Span,
    },
    /// A graphical body (`LD`, `FBD`, `SFC`) from a PLCopen file, kept as its XML for the
    /// graphical front ends.
    Graphical {
        language: GraphicalLanguage,
        xml: crate::xml::Element,
        span: Span,
    },
    /// No body (a PLCopen POU without one).
    Missing(Span),
}

/// One line of Instruction List: an instruction, a label, or the `)` that closes a deferred
/// operation.
#[derive(Clone, Debug)]
pub struct IlInstr {
    pub kind: IlKind,
    pub span: Span,
}

/// `C` or `CN` on JMP, CAL and RET: the instruction runs when the current result is TRUE
/// (`C`) or FALSE (`CN`).
pub type IlCond = Option<bool>;

#[derive(Clone, Debug)]
pub enum IlKind {
    /// `name:`
    Label(Ident),
    /// An operator on the current result: `LD x`, `ANDN x`, `ADD( x`, `NOT`, `ST x`, `S x`.
    Op {
        op: IlOp,
        /// The `N` modifier (`LDN`, `STN`, `ANDN`, `ORN`, `XORN`).
        negated: bool,
        /// `OP(`: the operand is computed by the instructions up to the matching `)`.
        deferred: bool,
        operand: Option<Expr>,
    },
    /// `)`
    Close,
    /// `JMP label`, `JMPC label`, `JMPCN label`.
    Jump { cond: IlCond, label: Ident },
    /// `CAL instance`, `CAL instance(args)` (formal `IN := x, Q => y` or informal `x, y`).
    Call {
        cond: IlCond,
        instance: Expr,
        args: Vec<Arg>,
    },
    /// An input operator of a standard function block: `PT timer`, `CU counter`, `S1 sr`
    /// (the instance is called with that input set to the current result).
    FbInput { input: Ident, instance: Expr },
    /// `RET`, `RETC`, `RETCN`.
    Return { cond: IlCond },
    /// A function: `MAX b, c` (the current result is the first argument) or, with `formal`,
    /// `LIMIT(MN := 0, IN := x, MX := 9)`.
    Function {
        name: Ident,
        args: Vec<Arg>,
        formal: bool,
    },
}

/// The operators of the current result (modifiers apart).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IlOp {
    Ld,
    St,
    S,
    R,
    And,
    Or,
    Xor,
    Not,
    Add,
    Sub,
    Mul,
    Div,
    Mod,
    Gt,
    Ge,
    Eq,
    Ne,
    Le,
    Lt,
}

impl IlOp {
    pub fn name(self) -> &'static str {
        match self {
            IlOp::Ld => "LD",
            IlOp::St => "ST",
            IlOp::S => "S",
            IlOp::R => "R",
            IlOp::And => "AND",
            IlOp::Or => "OR",
            IlOp::Xor => "XOR",
            IlOp::Not => "NOT",
            IlOp::Add => "ADD",
            IlOp::Sub => "SUB",
            IlOp::Mul => "MUL",
            IlOp::Div => "DIV",
            IlOp::Mod => "MOD",
            IlOp::Gt => "GT",
            IlOp::Ge => "GE",
            IlOp::Eq => "EQ",
            IlOp::Ne => "NE",
            IlOp::Le => "LE",
            IlOp::Lt => "LT",
        }
    }

    /// The ST operator an operation with an operand is (LD, ST, S, R, NOT have none).
    pub fn binary(self) -> Option<BinaryOp> {
        Some(match self {
            IlOp::And => BinaryOp::And,
            IlOp::Or => BinaryOp::Or,
            IlOp::Xor => BinaryOp::Xor,
            IlOp::Add => BinaryOp::Add,
            IlOp::Sub => BinaryOp::Sub,
            IlOp::Mul => BinaryOp::Mul,
            IlOp::Div => BinaryOp::Div,
            IlOp::Mod => BinaryOp::Mod,
            IlOp::Gt => BinaryOp::Gt,
            IlOp::Ge => BinaryOp::Ge,
            IlOp::Eq => BinaryOp::Eq,
            IlOp::Ne => BinaryOp::Ne,
            IlOp::Le => BinaryOp::Le,
            IlOp::Lt => BinaryOp::Lt,
            _ => return None,
        })
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GraphicalLanguage {
    Ld,
    Fbd,
    Sfc,
}

impl GraphicalLanguage {
    pub fn name(self) -> &'static str {
        match self {
            GraphicalLanguage::Ld => "LD",
            GraphicalLanguage::Fbd => "FBD",
            GraphicalLanguage::Sfc => "SFC",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarKind {
    Input,
    Output,
    InOut,
    /// `VAR`
    Local,
    Temp,
    External,
    Global,
    /// `VAR_INST` of a METHOD: kept in the function block instance between calls.
    Inst,
    /// `VAR_STAT` (CODESYS, TwinCAT): one variable for all calls and instances of the POU,
    /// kept as a hidden global (docs/iec.md, "Static variables").
    Stat,
    /// `VAR_ACCESS`, `VAR_CONFIG` (reported as not supported).
    Other,
}

impl VarKind {
    pub fn keyword(self) -> &'static str {
        match self {
            VarKind::Input => "VAR_INPUT",
            VarKind::Output => "VAR_OUTPUT",
            VarKind::InOut => "VAR_IN_OUT",
            VarKind::Local => "VAR",
            VarKind::Temp => "VAR_TEMP",
            VarKind::External => "VAR_EXTERNAL",
            VarKind::Global => "VAR_GLOBAL",
            VarKind::Inst => "VAR_INST",
            VarKind::Stat => "VAR_STAT",
            VarKind::Other => "VAR_ACCESS",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Retain {
    #[default]
    Unspecified,
    Retain,
    NonRetain,
}

#[derive(Clone, Debug)]
pub struct VarBlock {
    pub kind: VarKind,
    pub constant: bool,
    pub retain: Retain,
    pub vars: Vec<VarDecl>,
    /// The name of the global variable list holding a top-level VAR_GLOBAL block (a TwinCAT
    /// GVL object's `Name`), by which `LIST.x` names its variables.
    pub list: Option<Ident>,
    pub span: Span,
}

/// `a, b AT %IX0.0 : INT := 5;`
#[derive(Clone, Debug)]
pub struct VarDecl {
    pub names: Vec<Ident>,
    pub location: Option<Location>,
    pub ty: TypeSpec,
    pub init: Option<Init>,
    /// `R_EDGE`/`F_EDGE` on a BOOL input.
    pub edge: Option<Edge>,
    /// CODESYS's and TwinCAT's `fb : FB_X(10, b := 2);`: the arguments its FB_init method is
    /// called with when the program starts (iec-sema's `fb_init.rs`).
    pub fb_init: Option<Vec<Arg>>,
    pub span: Span,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edge {
    Rising,
    Falling,
}

/// `AT %…`: the text after the percent sign.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    pub text: String,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub struct Stmt {
    pub kind: StmtKind,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub enum StmtKind {
    Assign {
        target: Expr,
        value: Expr,
    },
    /// CODESYS's `r REF= x`: binds the REFERENCE TO `r` to the variable `x`.
    RefAssign {
        target: Expr,
        value: Expr,
    },
    /// A function or function block call as a statement.
    Call(Call),
    If {
        branches: Vec<(Expr, Vec<Stmt>)>,
        else_body: Option<Vec<Stmt>>,
    },
    Case {
        selector: Expr,
        arms: Vec<CaseArm>,
        else_body: Option<Vec<Stmt>>,
    },
    For {
        /// The control variable: a name, or (CODESYS, TwinCAT: TcUnit's `FOR Offset[1] :=`)
        /// an element or field of a variable (boxed: the statement stays small).
        var: Box<Expr>,
        from: Expr,
        to: Expr,
        by: Option<Expr>,
        body: Vec<Stmt>,
    },
    While {
        cond: Expr,
        body: Vec<Stmt>,
    },
    Repeat {
        body: Vec<Stmt>,
        until: Expr,
    },
    Exit,
    Continue,
    Return,
    /// A lone `;`.
    Empty,
}

#[derive(Clone, Debug)]
pub struct CaseArm {
    pub labels: Vec<CaseLabel>,
    pub body: Vec<Stmt>,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub enum CaseLabel {
    Value(Expr),
    Range(Expr, Expr),
}

impl CaseLabel {
    pub fn span(&self) -> Span {
        match self {
            CaseLabel::Value(e) => e.span,
            CaseLabel::Range(a, b) => a.span.to(b.span),
        }
    }
}

/// `callee(args)`.
#[derive(Clone, Debug)]
pub struct Call {
    /// A name (`MAX`, `timer1`) or a path to an instance (`a.b.timer`, `fbs[i]`).
    pub callee: Box<Expr>,
    pub args: Vec<Arg>,
    pub span: Span,
}

/// `value`, `name := value`, `name => variable`, `NOT name => variable`.
#[derive(Clone, Debug)]
pub struct Arg {
    pub name: Option<Ident>,
    /// `=>`: an output connected to a variable.
    pub output: bool,
    /// `NOT name => v`.
    pub negated: bool,
    /// `None` for an output left unconnected (`Q =>`).
    pub value: Option<Expr>,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub enum ExprKind {
    Literal(Literal),
    /// A variable, constant, enumeration value or POU name.
    Name(Ident),
    /// `a.b`
    Field(Box<Expr>, Ident),
    /// `x.3`: one bit of a bit string (or integer).
    Bit(Box<Expr>, u32),
    /// `x.%B1`, `x.%W0`, `x.%D1`: a byte, word or double word of a bit string (IEC
    /// 61131-3's partial access): the part's size in bits (8, 16, 32), then its index.
    Part(Box<Expr>, u32, u32),
    /// `a[i, j]`
    Index(Box<Expr>, Vec<Expr>),
    Call(Call),
    Unary(UnaryOp, Box<Expr>),
    Binary(BinaryOp, Box<Expr>, Box<Expr>),
    /// `(e)`: kept so a negated literal in parentheses stays distinguishable.
    Paren(Box<Expr>),
    /// A direct variable `%IX0.1` used in code.
    Direct(String),
    /// `r^`: what a reference or pointer designates.
    Deref(Box<Expr>),
    /// A parse error; the checker skips it silently.
    Error,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnaryOp {
    Neg,
    Plus,
    Not,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinaryOp {
    Or,
    Xor,
    And,
    /// CODESYS's `AND_THEN`: AND on BOOL whose right operand is not evaluated when the left
    /// is FALSE.
    AndThen,
    /// CODESYS's `OR_ELSE`: OR on BOOL whose right operand is not evaluated when the left is
    /// TRUE.
    OrElse,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    Add,
    Sub,
    Mul,
    Div,
    Mod,
    Power,
}

impl BinaryOp {
    pub fn text(self) -> &'static str {
        match self {
            BinaryOp::Or => "OR",
            BinaryOp::Xor => "XOR",
            BinaryOp::And => "AND",
            BinaryOp::AndThen => "AND_THEN",
            BinaryOp::OrElse => "OR_ELSE",
            BinaryOp::Eq => "=",
            BinaryOp::Ne => "<>",
            BinaryOp::Lt => "<",
            BinaryOp::Le => "<=",
            BinaryOp::Gt => ">",
            BinaryOp::Ge => ">=",
            BinaryOp::Add => "+",
            BinaryOp::Sub => "-",
            BinaryOp::Mul => "*",
            BinaryOp::Div => "/",
            BinaryOp::Mod => "MOD",
            BinaryOp::Power => "**",
        }
    }

    pub fn is_comparison(self) -> bool {
        matches!(
            self,
            BinaryOp::Eq | BinaryOp::Ne | BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge
        )
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum Literal {
    /// An integer (`5`, `16#FF`), typed when written `INT#5` (negative only when typed:
    /// `INT#-5`; an untyped `-5` is a negation of `5`).
    Int {
        value: i128,
        ty: Option<Ident>,
    },
    Real {
        value: f64,
        ty: Option<Ident>,
    },
    Bool {
        value: bool,
        ty: Option<Ident>,
    },
    /// `'…'` (Windows-1252 bytes) or `"…"` (`wide`: UTF-8), with its prefix if typed
    /// (`STRING#'…'`, `WSTRING#"…"`).
    String {
        bytes: Vec<u8>,
        wide: bool,
        ty: Option<Ident>,
    },
    /// Durations, dates and times of day in nanoseconds.
    Time {
        kind: crate::lexer::TimeKind,
        nanos: i128,
    },
    /// `Color#Red`.
    Enum {
        ty: Ident,
        value: Ident,
    },
}

/// `CONFIGURATION name … END_CONFIGURATION`.
#[derive(Clone, Debug)]
pub struct Configuration {
    pub name: Ident,
    pub globals: Vec<VarBlock>,
    pub resources: Vec<Resource>,
    /// `VAR_CONFIG … END_VAR` entries: instance variables' initial values by path.
    pub var_config: Vec<VarConfigItem>,
    pub span: Span,
}

/// `resource.instance.fb.var [AT %QB1] : TYPE := value;` in VAR_CONFIG.
#[derive(Clone, Debug)]
pub struct VarConfigItem {
    pub path: Vec<Ident>,
    pub location: Option<Location>,
    pub ty: TypeSpec,
    pub init: Option<Init>,
    pub span: Span,
}

/// A `RESOURCE` (or the configuration's own tasks and programs when it has no RESOURCE).
#[derive(Clone, Debug)]
pub struct Resource {
    pub name: Ident,
    /// `ON processor`.
    pub on: Option<Ident>,
    pub globals: Vec<VarBlock>,
    pub tasks: Vec<Task>,
    pub programs: Vec<ProgramConfig>,
    pub span: Span,
}

/// `TASK name (INTERVAL := T#10ms, PRIORITY := 1);`
#[derive(Clone, Debug)]
pub struct Task {
    pub name: Ident,
    pub interval: Option<Expr>,
    pub single: Option<Expr>,
    pub priority: Option<Expr>,
    pub span: Span,
}

/// `PROGRAM [RETAIN] name [WITH task] : type [(connections)];`
#[derive(Clone, Debug)]
pub struct ProgramConfig {
    pub name: Ident,
    pub retain: Retain,
    pub task: Option<Ident>,
    pub type_name: Ident,
    pub args: Vec<Arg>,
    pub span: Span,
}
