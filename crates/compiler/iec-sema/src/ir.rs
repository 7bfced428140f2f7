//! The checked, lowered form: what every IEC 61131-3 language compiles to and what the VM
//! compiles to bytecode. Names are resolved to indices, every expression carries its type,
//! implicit conversions are explicit ([`ExprKind::Convert`]), calls list their parameters by
//! index with defaults filled in, and CASE labels are folded to integer ranges.
//!
//! Structured Text maps onto it statement for statement. Instruction List (its accumulator
//! becomes temporaries, its jumps [`StmtKind::Label`]/[`StmtKind::Goto`]) and the graphical
//! languages (networks become assignments and calls, SFC steps flags and timers) lower into
//! the same form, so the checker's rules and the VM are shared (issue 17).

use std::collections::BTreeSet;

use petriplc_iec_syntax::source::Span;

pub use petriplc_iec_syntax::ast::{BinaryOp, PouKind, UnaryOp};

use crate::types::{Elem, FbRef, TypeId, TypeTable};
use crate::value::Value;

pub type PouId = u32;
pub type VarId = u32;
pub type GlobalId = u32;

/// A checked project: every type, POU, global variable, task and program instance.
#[derive(Clone, Debug)]
pub struct Project {
    pub types: TypeTable,
    pub pous: Vec<Pou>,
    /// Function blocks built into the engine that the project may use, indexed by
    /// [`FbRef::Native`].
    pub natives: Vec<NativeSig>,
    pub globals: Vec<Var>,
    pub configuration: Option<Configuration>,
    /// What integer overflow does when the project runs ([`crate::Options::overflow`]).
    pub overflow: Overflow,
    /// POUs that a call through an interface may enter again while they run (W050): the
    /// engine faults if one is (its frame is static).
    pub guarded: BTreeSet<PouId>,
}

impl Project {
    pub fn pou(&self, id: PouId) -> &Pou {
        &self.pous[id as usize]
    }

    /// A POU by name (case-insensitive).
    pub fn pou_by_name(&self, name: &str) -> Option<PouId> {
        self.pous
            .iter()
            .position(|p| p.name.eq_ignore_ascii_case(name))
            .map(|i| i as PouId)
    }

    /// The PROGRAM POUs, in source order.
    pub fn programs(&self) -> impl Iterator<Item = (PouId, &Pou)> {
        self.pous
            .iter()
            .enumerate()
            .filter(|(_, p)| p.kind == PouKind::Program)
            .map(|(i, p)| (i as PouId, p))
    }

    pub fn global_by_name(&self, name: &str) -> Option<GlobalId> {
        self.globals
            .iter()
            .position(|g| g.name.eq_ignore_ascii_case(name))
            .map(|i| i as GlobalId)
    }
}

#[derive(Clone, Debug)]
pub struct Pou {
    pub name: String,
    pub kind: PouKind,
    /// Parameters first (inputs, in-outs and outputs in declaration order), then the others.
    pub vars: Vec<Var>,
    /// A FUNCTION's result variable.
    pub result: Option<VarId>,
    pub body: Vec<Stmt>,
    pub span: Span,
    /// `false` when the body is in a language the engine does not run yet: it must not be
    /// instantiated or called (the checker reports that where it happens).
    pub runnable: bool,
}

impl Pou {
    pub fn var_by_name(&self, name: &str) -> Option<VarId> {
        self.vars
            .iter()
            .position(|v| v.name.eq_ignore_ascii_case(name))
            .map(|i| i as VarId)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarClass {
    Input,
    Output,
    InOut,
    Local,
    Temp,
    /// A reference to a global variable.
    External(GlobalId),
    Global,
    /// A FUNCTION's result.
    Result,
    /// A variable the checker adds (e.g. the previous value of an R_EDGE input).
    Hidden,
}

#[derive(Clone, Debug)]
pub struct Var {
    pub name: String,
    pub ty: TypeId,
    pub class: VarClass,
    /// The initial value; `None` is the type's own (its declared initial value, else zero,
    /// FALSE, empty, the first enumeration value, a subrange's lower bound).
    pub init: Option<Value>,
    pub constant: bool,
    pub retain: bool,
    /// `AT %…`, the text after the percent sign.
    pub location: Option<String>,
    pub span: Span,
}

impl Var {
    /// A variable the checker adds (`VarClass::Hidden`): no initial value but its type's, not
    /// constant, retained or located.
    pub fn hidden(name: String, ty: TypeId, span: Span) -> Var {
        Var {
            name,
            ty,
            class: VarClass::Hidden,
            init: None,
            constant: false,
            retain: false,
            location: None,
            span,
        }
    }
}

#[derive(Clone, Debug)]
pub struct Stmt {
    pub kind: StmtKind,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub enum StmtKind {
    Assign {
        target: Place,
        value: Expr,
    },
    CallFb(Box<FbCall>),
    /// A function called for its effects (outputs, in-outs); the result is dropped.
    Eval(Expr),
    If {
        branches: Vec<(Expr, Vec<Stmt>)>,
        else_body: Vec<Stmt>,
    },
    Case {
        selector: Expr,
        arms: Vec<CaseArm>,
        else_body: Vec<Stmt>,
    },
    /// Bounds and step are evaluated once, before the first iteration.
    For(Box<ForLoop>),
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
    /// A jump target (IL labels, SFC).
    Label(u32),
    /// A jump, when `cond` (if any) equals the flag.
    Goto {
        label: u32,
        cond: Option<(Expr, bool)>,
    },
}

#[derive(Clone, Debug)]
pub struct ForLoop {
    pub var: Place,
    pub from: Expr,
    pub to: Expr,
    pub by: Expr,
    pub body: Vec<Stmt>,
}

#[derive(Clone, Debug)]
pub struct CaseArm {
    /// Inclusive ranges of selector values (a single label is `(v, v)`).
    pub ranges: Vec<(i128, i128)>,
    pub body: Vec<Stmt>,
}

/// Something that can be read and written: a variable and a path into it.
#[derive(Clone, Debug)]
pub struct Place {
    pub root: Root,
    pub path: Vec<Step>,
    pub ty: TypeId,
    pub span: Span,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Root {
    /// A variable of the POU the code belongs to.
    Var(VarId),
    Global(GlobalId),
    /// The whole instance of the function block (or program) whose own body this is:
    /// `THIS^`, and the instance a method or action called inside the body works on.
    This,
    /// A reference computed by an expression, which is the path's first step
    /// ([`Step::Value`]): a call giving a REFERENCE TO (`obj.Get().x`), `f()^`, `(p + 2)^`,
    /// CODESYS's pointer indexing `p[i]`. The path goes on with [`Step::Deref`].
    Value,
}

#[derive(Clone, Debug)]
pub enum Step {
    /// A structure's field, by index.
    Field(u32),
    /// A variable of a function block instance (its inputs and outputs), by index.
    Member(u32),
    /// Array subscripts, one per dimension (integer expressions).
    Index(Vec<Expr>),
    /// One bit of a bit string or integer.
    Bit(u32),
    /// `width` bits from bit `lo` of a bit string, as BYTE, WORD or DWORD (`.%B1` is
    /// `Bits(8, 8)`).
    Bits(u32, u32),
    /// What the reference or pointer here designates (checked when the program runs: not
    /// NULL, of the designated type).
    Deref,
    /// Member `member` (of type `ty`) of the UNION `union`, at byte 0 of the union's bytes:
    /// read and written through a view of the union's byte image, as a pointer of another
    /// type is.
    Overlay {
        union: TypeId,
        member: u32,
        ty: TypeId,
    },
    /// The reference a [`Root::Value`] place starts from (only as that place's first step),
    /// evaluated where the place is.
    Value(Box<Expr>),
}

#[derive(Clone, Debug)]
pub struct Expr {
    pub kind: ExprKind,
    pub ty: TypeId,
    pub span: Span,
}

impl Expr {
    /// Levels of the tree, subscripts and call arguments included (counted without
    /// recursion, so any tree can be measured).
    pub fn depth(&self) -> usize {
        fn place<'e>(p: &'e Place, d: usize, todo: &mut Vec<(&'e Expr, usize)>) {
            for s in &p.path {
                match s {
                    Step::Index(ix) => todo.extend(ix.iter().map(|i| (i, d))),
                    Step::Value(x) => todo.push((x, d)),
                    _ => {}
                }
            }
        }
        let mut most = 0;
        let mut todo = vec![(self, 1)];
        while let Some((e, d)) = todo.pop() {
            most = most.max(d);
            match &e.kind {
                ExprKind::Const(_) => {}
                ExprKind::Load(p) | ExprKind::Ref(p) => place(p, d + 1, &mut todo),
                ExprKind::Unary(_, x) | ExprKind::Convert(x) | ExprKind::Trunc(x) => {
                    todo.push((x, d + 1))
                }
                ExprKind::Binary(_, a, b) => todo.extend([(&**a, d + 1), (&**b, d + 1)]),
                ExprKind::Call(c) => {
                    todo.extend(c.inputs.iter().map(|(_, x)| (x, d + 1)));
                    for (_, p) in c.in_outs.iter().chain(&c.outputs) {
                        place(p, d + 1, &mut todo);
                    }
                }
                ExprKind::Builtin(_, args) => todo.extend(args.iter().map(|x| (x, d + 1))),
            }
        }
        most
    }
}

#[derive(Clone, Debug)]
pub enum ExprKind {
    Const(Value),
    Load(Place),
    /// `Neg` on numbers and durations; `Not` on BOOL and bit strings (bitwise).
    Unary(UnaryOp, Box<Expr>),
    /// Operands have the same type except for time arithmetic (TIME * number, TOD + TIME,
    /// DT - DT, …); comparisons give BOOL.
    Binary(BinaryOp, Box<Expr>, Box<Expr>),
    /// A conversion from the operand's type to this expression's.
    Convert(Box<Expr>),
    /// Truncation of a real toward zero, to this expression's integer type.
    Trunc(Box<Expr>),
    Call(FnCall),
    Builtin(Builtin, Vec<Expr>),
    /// `REF(x)`, `ADR(x)`: a reference to a place with a lasting address (this
    /// expression's type is the reference type).
    Ref(Place),
}

/// A call of a user FUNCTION: every input given (defaults filled in).
#[derive(Clone, Debug)]
pub struct FnCall {
    pub pou: PouId,
    pub inputs: Vec<(VarId, Expr)>,
    pub in_outs: Vec<(VarId, Place)>,
    pub outputs: Vec<(VarId, Place)>,
}

/// A call of a function block instance: inputs not given keep their values.
#[derive(Clone, Debug)]
pub struct FbCall {
    pub instance: Place,
    pub fb: FbRef,
    pub inputs: Vec<(VarId, Expr)>,
    pub in_outs: Vec<(VarId, Place)>,
    /// Outputs copied after the call (`Q => x`; negated with `NOT Q => x`).
    pub outputs: Vec<(VarId, Place, bool)>,
}

/// Standard functions the VM implements directly, over concrete argument types.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Builtin {
    Abs,
    Sqrt,
    Ln,
    Log,
    Exp,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Atan2,
    Expt,
    /// SEL(G, IN0, IN1)
    Sel,
    Max,
    Min,
    /// LIMIT(MN, IN, MX)
    Limit,
    /// MUX(K, IN0, …)
    Mux,
    Shl,
    Shr,
    Rol,
    Ror,
    Len,
    Left,
    Right,
    Mid,
    Concat,
    Insert,
    Delete,
    Replace,
    Find,
    /// CONCAT_DATE_TOD(D, TOD) → DT
    ConcatDateTod,
    /// DT → TOD
    DtToTod,
    /// DT → DATE
    DtToDate,
    /// BCD digits (a bit string) → the integer they spell: `WORD_BCD_TO_INT`.
    BcdToInt,
    /// An integer → its BCD digits (a bit string): `INT_TO_BCD_WORD`.
    IntToBcd,
    /// CODESYS `TIME()`: the scan's clock (vendor library `codesys`).
    Time,
    /// PCWorx `GET_CHAR(string, position)` → INT (vendor library `pcworx`).
    GetChar,
    /// PCWorx `X_TO_STRING(value, format)`: the value by a C printf format.
    Format,
    /// TwinCAT `F_ToCHR(code)`: the one-character string of a code ('' for 0).
    Chr,
    /// CODESYS/TwinCAT MEMCPY(dest, src, n): `n` bytes through pointers.
    MemCpy,
    /// MEMSET(dest, fill, n).
    MemSet,
    /// MEMCMP(a, b, n): -1, 0 or 1.
    MemCmp,
    /// `__NEW`: a new object of the result's target type (an argument: the count of an
    /// array of them), NULL when the dynamic memory is full.
    New,
    /// `__DELETE`: the object its argument (a pointer, given by `Load` of the variable when
    /// it has one, which is then set to NULL) designates is freed.
    Free,
    /// The memory area of a pointer (UDINT: 0 unknown, 1 static, 2 dynamic).
    MemArea,
    /// A pointer's handle as a number (ULINT), which converts back to no pointer: CODESYS's
    /// and TwinCAT's conversions of a pointer to a number or a string.
    Address,
    /// The interface handle given, a fault when it is NULL (a call through an interface).
    ItfCheck,
    /// The type id of the instance an interface handle designates (DINT; -1 for NULL): the
    /// selector of an interface member's dispatch.
    ItfType,
    /// A bound of an ARRAY[*] in-out: its arguments the array (a `Load` of the in-out,
    /// never read as a value), the dimension from 1, and 1 for the upper bound, 0 for the
    /// lower (DINT constants).
    Bound,
}

impl Builtin {
    pub fn name(self) -> &'static str {
        match self {
            Builtin::Abs => "ABS",
            Builtin::Sqrt => "SQRT",
            Builtin::Ln => "LN",
            Builtin::Log => "LOG",
            Builtin::Exp => "EXP",
            Builtin::Sin => "SIN",
            Builtin::Cos => "COS",
            Builtin::Tan => "TAN",
            Builtin::Asin => "ASIN",
            Builtin::Acos => "ACOS",
            Builtin::Atan => "ATAN",
            Builtin::Atan2 => "ATAN2",
            Builtin::Expt => "EXPT",
            Builtin::Sel => "SEL",
            Builtin::Max => "MAX",
            Builtin::Min => "MIN",
            Builtin::Limit => "LIMIT",
            Builtin::Mux => "MUX",
            Builtin::Shl => "SHL",
            Builtin::Shr => "SHR",
            Builtin::Rol => "ROL",
            Builtin::Ror => "ROR",
            Builtin::Len => "LEN",
            Builtin::Left => "LEFT",
            Builtin::Right => "RIGHT",
            Builtin::Mid => "MID",
            Builtin::Concat => "CONCAT",
            Builtin::Insert => "INSERT",
            Builtin::Delete => "DELETE",
            Builtin::Replace => "REPLACE",
            Builtin::Find => "FIND",
            Builtin::ConcatDateTod => "CONCAT_DATE_TOD",
            Builtin::DtToTod => "DT_TO_TOD",
            Builtin::DtToDate => "DT_TO_DATE",
            Builtin::BcdToInt => "BCD_TO_*",
            Builtin::IntToBcd => "*_TO_BCD",
            Builtin::Time => "TIME",
            Builtin::GetChar => "GET_CHAR",
            Builtin::Format => "X_TO_STRING",
            Builtin::Chr => "F_ToCHR",
            Builtin::MemCpy => "MEMCPY",
            Builtin::MemSet => "MEMSET",
            Builtin::MemCmp => "MEMCMP",
            Builtin::New => "__NEW",
            Builtin::Free => "__DELETE",
            Builtin::MemArea => "__MEMORYAREA",
            Builtin::Address => "pointer as a number",
            Builtin::ItfCheck => "interface call",
            Builtin::ItfType => "interface dispatch",
            Builtin::Bound => "LOWER_BOUND/UPPER_BOUND",
        }
    }
}

/// The interface of a function block implemented in Rust: its variables, all elementary
/// (inputs, outputs, and the state it keeps between calls).
#[derive(Clone, Debug, PartialEq)]
pub struct NativeSig {
    pub name: String,
    pub vars: Vec<NativeVar>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct NativeVar {
    pub name: String,
    pub ty: Elem,
    pub kind: NativeVarKind,
    pub init: Value,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NativeVarKind {
    Input,
    Output,
    /// State kept between calls, invisible to programs.
    State,
}

impl NativeSig {
    pub fn var_by_name(&self, name: &str) -> Option<VarId> {
        self.vars
            .iter()
            .position(|v| v.kind != NativeVarKind::State && v.name.eq_ignore_ascii_case(name))
            .map(|i| i as VarId)
    }
}

/// A checked CONFIGURATION.
#[derive(Clone, Debug)]
pub struct Configuration {
    pub name: String,
    pub tasks: Vec<Task>,
    pub programs: Vec<ProgramInstance>,
    /// VAR_CONFIG's initial values of instance variables.
    pub var_config: Vec<VarConfig>,
    pub span: Span,
}

/// `resource.instance.var : TYPE := value;` in VAR_CONFIG, checked: the variable's path
/// from the instance (`inst.fb.x`), its type and the value it starts with.
#[derive(Clone, Debug)]
pub struct VarConfig {
    pub path: String,
    pub ty: TypeId,
    pub value: Value,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub struct Task {
    pub name: String,
    /// Cyclic period in nanoseconds (`None`: the task runs every scan).
    pub interval: Option<i64>,
    /// Lower numbers run first.
    pub priority: i64,
    /// An event task (`SINGLE := v`): the global BOOL whose rising edge, seen at the start
    /// of a scan, runs the task's programs once in that scan (no interval then).
    pub single: Option<GlobalId>,
    pub span: Span,
}

/// `PROGRAM name WITH task : type (connections);`
#[derive(Clone, Debug)]
pub struct ProgramInstance {
    pub name: String,
    pub pou: PouId,
    pub task: Option<u32>,
    /// Inputs set from global expressions before each run.
    pub inputs: Vec<(VarId, Expr)>,
    /// Outputs copied to global variables after each run.
    pub outputs: Vec<(VarId, Place)>,
    pub retain: bool,
    pub span: Span,
}

/// What an integer result outside its type does: the project's choice (`Sources::overflow`,
/// `petriplc sim --overflow`, the `iec` module's `overflow` setting).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Overflow {
    /// Two's complement in the result's type, as CODESYS, TwinCAT, matiec and OpenPLC; shift
    /// counts read as unsigned; REAL to integer out of range keeps the low bits.
    #[default]
    Wrap,
    /// A run-time fault, handled by the module's `on_failure`.
    Fault,
}

impl Overflow {
    /// `wrap` or `fault`, as the flag and the setting spell it.
    pub fn parse(text: &str) -> Option<Overflow> {
        match text.trim().to_ascii_lowercase().as_str() {
            "wrap" => Some(Overflow::Wrap),
            "fault" => Some(Overflow::Fault),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Overflow::Wrap => "wrap",
            Overflow::Fault => "fault",
        }
    }
}
