//! Transition guards: boolean expressions over input signals in IEC 61131-3 style
//! (`B1 AND NOT N2 OR (X AND Y)`, also `!`, `&`, `|`, `XOR`, and integer comparisons
//! such as `Level >= 3`).
//!
//! Precedence follows IEC 61131-3 ST: `NOT` binds tightest, then comparisons, `AND`, `XOR`,
//! `OR`. A parse error carries the 1-based column where it went wrong.

use std::fmt;

use crate::ids::SignalId;

/// A comparison between two integer operands.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CmpOp {
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
}

impl CmpOp {
    pub fn symbol(self) -> &'static str {
        match self {
            CmpOp::Eq => "=",
            CmpOp::Ne => "<>",
            CmpOp::Lt => "<",
            CmpOp::Le => "<=",
            CmpOp::Gt => ">",
            CmpOp::Ge => ">=",
        }
    }

    pub fn apply(self, a: i64, b: i64) -> bool {
        match self {
            CmpOp::Eq => a == b,
            CmpOp::Ne => a != b,
            CmpOp::Lt => a < b,
            CmpOp::Le => a <= b,
            CmpOp::Gt => a > b,
            CmpOp::Ge => a >= b,
        }
    }
}

/// An operand of a comparison.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Operand<S> {
    Signal(S),
    Literal(i64),
}

/// A guard expression over signals named by `S` (a `String` before resolution, a
/// [`SignalId`] inside a net).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Expr<S> {
    Const(bool),
    /// A signal read as a boolean: TRUE when its value is not 0.
    Signal(S),
    Not(Box<Expr<S>>),
    And(Box<Expr<S>>, Box<Expr<S>>),
    Xor(Box<Expr<S>>, Box<Expr<S>>),
    Or(Box<Expr<S>>, Box<Expr<S>>),
    Cmp(Operand<S>, CmpOp, Operand<S>),
}

/// A syntax error in a guard, at a 1-based character column.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("column {column}: {message}")]
pub struct GuardError {
    pub column: usize,
    pub message: String,
}

/// A transition's firing condition; TRUE when absent.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Guard(pub Expr<SignalId>);

impl Default for Guard {
    fn default() -> Self {
        Guard(Expr::Const(true))
    }
}

impl Guard {
    /// True when the guard is the constant TRUE (the default).
    pub fn is_true(&self) -> bool {
        self.0 == Expr::Const(true)
    }

    /// Evaluates the guard; `values` is indexed by [`SignalId`].
    #[inline]
    pub fn eval(&self, values: &[i64]) -> bool {
        self.0.eval(&|s: &SignalId| values[s.index()])
    }

    /// Every signal the guard reads, in order of first appearance, without repeats.
    pub fn signals(&self) -> Vec<SignalId> {
        let mut out = Vec::new();
        self.0.visit_signals(&mut |s| {
            if !out.contains(s) {
                out.push(*s);
            }
        });
        out
    }
}

/// A guard compiled once into postfix form over a stack of bits, for the scans that evaluate
/// it every cycle: no boxes to follow and no recursion. It means exactly what
/// [`Guard::eval`] means (tested against it on random guards).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FlatGuard {
    ops: Vec<FlatOp>,
    /// Kept for the rare guard whose evaluation stack would not fit in 64 bits.
    deep: Option<Expr<SignalId>>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FlatOp {
    Const(bool),
    Signal(u32),
    NotSignal(u32),
    Not,
    And,
    Or,
    Xor,
    Cmp(FlatOperand, CmpOp, FlatOperand),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FlatOperand {
    Signal(u32),
    Literal(i64),
}

impl FlatGuard {
    /// Compiles `guard`.
    pub fn new(guard: &Guard) -> FlatGuard {
        let mut ops = Vec::new();
        let mut depth = 0usize;
        let mut most = 0usize;
        flatten(&guard.0, &mut ops, &mut depth, &mut most);
        FlatGuard {
            deep: (most > 64).then(|| guard.0.clone()),
            ops,
        }
    }

    /// Evaluates the guard; `values` is indexed by [`SignalId`].
    #[inline]
    pub fn eval(&self, values: &[i64]) -> bool {
        let operand = |o: FlatOperand| match o {
            FlatOperand::Signal(s) => values[s as usize],
            FlatOperand::Literal(v) => v,
        };
        match self.ops.as_slice() {
            [FlatOp::Const(b)] => return *b,
            [FlatOp::Signal(s)] => return values[*s as usize] != 0,
            [FlatOp::NotSignal(s)] => return values[*s as usize] == 0,
            _ => {}
        }
        if let Some(e) = &self.deep {
            return e.eval(&|s: &SignalId| values[s.index()]);
        }
        // Bit 0 is the top of the stack.
        let mut st: u64 = 0;
        for &op in &self.ops {
            match op {
                FlatOp::Const(b) => st = (st << 1) | u64::from(b),
                FlatOp::Signal(s) => st = (st << 1) | u64::from(values[s as usize] != 0),
                FlatOp::NotSignal(s) => st = (st << 1) | u64::from(values[s as usize] == 0),
                FlatOp::Cmp(a, c, b) => st = (st << 1) | u64::from(c.apply(operand(a), operand(b))),
                FlatOp::Not => st ^= 1,
                FlatOp::And => {
                    let b = st & 1;
                    st >>= 1;
                    st &= !1 | b;
                }
                FlatOp::Or => {
                    let b = st & 1;
                    st >>= 1;
                    st |= b;
                }
                FlatOp::Xor => {
                    let b = st & 1;
                    st >>= 1;
                    st ^= b;
                }
            }
        }
        st & 1 == 1
    }
}

/// Appends `e` in postfix form, tracking the evaluation stack's depth.
fn flatten(e: &Expr<SignalId>, ops: &mut Vec<FlatOp>, depth: &mut usize, most: &mut usize) {
    let operand = |o: &Operand<SignalId>| match o {
        Operand::Signal(s) => FlatOperand::Signal(s.0),
        Operand::Literal(v) => FlatOperand::Literal(*v),
    };
    let mut push = |ops: &mut Vec<FlatOp>, op: FlatOp| {
        ops.push(op);
        *depth += 1;
        *most = (*most).max(*depth);
    };
    match e {
        Expr::Const(b) => push(ops, FlatOp::Const(*b)),
        Expr::Signal(s) => push(ops, FlatOp::Signal(s.0)),
        Expr::Cmp(a, c, b) => push(ops, FlatOp::Cmp(operand(a), *c, operand(b))),
        Expr::Not(inner) => match inner.as_ref() {
            Expr::Signal(s) => push(ops, FlatOp::NotSignal(s.0)),
            _ => {
                flatten(inner, ops, depth, most);
                ops.push(FlatOp::Not);
            }
        },
        Expr::And(a, b) | Expr::Or(a, b) | Expr::Xor(a, b) => {
            flatten(a, ops, depth, most);
            flatten(b, ops, depth, most);
            ops.push(match e {
                Expr::And(..) => FlatOp::And,
                Expr::Or(..) => FlatOp::Or,
                _ => FlatOp::Xor,
            });
            *depth -= 1;
        }
    }
}

impl<S> Expr<S> {
    /// Evaluates with `value` giving each signal's value.
    pub fn eval(&self, value: &impl Fn(&S) -> i64) -> bool {
        match self {
            Expr::Const(b) => *b,
            Expr::Signal(s) => value(s) != 0,
            Expr::Not(e) => !e.eval(value),
            Expr::And(a, b) => a.eval(value) && b.eval(value),
            Expr::Xor(a, b) => a.eval(value) != b.eval(value),
            Expr::Or(a, b) => a.eval(value) || b.eval(value),
            Expr::Cmp(a, op, b) => {
                let get = |o: &Operand<S>| match o {
                    Operand::Signal(s) => value(s),
                    Operand::Literal(v) => *v,
                };
                op.apply(get(a), get(b))
            }
        }
    }

    pub fn visit_signals(&self, f: &mut impl FnMut(&S)) {
        match self {
            Expr::Const(_) => {}
            Expr::Signal(s) => f(s),
            Expr::Not(e) => e.visit_signals(f),
            Expr::And(a, b) | Expr::Xor(a, b) | Expr::Or(a, b) => {
                a.visit_signals(f);
                b.visit_signals(f);
            }
            Expr::Cmp(a, _, b) => {
                for o in [a, b] {
                    if let Operand::Signal(s) = o {
                        f(s)
                    }
                }
            }
        }
    }

    /// Maps every signal reference, failing on the first error.
    pub fn try_map<T, E>(&self, f: &mut impl FnMut(&S) -> Result<T, E>) -> Result<Expr<T>, E> {
        let mut op = |o: &Operand<S>| -> Result<Operand<T>, E> {
            Ok(match o {
                Operand::Signal(s) => Operand::Signal(f(s)?),
                Operand::Literal(v) => Operand::Literal(*v),
            })
        };
        Ok(match self {
            Expr::Const(b) => Expr::Const(*b),
            Expr::Signal(s) => Expr::Signal(f(s)?),
            Expr::Not(e) => Expr::Not(Box::new(e.try_map(f)?)),
            Expr::And(a, b) => Expr::And(Box::new(a.try_map(f)?), Box::new(b.try_map(f)?)),
            Expr::Xor(a, b) => Expr::Xor(Box::new(a.try_map(f)?), Box::new(b.try_map(f)?)),
            Expr::Or(a, b) => Expr::Or(Box::new(a.try_map(f)?), Box::new(b.try_map(f)?)),
            Expr::Cmp(a, o, b) => {
                let a = op(a)?;
                Expr::Cmp(a, *o, op(b)?)
            }
        })
    }

    /// Binding strength, for printing the fewest parentheses.
    fn level(&self) -> u8 {
        match self {
            Expr::Or(..) => 0,
            Expr::Xor(..) => 1,
            Expr::And(..) => 2,
            Expr::Cmp(..) => 3,
            Expr::Not(..) => 4,
            Expr::Const(_) | Expr::Signal(_) => 5,
        }
    }

    /// Writes the expression in canonical IEC form (`AND`, `OR`, `XOR`, `NOT`), naming
    /// signals with `name`. Parsing the result gives back the same tree.
    pub fn write_iec(
        &self,
        out: &mut impl fmt::Write,
        name: &impl Fn(&S) -> String,
    ) -> fmt::Result {
        let child = |out: &mut dyn fmt::Write, e: &Expr<S>, min: u8| -> fmt::Result {
            if e.level() < min {
                out.write_char('(')?;
                e.write_dyn(out, name)?;
                out.write_char(')')
            } else {
                e.write_dyn(out, name)
            }
        };
        match self {
            Expr::Const(true) => out.write_str("TRUE"),
            Expr::Const(false) => out.write_str("FALSE"),
            Expr::Signal(s) => out.write_str(&name(s)),
            Expr::Not(e) => {
                out.write_str("NOT ")?;
                child(out, e, 4)
            }
            Expr::And(a, b) | Expr::Xor(a, b) | Expr::Or(a, b) => {
                let (kw, lvl) = match self {
                    Expr::And(..) => ("AND", 2),
                    Expr::Xor(..) => ("XOR", 1),
                    _ => ("OR", 0),
                };
                // Left-associative: the right operand needs parentheses at equal strength.
                child(out, a, lvl)?;
                write!(out, " {kw} ")?;
                child(out, b, lvl + 1)
            }
            Expr::Cmp(a, op, b) => {
                let w = |out: &mut dyn fmt::Write, o: &Operand<S>| match o {
                    Operand::Signal(s) => out.write_str(&name(s)),
                    Operand::Literal(v) => write!(out, "{v}"),
                };
                w(out, a)?;
                write!(out, " {} ", op.symbol())?;
                w(out, b)
            }
        }
    }

    fn write_dyn(&self, out: &mut dyn fmt::Write, name: &impl Fn(&S) -> String) -> fmt::Result {
        struct W<'a>(&'a mut dyn fmt::Write);
        impl fmt::Write for W<'_> {
            fn write_str(&mut self, s: &str) -> fmt::Result {
                self.0.write_str(s)
            }
        }
        self.write_iec(&mut W(out), name)
    }

    /// The canonical IEC text of the expression.
    pub fn to_iec(&self, name: &impl Fn(&S) -> String) -> String {
        let mut s = String::new();
        self.write_iec(&mut s, name)
            .expect("writing to a String cannot fail");
        s
    }
}

impl fmt::Display for Expr<String> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.write_iec(f, &|s: &String| s.clone())
    }
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    Int(i64),
    True,
    False,
    Not,
    And,
    Or,
    Xor,
    Cmp(CmpOp),
    LParen,
    RParen,
    End,
}

fn describe(t: &Tok) -> String {
    match t {
        Tok::Ident(s) => format!("`{s}`"),
        Tok::Int(v) => format!("`{v}`"),
        Tok::True => "`TRUE`".into(),
        Tok::False => "`FALSE`".into(),
        Tok::Not => "`NOT`".into(),
        Tok::And => "`AND`".into(),
        Tok::Or => "`OR`".into(),
        Tok::Xor => "`XOR`".into(),
        Tok::Cmp(op) => format!("`{}`", op.symbol()),
        Tok::LParen => "`(`".into(),
        Tok::RParen => "`)`".into(),
        Tok::End => "the end".into(),
    }
}

fn lex(text: &str) -> Result<Vec<(Tok, usize)>, GuardError> {
    let chars: Vec<char> = text.chars().collect();
    let mut toks = Vec::new();
    let mut i = 0;
    let err = |col: usize, message: String| GuardError {
        column: col + 1,
        message,
    };
    while i < chars.len() {
        let c = chars[i];
        let start = i;
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        let two: String = chars[i..chars.len().min(i + 2)].iter().collect();
        let tok = if c.is_ascii_alphabetic() || c == '_' {
            while i < chars.len() && (chars[i].is_ascii_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            let word: String = chars[start..i].iter().collect();
            match word.to_ascii_uppercase().as_str() {
                "TRUE" => Tok::True,
                "FALSE" => Tok::False,
                "NOT" => Tok::Not,
                "AND" => Tok::And,
                "OR" => Tok::Or,
                "XOR" => Tok::Xor,
                _ => Tok::Ident(word),
            }
        } else if c.is_ascii_digit()
            || (c == '-' && chars.get(i + 1).is_some_and(|d| d.is_ascii_digit()))
        {
            // `-` only ever starts a negative number: guards have no arithmetic.
            i += 1;
            while i < chars.len() && (chars[i].is_ascii_digit() || chars[i] == '_') {
                i += 1;
            }
            let digits: String = chars[start..i].iter().filter(|c| **c != '_').collect();
            let v = digits
                .parse::<i64>()
                .map_err(|_| err(start, format!("the number {digits} is too large")))?;
            Tok::Int(v)
        } else {
            let (tok, len) = match two.as_str() {
                "&&" => (Tok::And, 2),
                "||" => (Tok::Or, 2),
                "<>" | "!=" => (Tok::Cmp(CmpOp::Ne), 2),
                "<=" => (Tok::Cmp(CmpOp::Le), 2),
                ">=" => (Tok::Cmp(CmpOp::Ge), 2),
                "==" => (Tok::Cmp(CmpOp::Eq), 2),
                _ => match c {
                    '!' => (Tok::Not, 1),
                    '&' => (Tok::And, 1),
                    '|' => (Tok::Or, 1),
                    '(' => (Tok::LParen, 1),
                    ')' => (Tok::RParen, 1),
                    '=' => (Tok::Cmp(CmpOp::Eq), 1),
                    '<' => (Tok::Cmp(CmpOp::Lt), 1),
                    '>' => (Tok::Cmp(CmpOp::Gt), 1),
                    _ => {
                        return Err(err(
                            start,
                            format!(
                                "unexpected character `{c}`: a guard uses signal names, \
                                 AND/OR/XOR/NOT (or & | !), comparisons and parentheses"
                            ),
                        ))
                    }
                },
            };
            i += len;
            tok
        };
        toks.push((tok, start + 1));
    }
    toks.push((Tok::End, chars.len() + 1));
    Ok(toks)
}

/// Builds a binary node from its operands (`Expr::And` and the like).
type MakeBinary = fn(Box<Expr<String>>, Box<Expr<String>>) -> Expr<String>;

/// How deeply parentheses and `NOT`s may nest: deep enough for any real guard, shallow
/// enough that the recursive parser, evaluator and printer cannot exhaust the stack.
pub const MAX_DEPTH: usize = 64;

/// How deep a guard's tree may be, operators in a row counted (`a AND b AND …` is a tree as
/// deep as it has operators): every pass over a guard (evaluation, printing, analysis) is
/// recursive.
pub const MAX_TREE: usize = 1000;

struct Parser {
    toks: Vec<(Tok, usize)>,
    pos: usize,
    depth: usize,
    /// Levels of the tree being built: nesting and operators in a row.
    tree: usize,
}

impl Parser {
    fn peek(&self) -> &Tok {
        &self.toks[self.pos].0
    }
    fn column(&self) -> usize {
        self.toks[self.pos].1
    }
    fn bump(&mut self) -> Tok {
        let t = self.toks[self.pos].0.clone();
        if t != Tok::End {
            self.pos += 1;
        }
        t
    }
    fn error(&self, message: String) -> GuardError {
        GuardError {
            column: self.column(),
            message,
        }
    }

    fn binary(
        &mut self,
        op: Tok,
        next: fn(&mut Self) -> Result<Expr<String>, GuardError>,
        make: MakeBinary,
    ) -> Result<Expr<String>, GuardError> {
        let mut links = 0;
        let r = (|| {
            let mut lhs = next(self)?;
            while *self.peek() == op {
                if self.tree == MAX_TREE {
                    return Err(self.error(format!(
                        "the guard has more than {MAX_TREE} operators in a row; simplify it"
                    )));
                }
                self.tree += 1;
                links += 1;
                self.bump();
                let rhs = next(self)?;
                lhs = make(Box::new(lhs), Box::new(rhs));
            }
            Ok(lhs)
        })();
        self.tree -= links;
        r
    }
    fn or(&mut self) -> Result<Expr<String>, GuardError> {
        self.binary(Tok::Or, Self::xor, Expr::Or)
    }
    fn xor(&mut self) -> Result<Expr<String>, GuardError> {
        self.binary(Tok::Xor, Self::and, Expr::Xor)
    }
    fn and(&mut self) -> Result<Expr<String>, GuardError> {
        self.binary(Tok::And, Self::cmp, Expr::And)
    }
    fn cmp(&mut self) -> Result<Expr<String>, GuardError> {
        let starts_comparison = matches!(self.peek(), Tok::Ident(_) | Tok::Int(_))
            && matches!(self.toks.get(self.pos + 1), Some((Tok::Cmp(_), _)));
        if starts_comparison {
            let a = self.operand(None)?;
            let Tok::Cmp(op) = self.bump() else {
                unreachable!("checked by the lookahead")
            };
            let b = self.operand(Some(op))?;
            if let Tok::Cmp(_) = self.peek() {
                return Err(self.error("comparisons cannot be chained; join them with AND".into()));
            }
            return Ok(Expr::Cmp(a, op, b));
        }
        let col = self.column();
        let e = self.unary()?;
        if let Tok::Cmp(_) = self.peek() {
            return Err(GuardError {
                column: col,
                message: "a comparison needs a signal name or an integer on each side; \
                          write `NOT (a = b)` rather than `NOT a = b`"
                    .into(),
            });
        }
        Ok(e)
    }
    fn operand(&mut self, after: Option<CmpOp>) -> Result<Operand<String>, GuardError> {
        let col = self.column();
        match self.bump() {
            Tok::Ident(s) => Ok(Operand::Signal(s)),
            Tok::Int(v) => Ok(Operand::Literal(v)),
            t => Err(GuardError {
                column: col,
                message: match after {
                    Some(op) => format!(
                        "expected a signal name or an integer after `{}`, found {}",
                        op.symbol(),
                        describe(&t)
                    ),
                    None => format!(
                        "expected a signal name or an integer, found {}",
                        describe(&t)
                    ),
                },
            }),
        }
    }
    fn nested<T>(
        &mut self,
        f: impl FnOnce(&mut Self) -> Result<T, GuardError>,
    ) -> Result<T, GuardError> {
        if self.depth == MAX_DEPTH {
            // Point at the `(` or `NOT` just read, the one that goes too deep.
            return Err(GuardError {
                column: self.toks[self.pos.saturating_sub(1)].1,
                message: format!(
                    "the guard nests parentheses and NOTs more than {MAX_DEPTH} deep; simplify it"
                ),
            });
        }
        self.depth += 1;
        self.tree += 1;
        let r = f(self);
        self.depth -= 1;
        self.tree -= 1;
        r
    }
    fn unary(&mut self) -> Result<Expr<String>, GuardError> {
        if *self.peek() == Tok::Not {
            self.bump();
            return self.nested(|p| Ok(Expr::Not(Box::new(p.unary()?))));
        }
        self.primary()
    }
    fn primary(&mut self) -> Result<Expr<String>, GuardError> {
        let col = self.column();
        match self.bump() {
            Tok::True => Ok(Expr::Const(true)),
            Tok::False => Ok(Expr::Const(false)),
            Tok::Ident(s) => Ok(Expr::Signal(s)),
            Tok::Int(v) => Err(GuardError {
                column: col,
                message: format!(
                    "a number ({v}) cannot stand alone; compare it with a signal, e.g. `Level >= {v}`"
                ),
            }),
            Tok::LParen => {
                let e = self.nested(Self::or)?;
                if *self.peek() != Tok::RParen {
                    return Err(self.error(format!(
                        "expected `)` to close the `(` at column {col}, found {}",
                        describe(self.peek())
                    )));
                }
                self.bump();
                Ok(e)
            }
            Tok::End => Err(GuardError {
                column: col,
                message: "the guard ends where a signal name, TRUE, FALSE, NOT or `(` is expected".into(),
            }),
            t => Err(GuardError {
                column: col,
                message: format!("expected a signal name, TRUE, FALSE, NOT or `(`, found {}", describe(&t)),
            }),
        }
    }
}

/// Parses a guard into a tree of signal names. An empty text is TRUE.
pub fn parse(text: &str) -> Result<Expr<String>, GuardError> {
    let toks = lex(text)?;
    if toks.len() == 1 {
        return Ok(Expr::Const(true));
    }
    let mut p = Parser {
        toks,
        pos: 0,
        depth: 0,
        tree: 0,
    };
    let e = p.or()?;
    if *p.peek() != Tok::End {
        let what = describe(p.peek());
        return Err(p.error(format!(
            "unexpected {what}: expected AND, OR, XOR or the end of the guard"
        )));
    }
    Ok(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(input: &str, expect: &str) {
        let got = match parse(input) {
            Ok(e) => e.to_string(),
            Err(e) => format!("error: {e}"),
        };
        assert_eq!(got, expect, "parsing {input:?}");
    }

    #[test]
    fn precedence_and_spellings() {
        check("B1 AND NOT N2 OR (X AND Y)", "B1 AND NOT N2 OR X AND Y");
        check("!a & b | c", "NOT a AND b OR c");
        check("a && (b || c)", "a AND (b OR c)");
        check("a OR b XOR c AND d", "a OR b XOR c AND d");
        check("(a OR b) AND c", "(a OR b) AND c");
        check("NOT (a AND b)", "NOT (a AND b)");
        check("a AND (b AND c)", "a AND (b AND c)");
        check("not not x", "NOT NOT x");
        check(
            "Level >= 3 AND NOT (Level > 7)",
            "Level >= 3 AND NOT (Level > 7)",
        );
        check("3 < Level", "3 < Level");
        check("x <> y OR x != 2", "x <> y OR x <> 2");
        check("Level >= -3", "Level >= -3");
        check("-3 < Level", "-3 < Level");
        check("", "TRUE");
        check("  true ", "TRUE");
        check("False", "FALSE");
    }

    #[test]
    fn errors_point_at_the_column() {
        check("B1 AND", "error: column 7: the guard ends where a signal name, TRUE, FALSE, NOT or `(` is expected");
        check(
            "(a OR b",
            "error: column 8: expected `)` to close the `(` at column 1, found the end",
        );
        check(
            "a b",
            "error: column 3: unexpected `b`: expected AND, OR, XOR or the end of the guard",
        );
        check("a # b", "error: column 3: unexpected character `#`: a guard uses signal names, AND/OR/XOR/NOT (or & | !), comparisons and parentheses");
        check(
            "a < b < c",
            "error: column 7: comparisons cannot be chained; join them with AND",
        );
        check("5", "error: column 1: a number (5) cannot stand alone; compare it with a signal, e.g. `Level >= 5`");
        check("(a AND b) = 1", "error: column 1: a comparison needs a signal name or an integer on each side; write `NOT (a = b)` rather than `NOT a = b`");
        check(
            "x >= AND",
            "error: column 6: expected a signal name or an integer after `>=`, found `AND`",
        );
        check("a - 3", "error: column 3: unexpected character `-`: a guard uses signal names, AND/OR/XOR/NOT (or & | !), comparisons and parentheses");
        let deep = format!(
            "{}x{}",
            "(".repeat(MAX_DEPTH + 1),
            ")".repeat(MAX_DEPTH + 1)
        );
        check(&deep, &format!("error: column {}: the guard nests parentheses and NOTs more than 64 deep; simplify it", MAX_DEPTH + 1));
        let ok = format!("{}x{}", "(".repeat(MAX_DEPTH), ")".repeat(MAX_DEPTH));
        check(&ok, "x");
        check(&"NOT ".repeat(MAX_DEPTH + 1), "error: column 257: the guard nests parentheses and NOTs more than 64 deep; simplify it");
        check(
            "99999999999999999999 < x",
            "error: column 1: the number 99999999999999999999 is too large",
        );
    }

    #[test]
    fn long_chains_of_operators_are_bounded() {
        for op in ["AND", "OR", "XOR"] {
            let long = vec!["a"; 100_000].join(&format!(" {op} "));
            let e = parse(&long).unwrap_err();
            assert!(
                e.message.contains("more than 1000 operators in a row"),
                "{op}: {e:?}"
            );
            assert_eq!(e.column, 1000 * (op.len() + 3) + 3, "{op}");
            // Within the limit a chain is read, evaluated, printed and flattened.
            let ok = vec!["a"; MAX_TREE].join(&format!(" {op} "));
            let e = parse(&ok).unwrap();
            e.eval(&|_: &String| 1);
            assert_eq!(e.to_iec(&|s: &String| s.clone()).len(), ok.len());
        }
        // A chain in parentheses counts while the chain around it is being read.
        let inner = vec!["a"; 990].join(" OR ");
        assert!(parse(&format!("{} AND ({inner})", vec!["a"; 20].join(" AND "))).is_err());
    }

    #[test]
    fn evaluates() {
        let e = parse("a AND NOT b OR n >= 3 XOR c").unwrap();
        let eval = |a, b, n, c| {
            e.eval(&|s: &String| match s.as_str() {
                "a" => a,
                "b" => b,
                "n" => n,
                _ => c,
            })
        };
        assert!(eval(1, 0, 0, 0));
        assert!(!eval(1, 1, 0, 0));
        assert!(eval(0, 0, 3, 0));
        assert!(!eval(0, 0, 3, 1));
        assert!(eval(0, 0, 0, 1));
    }

    #[test]
    fn printing_round_trips() {
        for text in [
            "a AND (b OR NOT c) XOR d",
            "NOT (x > 2) OR y",
            "(a XOR b) AND c",
            "a OR (b OR c)",
        ] {
            let e = parse(text).unwrap();
            assert_eq!(parse(&e.to_string()).unwrap(), e, "{text}");
        }
    }
}
