//! The Structured Text parser: recursive descent over the lexer's tokens, expressions by the
//! standard's precedence (parentheses and calls, unary `-`/`NOT`, `**`, `* / MOD`, `+ -`,
//! `< > <= >=`, `= <>`, `AND &`, `XOR`, `OR`).
//!
//! A syntax error is reported and the parser resynchronises at the next `;`, `END_…` or
//! declaration keyword, so one run reports every error of a file. Nesting (statements,
//! parentheses, `ARRAY … OF`, initial values) and the depth of an expression's tree are
//! bounded ([`crate::depth`]) so no input can exhaust the stack: the first level too deep is
//! reported (`E014`) and the rest of the source skipped, without a report per open block.

use crate::ast::*;
use crate::depth::{Depth, MAX_EXPR_DEPTH, MAX_NESTING};
use crate::diag::{self, Code, Diagnostics};
use crate::lexer::{self, Kw, Tok, Token};
use crate::source::{FileId, Span};

/// Deepest nesting of expressions and statements accepted.
pub const MAX_DEPTH: usize = MAX_NESTING;

/// Parses a Structured Text source (any number of TYPE blocks, POUs, configurations and
/// global variable lists). Problems go to `diags`; the tree holds what could be read.
pub fn parse(file: FileId, text: &str, diags: &mut Diagnostics) -> Library {
    parse_source(file, text, false, diags)
}

/// Parses an Instruction List source (`.il`): declarations as in Structured Text, POU bodies
/// in IL.
pub fn parse_il(file: FileId, text: &str, diags: &mut Diagnostics) -> Library {
    parse_source(file, text, true, diags)
}

fn parse_source(file: FileId, text: &str, il: bool, diags: &mut Diagnostics) -> Library {
    let tokens = lexer::lex(file, text, diags);
    let mut p = Parser::new(file, text, tokens, diags);
    p.il = il;
    let mut lib = p.library();
    crate::sfc::add_types(&mut lib);
    if lib.elements.is_empty() && !p.diags.has_errors() {
        p.diags.error(
            diag::EMPTY_SOURCE,
            Span::new(file, 0, 0),
            "no declaration here; a source holds PROGRAM, FUNCTION, FUNCTION_BLOCK, TYPE or CONFIGURATION declarations",
        );
    }
    lib
}

/// Parses a statement list alone (a PLCopen `<ST>` body).
pub fn parse_body(file: FileId, text: &str, diags: &mut Diagnostics) -> Vec<Stmt> {
    let tokens = lexer::lex(file, text, diags);
    let mut p = Parser::new(file, text, tokens, diags);
    let body = p.statements(&[]);
    p.expect_eof(|t| format!("{t} is not a statement here"));
    body
}

/// Parses a POU's declaration alone, as TwinCAT keeps it apart from the body: the header and
/// the variable blocks, with no statements and no `END_…` (one is accepted if written). The
/// POU is returned with an empty body.
pub fn parse_declaration(file: FileId, text: &str, diags: &mut Diagnostics) -> Option<Pou> {
    let mut tokens = lexer::lex(file, text, diags);
    let first = tokens.first().map(|t| t.tok.clone());
    let (kind, end_kw) = match first {
        Some(Tok::Kw(Kw::Program)) => (PouKind::Program, Kw::EndProgram),
        Some(Tok::Kw(Kw::FunctionBlock)) => (PouKind::FunctionBlock, Kw::EndFunctionBlock),
        Some(Tok::Kw(Kw::Function)) => (PouKind::Function, Kw::EndFunction),
        _ => {
            let span = tokens.first().map_or(Span::new(file, 0, 0), |t| t.span);
            if !diags.has_errors() {
                diags.error(
                    diag::SYNTAX,
                    span,
                    "a POU's declaration starts with PROGRAM, FUNCTION_BLOCK or FUNCTION",
                );
            }
            return None;
        }
    };
    // The END_ keyword the declaration leaves out, at its end, so that the POU parser sees a
    // complete POU whose body is empty.
    let eof = tokens.len() - 1;
    let written = eof > 0 && tokens[eof - 1].tok == Tok::Kw(end_kw);
    if !written {
        let at = tokens[eof].span.at_start();
        tokens.insert(
            eof,
            Token {
                tok: Tok::Kw(end_kw),
                span: at,
            },
        );
    }
    let mut p = Parser::new(file, text, tokens, diags);
    let mut pou = p.pou(kind).ok()?;
    if let Body::St(body) = &pou.body {
        if let Some(s) = body.first() {
            p.error_at(
                diag::SYNTAX,
                s.span,
                format!(
                    "a statement in the declaration of {}; statements go in the POU's implementation",
                    pou.name.name
                ),
            );
        }
    }
    p.expect_eof(|t| format!("{t} after the declaration of {}", pou.name.name));
    pou.body = Body::St(Vec::new());
    Some(pou)
}

/// The `<Declaration>` of a TwinCAT `<Itf>` (`INTERFACE I_X EXTENDS I_A`, END_INTERFACE left
/// out), or a whole interface in text: the interface, its members added by the caller.
pub fn parse_interface_declaration(
    file: FileId,
    text: &str,
    diags: &mut Diagnostics,
) -> Option<Pou> {
    let tokens = lexer::lex(file, text, diags);
    let mut p = Parser::new(file, text, tokens, diags);
    if !p.at_interface() {
        p.refuse_start("an interface's declaration starts with INTERFACE and its name");
        return None;
    }
    let pou = p.interface(true).ok()?;
    p.expect_eof(|t| format!("{t} after the declaration of {}", pou.name.name));
    Some(pou)
}

/// The `<Declaration>` of a TwinCAT method, property or action (`METHOD M : INT` and its
/// variable blocks, `PROPERTY P : INT`): the member, without a body.
pub fn parse_member_declaration(
    file: FileId,
    text: &str,
    diags: &mut Diagnostics,
) -> Option<PouOop> {
    let tokens = lexer::lex(file, text, diags);
    let mut p = Parser::new(file, text, tokens, diags);
    let mut oop = PouOop::default();
    if !p.at_member_start() {
        p.refuse_start(
            "a member's declaration starts with METHOD, PROPERTY or ACTION and its name",
        );
        return None;
    }
    p.member(&mut oop, true).ok()?;
    p.expect_eof(|t| format!("{t} after the member's declaration"));
    Some(oop)
}

/// Variable blocks alone (the `<Declaration>` of a TwinCAT property's GET or SET).
pub fn parse_var_blocks(file: FileId, text: &str, diags: &mut Diagnostics) -> Vec<VarBlock> {
    let tokens = lexer::lex(file, text, diags);
    let mut p = Parser::new(file, text, tokens, diags);
    let blocks = p.member_var_blocks();
    p.expect_eof(|t| format!("{t} where variable blocks were expected"));
    blocks
}

/// Parses one expression alone (a PLCopen initial value, a task interval).
pub fn parse_expression(file: FileId, text: &str, diags: &mut Diagnostics) -> Option<Expr> {
    let tokens = lexer::lex(file, text, diags);
    let mut p = Parser::new(file, text, tokens, diags);
    let e = p.expr().ok()?;
    if !p.expect_eof(|t| format!("{t} after the expression")) {
        return None;
    }
    Some(e)
}

/// Parses a type as written in a declaration (a PLCopen derived type's base, an array's
/// element type).
pub fn parse_type_spec(file: FileId, text: &str, diags: &mut Diagnostics) -> Option<TypeSpec> {
    let tokens = lexer::lex(file, text, diags);
    let mut p = Parser::new(file, text, tokens, diags);
    let t = p.type_spec(false).ok()?;
    p.at(&Tok::Eof).then_some(t)
}

/// Parses an initial value (PLCopen `<simpleValue value="…"/>` may hold `[1, 2]`).
pub fn parse_init(file: FileId, text: &str, diags: &mut Diagnostics) -> Option<Init> {
    let tokens = lexer::lex(file, text, diags);
    let mut p = Parser::new(file, text, tokens, diags);
    let i = p.init().ok()?;
    p.at(&Tok::Eof).then_some(i)
}

/// Reserved words that may also name a variable, field, parameter or type, as in TwinCAT 3
/// (whose grammar does not reserve them; OSCAT names variables `ON` and `R_EDGE`). Each is a
/// keyword only where a name cannot stand: `ON` after a RESOURCE's name, `TASK` and `WITH` in
/// a RESOURCE, `R_EDGE`/`F_EDGE` after a declaration's type.
pub const NAME_KEYWORDS: &[Kw] = &[Kw::On, Kw::REdge, Kw::FEdge, Kw::Task, Kw::With];

/// An error has been reported; the caller resynchronises.
#[derive(Debug)]
struct Reported;

type PResult<T> = Result<T, Reported>;

/// An enumeration's values with their optional explicit numbers.
type EnumValues = Vec<(Ident, Option<Expr>)>;

struct Parser<'a, 'd> {
    file: FileId,
    text: &'a str,
    toks: Vec<Token>,
    pos: usize,
    /// Nesting of statements, parentheses, types and initial values.
    nest: Depth,
    /// Depth of the expression tree being built (operators in a row count too).
    tree: Depth,
    /// A nesting limit was passed: the rest of the source was skipped, so what is found
    /// missing at its end is not reported.
    too_deep: bool,
    /// The token at which the last missing-END error was reported, so the stray keyword
    /// found there is not reported again.
    reported_at: usize,
    /// POU bodies are Instruction List (a `.il` source).
    il: bool,
    /// The 0-based line of every token (computed for IL bodies, which are line-oriented).
    tok_lines: Vec<u32>,
    /// Statements one statement of the source stands for after the one returned (a
    /// chained assignment's outer assignments), taken by the statement list.
    queued: Vec<Stmt>,
    diags: &'d mut Diagnostics,
}

impl<'a, 'd> Parser<'a, 'd> {
    fn new(file: FileId, text: &'a str, toks: Vec<Token>, diags: &'d mut Diagnostics) -> Self {
        Parser {
            file,
            text,
            toks,
            pos: 0,
            nest: Depth::new(MAX_NESTING),
            tree: Depth::new(MAX_EXPR_DEPTH),
            too_deep: false,
            reported_at: usize::MAX,
            il: false,
            tok_lines: Vec::new(),
            queued: Vec::new(),
            diags,
        }
    }

    // ---- token helpers ----

    fn peek(&self) -> &Token {
        &self.toks[self.pos.min(self.toks.len() - 1)]
    }

    fn peek_at(&self, k: usize) -> &Token {
        &self.toks[(self.pos + k).min(self.toks.len() - 1)]
    }

    fn at(&self, t: &Tok) -> bool {
        std::mem::discriminant(&self.peek().tok) == std::mem::discriminant(t)
    }

    fn at_kw(&self, kw: Kw) -> bool {
        self.peek().tok == Tok::Kw(kw)
    }

    fn bump(&mut self) -> Token {
        let t = self.peek().clone();
        if self.pos < self.toks.len() - 1 {
            self.pos += 1;
        }
        t
    }

    fn eat(&mut self, t: &Tok) -> Option<Token> {
        self.at(t).then(|| self.bump())
    }

    fn eat_kw(&mut self, kw: Kw) -> Option<Token> {
        self.at_kw(kw).then(|| self.bump())
    }

    fn text_of(&self, span: Span) -> &'a str {
        &self.text[span.start as usize..span.end as usize]
    }

    fn prev_span(&self) -> Span {
        self.toks[self.pos.saturating_sub(1)].span
    }

    fn describe(&self, t: &Token) -> String {
        match &t.tok {
            Tok::Eof => "the end of the source".into(),
            Tok::Str { .. } => "a string".into(),
            Tok::Int(_) | Tok::Real(_) => format!("the number `{}`", self.text_of(t.span)),
            Tok::Kw(k) => format!("`{}`", k.text()),
            _ => format!("`{}`", self.text_of(t.span)),
        }
    }

    fn error_at(&mut self, code: Code, span: Span, msg: impl Into<String>) {
        self.diags.error(code, span, msg);
    }

    /// Reports "expected X" at the current token (unless the lexer already reported the
    /// problem there: a bad character, or a comment or string that ran to the end).
    fn expected(&mut self, what: &str) -> Reported {
        let t = self.peek().clone();
        if self.quiet_at(&t) {
            return Reported;
        }
        let code = if t.tok == Tok::Eof {
            diag::MISSING_END
        } else {
            diag::SYNTAX
        };
        let msg = format!("expected {what}, found {}", self.describe(&t));
        self.error_at(code, t.span, msg);
        Reported
    }

    /// At the end of a part parsed alone (a body, a declaration, an expression): reports a
    /// token left over, `what` telling what it follows (given the token's description).
    /// True when the text ended there.
    fn expect_eof(&mut self, what: impl FnOnce(String) -> String) -> bool {
        if self.at(&Tok::Eof) {
            return true;
        }
        let t = self.peek().clone();
        let msg = what(self.describe(&t));
        self.error_at(diag::SYNTAX, t.span, msg);
        false
    }

    /// A part parsed alone does not start as it must: `msg` at the first token, unless the
    /// lexer already reported the problem there.
    fn refuse_start(&mut self, msg: &str) {
        let t = self.peek().clone();
        if !self.quiet_at(&t) {
            self.error_at(diag::SYNTAX, t.span, msg);
        }
    }

    fn quiet_at(&self, t: &Token) -> bool {
        t.tok == Tok::Error
            || (t.tok == Tok::Eof
                && (self.too_deep
                    || self
                        .diags
                        .items
                        .iter()
                        .any(|d| d.code == diag::UNTERMINATED_COMMENT)))
    }

    fn expect(&mut self, t: &Tok, what: &str) -> PResult<Token> {
        self.eat(t).ok_or_else(|| self.expected(what))
    }

    fn expect_kw(&mut self, kw: Kw) -> PResult<Token> {
        match self.eat_kw(kw) {
            Some(t) => Ok(t),
            None => Err(self.expected(&format!("`{}`", kw.text()))),
        }
    }

    /// A keyword that may be missing: reported, and parsing goes on as if it were there.
    fn soft_kw(&mut self, kw: Kw) {
        if self.eat_kw(kw).is_none() {
            let _ = self.expected(&format!("`{}`", kw.text()));
        }
    }

    fn expect_semi(&mut self) -> PResult<()> {
        if self.eat(&Tok::Semi).is_some() {
            return Ok(());
        }
        let t = self.peek().clone();
        let after = self.prev_span();
        let unterminated = self.diags.items.iter().any(|d| {
            d.code == diag::UNTERMINATED_STRING
                && d.span.start == after.start
                && d.span.file == after.file
        });
        if self.quiet_at(&t) || unterminated {
            return Err(Reported);
        }
        let msg = format!("expected `;` after this, found {}", self.describe(&t));
        self.error_at(
            diag::MISSING_SEMI,
            Span::new(self.file, after.end as usize, after.end as usize),
            msg,
        );
        Err(Reported)
    }

    /// Whether a token can be a name: an identifier, or one of the reserved words TwinCAT 3
    /// does not reserve ([`NAME_KEYWORDS`]).
    fn is_name(tok: &Tok) -> bool {
        match tok {
            Tok::Ident => true,
            Tok::Kw(k) => NAME_KEYWORDS.contains(k),
            _ => false,
        }
    }

    fn at_name(&self) -> bool {
        Self::is_name(&self.peek().tok)
    }

    fn ident(&mut self, what: &str) -> PResult<Ident> {
        if self.at_name() {
            let t = self.bump();
            return Ok(Ident::new(self.text_of(t.span), t.span));
        }
        if let Tok::Kw(k) = self.peek().tok {
            let t = self.peek().clone();
            self.error_at(
                diag::SYNTAX,
                t.span,
                format!(
                    "`{}` is a reserved word and cannot be {what}; choose another name",
                    k.text()
                ),
            );
            return Err(Reported);
        }
        Err(self.expected(what))
    }

    /// One level of nesting deeper (a statement, a parenthesis, a type, an initial value).
    /// Callers `leave()` whether what they parse inside succeeds or not.
    fn enter(&mut self) -> PResult<()> {
        if !self.nest.enter() {
            return Err(self.too_deep(format!(
                "nesting deeper than {MAX_NESTING} levels; split the expression or statement"
            )));
        }
        if !self.tree.enter() {
            self.nest.leave();
            return Err(self.too_deep_tree());
        }
        Ok(())
    }

    fn leave(&mut self) {
        self.nest.leave();
        self.tree.leave();
    }

    /// One more operator or access in a row (`… + x`, `….f`, `…[i]`): a level of the tree,
    /// not of nesting. The caller leaves as many levels as it took, however it ends.
    fn link(&mut self, links: &mut usize) -> PResult<()> {
        if !self.tree.enter() {
            return Err(self.too_deep_tree());
        }
        *links += 1;
        Ok(())
    }

    fn unlink(&mut self, links: usize) {
        for _ in 0..links {
            self.tree.leave();
        }
    }

    fn too_deep_tree(&mut self) -> Reported {
        self.too_deep(format!(
            "an expression more than {MAX_EXPR_DEPTH} levels deep (operators, fields or \
             subscripts in a row); split it with intermediate variables"
        ))
    }

    /// Reports the limit passed and skips to the end: nothing sensible follows at this depth,
    /// and the blocks left open are not reported one by one.
    fn too_deep(&mut self, msg: String) -> Reported {
        let span = self.peek().span;
        self.error_at(diag::TOO_DEEP, span, msg);
        self.too_deep = true;
        self.pos = self.toks.len() - 1;
        Reported
    }

    fn is_top_start(&self) -> bool {
        matches!(
            self.peek().tok,
            Tok::Kw(
                Kw::Program
                    | Kw::Function
                    | Kw::FunctionBlock
                    | Kw::Type
                    | Kw::Configuration
                    | Kw::VarGlobal
            ) | Tok::Eof
        ) || self.at_interface()
    }
}

mod config;
mod decl;
mod expr;
pub mod il;
mod oop;
mod pou;
mod sfc;

pub use oop::accessor;
mod stmt;

#[cfg(test)]
mod tests;

#[cfg(test)]
mod sfc_tests;

#[cfg(test)]
mod vendor_tests;

#[cfg(test)]
mod oop_tests;
