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
    let lib = p.library();
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
    if !p.at(&Tok::Eof) {
        let t = p.peek().clone();
        p.error_at(
            diag::SYNTAX,
            t.span,
            format!("{} is not a statement here", p.describe(&t)),
        );
    }
    body
}

/// Parses one expression alone (a PLCopen initial value, a task interval).
pub fn parse_expression(file: FileId, text: &str, diags: &mut Diagnostics) -> Option<Expr> {
    let tokens = lexer::lex(file, text, diags);
    let mut p = Parser::new(file, text, tokens, diags);
    let e = p.expr().ok()?;
    if !p.at(&Tok::Eof) {
        let t = p.peek().clone();
        p.error_at(
            diag::SYNTAX,
            t.span,
            format!("{} after the expression", p.describe(&t)),
        );
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

    fn ident(&mut self, what: &str) -> PResult<Ident> {
        if self.at(&Tok::Ident) {
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
        )
    }

    // ---- library ----

    fn library(&mut self) -> Library {
        let mut lib = Library::default();
        while !self.at(&Tok::Eof) {
            let start = self.pos;
            let r = match self.peek().tok {
                Tok::Kw(Kw::Program) => self.pou(PouKind::Program).map(Element::Pou),
                Tok::Kw(Kw::FunctionBlock) => self.pou(PouKind::FunctionBlock).map(Element::Pou),
                Tok::Kw(Kw::Function) => self.pou(PouKind::Function).map(Element::Pou),
                Tok::Kw(Kw::Type) => self.type_block().map(Element::Types),
                Tok::Kw(Kw::Configuration) => self.configuration().map(Element::Configuration),
                Tok::Kw(Kw::VarGlobal) => self.var_block().map(Element::Globals),
                Tok::Semi => {
                    self.bump();
                    continue;
                }
                _ => Err(self.expected(
                    "PROGRAM, FUNCTION, FUNCTION_BLOCK, TYPE, CONFIGURATION or VAR_GLOBAL",
                )),
            };
            match r {
                Ok(e) => lib.elements.push(e),
                Err(Reported) => {
                    if self.pos == start {
                        self.bump();
                    }
                    while !self.is_top_start() {
                        self.bump();
                    }
                }
            }
        }
        lib
    }

    fn type_block(&mut self) -> PResult<Vec<TypeDecl>> {
        self.expect_kw(Kw::Type)?;
        let mut decls = Vec::new();
        while !self.at_kw(Kw::EndType) && !self.is_top_start() {
            let start = self.pos;
            match self.type_decl() {
                Ok(d) => decls.push(d),
                Err(Reported) => {
                    self.sync_decl(start);
                }
            }
        }
        self.expect_kw(Kw::EndType)?;
        self.eat(&Tok::Semi);
        Ok(decls)
    }

    /// Skips to just after the next `;` (or to an END_/top keyword).
    fn sync_decl(&mut self, start: usize) {
        if self.pos == start {
            self.bump();
        }
        loop {
            match self.peek().tok {
                Tok::Semi => {
                    self.bump();
                    return;
                }
                Tok::Kw(
                    Kw::EndType
                    | Kw::EndVar
                    | Kw::EndStruct
                    | Kw::Var
                    | Kw::VarInput
                    | Kw::VarOutput
                    | Kw::VarInOut
                    | Kw::VarTemp
                    | Kw::VarExternal
                    | Kw::EndProgram
                    | Kw::EndFunction
                    | Kw::EndFunctionBlock
                    | Kw::EndResource
                    | Kw::EndConfiguration
                    | Kw::Resource
                    | Kw::Task,
                ) => return,
                _ if self.is_top_start() => return,
                _ => {
                    self.bump();
                }
            }
        }
    }

    fn type_decl(&mut self) -> PResult<TypeDecl> {
        let name = self.ident("a type name")?;
        self.expect(&Tok::Colon, "`:` after the type name")?;
        let spec = self.type_spec(true)?;
        let init = if self.eat(&Tok::Assign).is_some() {
            Some(self.init()?)
        } else {
            None
        };
        self.expect_semi()?;
        let span = name.span.to(self.prev_span());
        Ok(TypeDecl {
            name,
            spec,
            init,
            span,
        })
    }

    /// A type specification; `in_type` allows STRUCT.
    fn type_spec(&mut self, in_type: bool) -> PResult<TypeSpec> {
        self.enter()?;
        let r = self.type_spec_inner(in_type);
        self.leave();
        r
    }

    fn type_spec_inner(&mut self, in_type: bool) -> PResult<TypeSpec> {
        let start = self.peek().span;
        match self.peek().tok.clone() {
            Tok::Kw(Kw::Array) => {
                self.bump();
                self.expect(&Tok::LBracket, "`[` after ARRAY")?;
                let mut ranges = Vec::new();
                loop {
                    if self.at(&Tok::Star) {
                        let t = self.bump();
                        self.error_at(
                            diag::UNSUPPORTED,
                            t.span,
                            "variable-length arrays (ARRAY[*]) are not supported; give the bounds (ARRAY[1..10] OF …)",
                        );
                        return Err(Reported);
                    }
                    let lo = self.expr()?;
                    self.expect(&Tok::DotDot, "`..` between the array's bounds")?;
                    let hi = self.expr()?;
                    ranges.push((lo, hi));
                    if self.eat(&Tok::Comma).is_none() {
                        break;
                    }
                }
                self.expect(&Tok::RBracket, "`]` after the array's bounds")?;
                self.expect_kw(Kw::Of)?;
                let elem = self.type_spec(false)?;
                let span = start.to(self.prev_span());
                Ok(TypeSpec::Array {
                    ranges,
                    elem: Box::new(elem),
                    span,
                })
            }
            Tok::Kw(Kw::Struct) => {
                self.bump();
                if !in_type {
                    self.error_at(
                        diag::BAD_DECLARATION,
                        start,
                        "a STRUCT is declared in TYPE … END_TYPE; declare the structure as a type and use its name here",
                    );
                }
                let mut fields = Vec::new();
                while !self.at_kw(Kw::EndStruct) && !self.is_top_start() && !self.at_kw(Kw::EndType)
                {
                    let s = self.pos;
                    match self.var_decl() {
                        Ok(d) => fields.push(d),
                        Err(Reported) => self.sync_decl(s),
                    }
                }
                self.expect_kw(Kw::EndStruct)?;
                let span = start.to(self.prev_span());
                Ok(TypeSpec::Struct { fields, span })
            }
            Tok::LParen => {
                let (values, span) = self.enum_values()?;
                Ok(TypeSpec::Enum {
                    base: None,
                    values,
                    span: start.to(span),
                })
            }
            Tok::Ident => {
                let name = self.ident("a type")?;
                if name.is("STRING") || name.is("WSTRING") {
                    let wide = name.is("WSTRING");
                    let len = if self.eat(&Tok::LBracket).is_some() {
                        let e = self.expr()?;
                        self.expect(&Tok::RBracket, "`]` after the string length")?;
                        Some(Box::new(e))
                    } else if self.at(&Tok::LParen) {
                        self.bump();
                        let e = self.expr()?;
                        self.expect(&Tok::RParen, "`)` after the string length")?;
                        Some(Box::new(e))
                    } else {
                        None
                    };
                    return Ok(TypeSpec::String {
                        wide,
                        len,
                        span: start.to(self.prev_span()),
                    });
                }
                if (name.is("REF_TO") || name.is("POINTER") || name.is("REFERENCE"))
                    && !self.at(&Tok::Semi)
                {
                    let what = name.name.to_ascii_uppercase();
                    while !matches!(self.peek().tok, Tok::Semi | Tok::Assign | Tok::Eof) {
                        self.bump();
                    }
                    return Ok(TypeSpec::Unsupported {
                        what,
                        span: start.to(self.prev_span()),
                    });
                }
                if self.at(&Tok::LParen) {
                    // INT (0..10) or INT (A := 1, B := 2)
                    let save = self.pos;
                    self.bump();
                    if self.at(&Tok::Ident)
                        && matches!(self.peek_at(1).tok, Tok::Comma | Tok::RParen | Tok::Assign)
                    {
                        self.pos = save;
                        let (values, span) = self.enum_values()?;
                        return Ok(TypeSpec::Enum {
                            base: Some(name),
                            values,
                            span: start.to(span),
                        });
                    }
                    let lo = self.expr()?;
                    self.expect(&Tok::DotDot, "`..` in the subrange")?;
                    let hi = self.expr()?;
                    self.expect(&Tok::RParen, "`)` after the subrange")?;
                    return Ok(TypeSpec::Subrange {
                        base: name,
                        lo: Box::new(lo),
                        hi: Box::new(hi),
                        span: start.to(self.prev_span()),
                    });
                }
                Ok(TypeSpec::Named(name))
            }
            _ => Err(self.expected("a type (e.g. INT, ARRAY[1..10] OF REAL, STRING[20])")),
        }
    }

    fn enum_values(&mut self) -> PResult<(EnumValues, Span)> {
        self.expect(&Tok::LParen, "`(`")?;
        let mut values = Vec::new();
        loop {
            let name = self.ident("an enumeration value")?;
            let v = if self.eat(&Tok::Assign).is_some() {
                Some(self.expr()?)
            } else {
                None
            };
            values.push((name, v));
            if self.eat(&Tok::Comma).is_none() {
                break;
            }
        }
        let end = self.expect(&Tok::RParen, "`)` after the enumeration values")?;
        Ok((values, end.span))
    }

    fn init(&mut self) -> PResult<Init> {
        self.enter()?;
        let r = self.init_inner();
        self.leave();
        r
    }

    fn init_inner(&mut self) -> PResult<Init> {
        let start = self.peek().span;
        if self.at(&Tok::LBracket) {
            self.bump();
            let mut items = Vec::new();
            if !self.at(&Tok::RBracket) {
                loop {
                    items.push(self.array_init_item()?);
                    if self.eat(&Tok::Comma).is_none() {
                        break;
                    }
                }
            }
            self.expect(&Tok::RBracket, "`]` after the array's initial values")?;
            return Ok(Init::Array {
                items,
                span: start.to(self.prev_span()),
            });
        }
        if self.at(&Tok::LParen)
            && self.peek_at(1).tok == Tok::Ident
            && self.peek_at(2).tok == Tok::Assign
        {
            self.bump();
            let mut fields = Vec::new();
            loop {
                let name = self.ident("a field name")?;
                self.expect(&Tok::Assign, "`:=` after the field name")?;
                let v = self.init()?;
                fields.push((name, v));
                if self.eat(&Tok::Comma).is_none() {
                    break;
                }
            }
            self.expect(&Tok::RParen, "`)` after the structure's initial values")?;
            return Ok(Init::Struct {
                fields,
                span: start.to(self.prev_span()),
            });
        }
        Ok(Init::Expr(self.expr()?))
    }

    fn array_init_item(&mut self) -> PResult<ArrayInitItem> {
        let start = self.peek().span;
        // n(value) or n()
        if matches!(self.peek().tok, Tok::Int(_)) && self.peek_at(1).tok == Tok::LParen {
            let n = self.primary()?;
            self.bump();
            let value = if self.at(&Tok::RParen) {
                None
            } else {
                Some(self.init()?)
            };
            self.expect(&Tok::RParen, "`)` after the repeated value")?;
            return Ok(ArrayInitItem {
                repeat: Some(n),
                value,
                span: start.to(self.prev_span()),
            });
        }
        let v = self.init()?;
        Ok(ArrayInitItem {
            repeat: None,
            span: start.to(self.prev_span()),
            value: Some(v),
        })
    }

    // ---- POUs ----

    fn pou(&mut self, kind: PouKind) -> PResult<Pou> {
        let start = self.bump().span;
        let name = self.ident("the POU's name")?;
        let return_type = if kind == PouKind::Function {
            if self.eat(&Tok::Colon).is_some() {
                Some(self.type_spec(false)?)
            } else {
                let span = self.peek().span;
                self.error_at(
                    diag::SYNTAX,
                    span,
                    format!(
                        "a FUNCTION declares its result type: FUNCTION {} : INT",
                        name.name
                    ),
                );
                None
            }
        } else {
            None
        };
        let end_kw = match kind {
            PouKind::Program => Kw::EndProgram,
            PouKind::FunctionBlock => Kw::EndFunctionBlock,
            PouKind::Function => Kw::EndFunction,
        };
        let mut var_blocks = Vec::new();
        while self.is_var_block_start() {
            let s = self.pos;
            match self.var_block() {
                Ok(b) => var_blocks.push(b),
                Err(Reported) => {
                    // Skip to END_VAR (or the body).
                    if self.pos == s {
                        self.bump();
                    }
                    while !self.at_kw(Kw::EndVar) && !self.is_top_start() && !self.at_kw(end_kw) {
                        self.bump();
                    }
                    self.eat_kw(Kw::EndVar);
                    self.eat(&Tok::Semi);
                }
            }
        }
        if self.il {
            let body_start = self.peek().span;
            let code = self.il_instructions(end_kw);
            let body = Body::Il {
                code,
                span: body_start.at_start(),
            };
            return self.pou_end(kind, name, return_type, var_blocks, body, start, end_kw);
        }
        let mut body = self.statements(&[end_kw]);
        // A stray END_WHILE, ELSE, UNTIL…: report it (unless a missing END_ was reported
        // there) and go on with the statements after it.
        while let Tok::Kw(
            k @ (Kw::EndIf
            | Kw::Elsif
            | Kw::Else
            | Kw::EndCase
            | Kw::EndFor
            | Kw::EndWhile
            | Kw::Until
            | Kw::EndRepeat),
        ) = self.peek().tok
        {
            if self.pos != self.reported_at {
                let span = self.peek().span;
                self.error_at(
                    diag::SYNTAX,
                    span,
                    format!("`{}` does not close any open statement here", k.text()),
                );
            }
            self.bump();
            self.eat(&Tok::Semi);
            body.extend(self.statements(&[end_kw]));
        }
        self.pou_end(
            kind,
            name,
            return_type,
            var_blocks,
            Body::St(body),
            start,
            end_kw,
        )
    }

    /// The `END_…` of a POU, and the POU.
    #[allow(clippy::too_many_arguments)]
    fn pou_end(
        &mut self,
        kind: PouKind,
        name: Ident,
        return_type: Option<TypeSpec>,
        var_blocks: Vec<VarBlock>,
        body: Body,
        start: Span,
        end_kw: Kw,
    ) -> PResult<Pou> {
        let end = match self.eat_kw(end_kw) {
            Some(t) => t.span,
            None => {
                let t = self.peek().clone();
                if self.quiet_at(&t) {
                    return Err(Reported);
                }
                let msg = format!(
                    "{} {} has no {}; found {}",
                    kind.keyword(),
                    name.name,
                    end_kw.text(),
                    self.describe(&t)
                );
                self.error_at(diag::MISSING_END, t.span, msg);
                return Err(Reported);
            }
        };
        self.eat(&Tok::Semi);
        Ok(Pou {
            kind,
            name,
            return_type,
            var_blocks,
            body,
            span: start.to(end),
        })
    }

    fn is_var_block_start(&self) -> bool {
        matches!(
            self.peek().tok,
            Tok::Kw(
                Kw::Var
                    | Kw::VarInput
                    | Kw::VarOutput
                    | Kw::VarInOut
                    | Kw::VarTemp
                    | Kw::VarExternal
                    | Kw::VarGlobal
                    | Kw::VarAccess
                    | Kw::VarConfig
            )
        )
    }

    fn var_block(&mut self) -> PResult<VarBlock> {
        let t = self.bump();
        let kind = match t.tok {
            Tok::Kw(Kw::Var) => VarKind::Local,
            Tok::Kw(Kw::VarInput) => VarKind::Input,
            Tok::Kw(Kw::VarOutput) => VarKind::Output,
            Tok::Kw(Kw::VarInOut) => VarKind::InOut,
            Tok::Kw(Kw::VarTemp) => VarKind::Temp,
            Tok::Kw(Kw::VarExternal) => VarKind::External,
            Tok::Kw(Kw::VarGlobal) => VarKind::Global,
            _ => VarKind::Other,
        };
        let mut constant = false;
        let mut retain = Retain::Unspecified;
        loop {
            if self.eat_kw(Kw::Constant).is_some() {
                constant = true;
            } else if self.eat_kw(Kw::Retain).is_some() {
                retain = Retain::Retain;
            } else if self.eat_kw(Kw::NonRetain).is_some() {
                retain = Retain::NonRetain;
            } else if self.at(&Tok::Ident)
                && ["PERSISTENT"]
                    .iter()
                    .any(|w| self.text_of(self.peek().span).eq_ignore_ascii_case(w))
            {
                // TwinCAT's PERSISTENT: kept like RETAIN.
                self.bump();
                retain = Retain::Retain;
            } else {
                break;
            }
        }
        let mut vars = Vec::new();
        if kind == VarKind::Other {
            self.error_at(
                diag::UNSUPPORTED,
                t.span,
                format!(
                    "{} blocks are not supported; declare the variables in VAR_GLOBAL",
                    self.text_of(t.span)
                ),
            );
            while !self.at_kw(Kw::EndVar) && !self.is_top_start() {
                self.bump();
            }
        } else {
            while !self.at_kw(Kw::EndVar) && !self.is_top_start() && !self.is_var_block_start() {
                let s = self.pos;
                if matches!(
                    self.peek().tok,
                    Tok::Kw(
                        Kw::EndProgram
                            | Kw::EndFunction
                            | Kw::EndFunctionBlock
                            | Kw::EndConfiguration
                            | Kw::EndResource
                    )
                ) {
                    break;
                }
                if self.looks_like_statement() {
                    let span = self.peek().span;
                    self.error_at(
                        diag::MISSING_END,
                        span,
                        format!("the {} block before this statement has no END_VAR; close it with END_VAR", self.text_of(t.span)),
                    );
                    return Ok(VarBlock {
                        kind,
                        constant,
                        retain,
                        vars,
                        span: t.span.to(self.prev_span()),
                    });
                }
                match self.var_decl() {
                    Ok(d) => vars.push(d),
                    Err(Reported) => self.sync_decl(s),
                }
            }
        }
        if self.eat_kw(Kw::EndVar).is_none() {
            let t2 = self.peek().clone();
            if self.quiet_at(&t2) {
                return Err(Reported);
            }
            let msg = format!(
                "{} block has no END_VAR; found {}",
                self.text_of(t.span),
                self.describe(&t2)
            );
            self.error_at(diag::MISSING_END, t2.span, msg);
            return Err(Reported);
        }
        self.eat(&Tok::Semi);
        Ok(VarBlock {
            kind,
            constant,
            retain,
            vars,
            span: t.span.to(self.prev_span()),
        })
    }

    fn var_decl(&mut self) -> PResult<VarDecl> {
        let start = self.peek().span;
        let mut names = Vec::new();
        if self.at_kw(Kw::At) {
            let t = self.peek().clone();
            self.error_at(
                diag::UNSUPPORTED,
                t.span,
                "a located variable needs a name: write `name AT %IX0.0 : BOOL;`",
            );
            return Err(Reported);
        }
        loop {
            names.push(self.ident("a variable name")?);
            if self.eat(&Tok::Comma).is_none() {
                break;
            }
        }
        let location = if self.eat_kw(Kw::At).is_some() {
            match self.peek().tok.clone() {
                Tok::Direct(text) => {
                    let t = self.bump();
                    Some(Location { text, span: t.span })
                }
                _ => return Err(self.expected("a location such as %IX0.1 or %point after AT")),
            }
        } else {
            None
        };
        self.expect(&Tok::Colon, "`:` and the variable's type")?;
        let ty = self.type_spec(false)?;
        let edge = if self.eat_kw(Kw::REdge).is_some() {
            Some(Edge::Rising)
        } else if self.eat_kw(Kw::FEdge).is_some() {
            Some(Edge::Falling)
        } else {
            None
        };
        let init = if self.eat(&Tok::Assign).is_some() {
            Some(self.init()?)
        } else {
            None
        };
        self.expect_semi()?;
        Ok(VarDecl {
            names,
            location,
            ty,
            init,
            edge,
            span: start.to(self.prev_span()),
        })
    }

    // ---- configuration ----

    fn configuration(&mut self) -> PResult<Configuration> {
        let start = self.bump().span;
        let name = self.ident("the configuration's name")?;
        let mut globals = Vec::new();
        let mut resources = Vec::new();
        let mut single = Resource {
            name: name.clone(),
            on: None,
            globals: Vec::new(),
            tasks: Vec::new(),
            programs: Vec::new(),
            span: name.span,
        };
        loop {
            let s = self.pos;
            let r: PResult<()> = match self.peek().tok {
                Tok::Kw(Kw::VarGlobal | Kw::VarAccess | Kw::VarConfig) => {
                    self.var_block().map(|b| globals.push(b))
                }
                Tok::Kw(Kw::Resource) => self.resource().map(|r| resources.push(r)),
                Tok::Kw(Kw::Task) => self.task().map(|t| single.tasks.push(t)),
                Tok::Kw(Kw::Program) => self.program_config().map(|p| single.programs.push(p)),
                Tok::Kw(Kw::EndConfiguration) => break,
                _ => Err(self.expected("VAR_GLOBAL, RESOURCE, TASK, PROGRAM or END_CONFIGURATION")),
            };
            if r.is_err() {
                self.sync_decl(s);
                if self.is_top_start() && !self.at_kw(Kw::VarGlobal) && !self.at_kw(Kw::Program) {
                    break;
                }
            }
        }
        let end = self.expect_kw(Kw::EndConfiguration)?;
        self.eat(&Tok::Semi);
        if !single.tasks.is_empty() || !single.programs.is_empty() {
            single.span = name.span;
            resources.insert(0, single);
        }
        Ok(Configuration {
            name,
            globals,
            resources,
            span: start.to(end.span),
        })
    }

    fn resource(&mut self) -> PResult<Resource> {
        let start = self.bump().span;
        let name = self.ident("the resource's name")?;
        let on = if self.eat_kw(Kw::On).is_some() {
            Some(self.ident("the processor type after ON")?)
        } else {
            None
        };
        let mut res = Resource {
            name,
            on,
            globals: Vec::new(),
            tasks: Vec::new(),
            programs: Vec::new(),
            span: start,
        };
        loop {
            let s = self.pos;
            let r: PResult<()> = match self.peek().tok {
                Tok::Kw(Kw::VarGlobal) => self.var_block().map(|b| res.globals.push(b)),
                Tok::Kw(Kw::Task) => self.task().map(|t| res.tasks.push(t)),
                Tok::Kw(Kw::Program) => self.program_config().map(|p| res.programs.push(p)),
                Tok::Kw(Kw::EndResource) => break,
                _ => Err(self.expected("VAR_GLOBAL, TASK, PROGRAM or END_RESOURCE")),
            };
            if r.is_err() {
                self.sync_decl(s);
                if self.at_kw(Kw::EndConfiguration) || self.at(&Tok::Eof) {
                    break;
                }
            }
        }
        let end = self.expect_kw(Kw::EndResource)?;
        self.eat(&Tok::Semi);
        res.span = start.to(end.span);
        Ok(res)
    }

    fn task(&mut self) -> PResult<Task> {
        let start = self.bump().span;
        let name = self.ident("the task's name")?;
        let mut task = Task {
            name,
            interval: None,
            single: None,
            priority: None,
            span: start,
        };
        self.expect(&Tok::LParen, "`(` and the task's INTERVAL and PRIORITY")?;
        if !self.at(&Tok::RParen) {
            loop {
                let key = self.ident("INTERVAL, PRIORITY or SINGLE")?;
                self.expect(&Tok::Assign, "`:=`")?;
                let v = self.expr()?;
                if key.is("INTERVAL") {
                    task.interval = Some(v);
                } else if key.is("PRIORITY") {
                    task.priority = Some(v);
                } else if key.is("SINGLE") {
                    task.single = Some(v);
                } else {
                    self.error_at(
                        diag::SYNTAX,
                        key.span,
                        format!(
                            "`{}` is not a task setting; use INTERVAL, PRIORITY or SINGLE",
                            key.name
                        ),
                    );
                }
                if self.eat(&Tok::Comma).is_none() {
                    break;
                }
            }
        }
        self.expect(&Tok::RParen, "`)` after the task's settings")?;
        self.expect_semi()?;
        task.span = start.to(self.prev_span());
        Ok(task)
    }

    fn program_config(&mut self) -> PResult<ProgramConfig> {
        let start = self.bump().span;
        let retain = if self.eat_kw(Kw::Retain).is_some() {
            Retain::Retain
        } else if self.eat_kw(Kw::NonRetain).is_some() {
            Retain::NonRetain
        } else {
            Retain::Unspecified
        };
        let name = self.ident("the program instance's name")?;
        let task = if self.eat_kw(Kw::With).is_some() {
            Some(self.ident("a task name after WITH")?)
        } else {
            None
        };
        self.expect(&Tok::Colon, "`:` and the program's type")?;
        let type_name = self.ident("the program's type")?;
        let args = if self.at(&Tok::LParen) {
            self.args()?.0
        } else {
            Vec::new()
        };
        self.expect_semi()?;
        Ok(ProgramConfig {
            name,
            retain,
            task,
            type_name,
            args,
            span: start.to(self.prev_span()),
        })
    }

    // ---- statements ----

    fn is_stmt_list_end(&self, extra: &[Kw]) -> bool {
        match self.peek().tok {
            Tok::Eof => true,
            Tok::Kw(k) => {
                extra.contains(&k)
                    || matches!(
                        k,
                        Kw::EndIf
                            | Kw::Elsif
                            | Kw::Else
                            | Kw::EndCase
                            | Kw::EndFor
                            | Kw::EndWhile
                            | Kw::Until
                            | Kw::EndRepeat
                            | Kw::EndProgram
                            | Kw::EndFunction
                            | Kw::EndFunctionBlock
                            | Kw::Program
                            | Kw::Function
                            | Kw::FunctionBlock
                            | Kw::Type
                            | Kw::Configuration
                            | Kw::Var
                            | Kw::VarInput
                            | Kw::VarOutput
                            | Kw::VarInOut
                            | Kw::VarTemp
                            | Kw::VarExternal
                            | Kw::VarGlobal
                    )
            }
            _ => false,
        }
    }

    /// Statements until one of the list-ending keywords (not consumed).
    fn statements(&mut self, extra: &[Kw]) -> Vec<Stmt> {
        self.statements_in(extra, false)
    }

    fn statements_in(&mut self, extra: &[Kw], in_case: bool) -> Vec<Stmt> {
        let mut out = Vec::new();
        while !self.is_stmt_list_end(extra) {
            if in_case && self.looks_like_case_label() {
                break;
            }
            let start = self.pos;
            match self.statement() {
                Ok(s) => out.push(s),
                Err(Reported) => self.sync_stmt(start, extra),
            }
        }
        out
    }

    fn sync_stmt(&mut self, start: usize, extra: &[Kw]) {
        if self.pos == start {
            self.bump();
        }
        loop {
            if self.is_stmt_list_end(extra) {
                return;
            }
            match self.peek().tok {
                Tok::Semi => {
                    self.bump();
                    return;
                }
                Tok::Kw(Kw::If | Kw::Case | Kw::For | Kw::While | Kw::Repeat) => return,
                _ => {
                    self.bump();
                }
            }
        }
    }

    /// `x :=`, `x[…] :=`, `x.y :=`, `f(` or a statement keyword: not a declaration.
    fn looks_like_statement(&self) -> bool {
        match self.peek().tok {
            Tok::Kw(
                Kw::If
                | Kw::Case
                | Kw::For
                | Kw::While
                | Kw::Repeat
                | Kw::Return
                | Kw::Exit
                | Kw::Continue,
            ) => {
                // `IF : INT;` is a declaration with a reserved name (reported as such).
                !matches!(self.peek_at(1).tok, Tok::Colon | Tok::Comma)
            }
            Tok::Ident => matches!(
                self.peek_at(1).tok,
                Tok::Assign | Tok::LBracket | Tok::Dot | Tok::LParen
            ),
            _ => false,
        }
    }

    /// `1, 2..5, Red:` at the start of a CASE arm.
    fn looks_like_case_label(&self) -> bool {
        let mut k = 0;
        loop {
            match &self.peek_at(k).tok {
                Tok::Int(_)
                | Tok::Ident
                | Tok::TypedPrefix
                | Tok::Minus
                | Tok::Plus
                | Tok::Comma
                | Tok::DotDot
                | Tok::Dot
                | Tok::Kw(Kw::True | Kw::False)
                | Tok::Time { .. } => k += 1,
                Tok::Colon => return k > 0,
                _ => return false,
            }
        }
    }

    fn statement(&mut self) -> PResult<Stmt> {
        self.enter()?;
        let r = self.statement_inner();
        self.leave();
        r
    }

    fn statement_inner(&mut self) -> PResult<Stmt> {
        let start = self.peek().span;
        let kind = match self.peek().tok.clone() {
            Tok::Semi => {
                self.bump();
                return Ok(Stmt {
                    kind: StmtKind::Empty,
                    span: start,
                });
            }
            Tok::Kw(Kw::If) => self.if_stmt()?,
            Tok::Kw(Kw::Case) => self.case_stmt()?,
            Tok::Kw(Kw::For) => self.for_stmt()?,
            Tok::Kw(Kw::While) => {
                self.bump();
                let cond = self.expr()?;
                self.soft_kw(Kw::Do);
                let body = self.statements(&[]);
                self.expect_end(Kw::EndWhile, start, "WHILE")?;
                StmtKind::While { cond, body }
            }
            Tok::Kw(Kw::Repeat) => {
                self.bump();
                let body = self.statements(&[]);
                if self.eat_kw(Kw::Until).is_none() {
                    let t = self.peek().clone();
                    if self.quiet_at(&t) {
                        return Err(Reported);
                    }
                    let msg = format!("this REPEAT has no UNTIL; found {}", self.describe(&t));
                    self.error_at(diag::MISSING_END, start, msg);
                    return Err(Reported);
                }
                let until = self.expr()?;
                self.expect_end(Kw::EndRepeat, start, "REPEAT")?;
                StmtKind::Repeat { body, until }
            }
            Tok::Kw(Kw::Exit) => {
                self.bump();
                self.expect_semi()?;
                StmtKind::Exit
            }
            Tok::Kw(Kw::Continue) => {
                self.bump();
                self.expect_semi()?;
                StmtKind::Continue
            }
            Tok::Kw(Kw::Return) => {
                self.bump();
                self.expect_semi()?;
                StmtKind::Return
            }
            Tok::Ident | Tok::Direct(_) => {
                let target = self.postfix()?;
                if self.eat(&Tok::Assign).is_some() {
                    let value = self.expr()?;
                    self.expect_semi()?;
                    StmtKind::Assign { target, value }
                } else if let ExprKind::Call(call) = target.kind {
                    self.expect_semi()?;
                    StmtKind::Call(call)
                } else {
                    let t = self.peek().clone();
                    let msg = format!(
                        "expected `:=` (an assignment) or `(` (a call) after `{}`, found {}",
                        self.text_of(target.span),
                        self.describe(&t)
                    );
                    let code = diag::SYNTAX;
                    let msg = if t.tok == Tok::Eq {
                        format!(
                            "`=` compares; an assignment is written `{} := …;`",
                            self.text_of(target.span)
                        )
                    } else {
                        msg
                    };
                    self.error_at(code, t.span, msg);
                    return Err(Reported);
                }
            }
            _ => return Err(self.expected("a statement")),
        };
        Ok(Stmt {
            kind,
            span: start.to(self.prev_span()),
        })
    }

    /// `END_xxx` and its `;`.
    fn expect_end(&mut self, kw: Kw, start: Span, what: &str) -> PResult<()> {
        if self.eat_kw(kw).is_none() {
            let t = self.peek().clone();
            if self.quiet_at(&t) {
                return Err(Reported);
            }
            let msg = format!(
                "this {what} has no {}; found {}",
                kw.text(),
                self.describe(&t)
            );
            self.error_at(diag::MISSING_END, start, msg);
            self.reported_at = self.pos;
            return Err(Reported);
        }
        self.expect_semi()
    }

    fn if_stmt(&mut self) -> PResult<StmtKind> {
        let start = self.bump().span;
        let mut branches = Vec::new();
        let cond = self.expr()?;
        self.soft_kw(Kw::Then);
        let body = self.statements(&[]);
        branches.push((cond, body));
        let mut else_body = None;
        loop {
            if self.eat_kw(Kw::Elsif).is_some() {
                let cond = self.expr()?;
                self.soft_kw(Kw::Then);
                let body = self.statements(&[]);
                branches.push((cond, body));
            } else if self.eat_kw(Kw::Else).is_some() {
                else_body = Some(self.statements(&[]));
                break;
            } else {
                break;
            }
        }
        self.expect_end(Kw::EndIf, start, "IF")?;
        Ok(StmtKind::If {
            branches,
            else_body,
        })
    }

    fn case_stmt(&mut self) -> PResult<StmtKind> {
        let start = self.bump().span;
        let selector = self.expr()?;
        self.soft_kw(Kw::Of);
        let mut arms = Vec::new();
        let mut else_body = None;
        loop {
            if self.eat_kw(Kw::Else).is_some() {
                else_body = Some(self.statements(&[]));
                break;
            }
            if self.at_kw(Kw::EndCase) || self.is_stmt_list_end(&[]) {
                break;
            }
            let arm_start = self.peek().span;
            let s = self.pos;
            let labels = match self.case_labels() {
                Ok(l) => l,
                Err(Reported) => {
                    self.sync_stmt(s, &[]);
                    continue;
                }
            };
            let body = self.statements_in(&[], true);
            arms.push(CaseArm {
                labels,
                body,
                span: arm_start.to(self.prev_span()),
            });
        }
        self.expect_end(Kw::EndCase, start, "CASE")?;
        Ok(StmtKind::Case {
            selector,
            arms,
            else_body,
        })
    }

    fn case_labels(&mut self) -> PResult<Vec<CaseLabel>> {
        let mut labels = Vec::new();
        loop {
            let lo = self.expr()?;
            if self.eat(&Tok::DotDot).is_some() {
                let hi = self.expr()?;
                labels.push(CaseLabel::Range(lo, hi));
            } else {
                labels.push(CaseLabel::Value(lo));
            }
            if self.eat(&Tok::Comma).is_none() {
                break;
            }
        }
        self.expect(&Tok::Colon, "`:` after the CASE labels")?;
        Ok(labels)
    }

    fn for_stmt(&mut self) -> PResult<StmtKind> {
        let start = self.bump().span;
        let var = self.ident("the FOR loop's control variable")?;
        self.expect(&Tok::Assign, "`:=` and the initial value")?;
        let from = self.expr()?;
        if self.eat_kw(Kw::To).is_none() {
            // Reported once; the header is skipped up to DO and the body still read.
            self.expected("`TO`");
            while !matches!(
                self.peek().tok,
                Tok::Kw(Kw::Do | Kw::EndFor) | Tok::Semi | Tok::Eof
            ) {
                self.bump();
            }
            self.eat_kw(Kw::Do);
            let _ = self.statements(&[]);
            self.expect_end(Kw::EndFor, start, "FOR")?;
            return Err(Reported);
        }
        let to = self.expr()?;
        let by = if self.eat_kw(Kw::By).is_some() {
            Some(self.expr()?)
        } else {
            None
        };
        self.soft_kw(Kw::Do);
        let body = self.statements(&[]);
        self.expect_end(Kw::EndFor, start, "FOR")?;
        Ok(StmtKind::For {
            var,
            from,
            to,
            by,
            body,
        })
    }

    // ---- expressions ----

    fn expr(&mut self) -> PResult<Expr> {
        self.enter()?;
        let r = self.binary(0);
        self.leave();
        r
    }

    /// Operators by binding power: OR 1, XOR 2, AND 3, = <> 4, < > <= >= 5, + - 6,
    /// * / MOD 7, ** 8.
    fn binary_op(&self) -> Option<(BinaryOp, u8)> {
        Some(match self.peek().tok {
            Tok::Kw(Kw::Or) => (BinaryOp::Or, 1),
            Tok::Kw(Kw::Xor) => (BinaryOp::Xor, 2),
            Tok::Kw(Kw::And) | Tok::Amp => (BinaryOp::And, 3),
            Tok::Eq => (BinaryOp::Eq, 4),
            Tok::Ne => (BinaryOp::Ne, 4),
            Tok::Lt => (BinaryOp::Lt, 5),
            Tok::Le => (BinaryOp::Le, 5),
            Tok::Gt => (BinaryOp::Gt, 5),
            Tok::Ge => (BinaryOp::Ge, 5),
            Tok::Plus => (BinaryOp::Add, 6),
            Tok::Minus => (BinaryOp::Sub, 6),
            Tok::Star => (BinaryOp::Mul, 7),
            Tok::Slash => (BinaryOp::Div, 7),
            Tok::Kw(Kw::Mod) => (BinaryOp::Mod, 7),
            Tok::Power => (BinaryOp::Power, 8),
            _ => return None,
        })
    }

    fn binary(&mut self, min: u8) -> PResult<Expr> {
        let mut links = 0;
        let r = self.binary_chain(min, &mut links);
        self.unlink(links);
        r
    }

    fn binary_chain(&mut self, min: u8, links: &mut usize) -> PResult<Expr> {
        let mut lhs = self.unary()?;
        while let Some((op, bp)) = self.binary_op() {
            if bp <= min {
                break;
            }
            self.bump();
            self.link(links)?;
            self.enter()?;
            let rhs = self.binary(bp);
            self.leave();
            let rhs = rhs?;
            let span = lhs.span.to(rhs.span);
            lhs = Expr {
                kind: ExprKind::Binary(op, Box::new(lhs), Box::new(rhs)),
                span,
            };
        }
        Ok(lhs)
    }

    fn unary(&mut self) -> PResult<Expr> {
        let start = self.peek().span;
        let op = match self.peek().tok {
            Tok::Minus => UnaryOp::Neg,
            Tok::Plus => UnaryOp::Plus,
            Tok::Kw(Kw::Not) => UnaryOp::Not,
            _ => return self.postfix(),
        };
        self.bump();
        self.enter()?;
        let e = self.unary();
        self.leave();
        let e = e?;
        let span = start.to(e.span);
        Ok(Expr {
            kind: ExprKind::Unary(op, Box::new(e)),
            span,
        })
    }

    /// A primary followed by `.field`, `.3`, `[i]` and `(args)`.
    fn postfix(&mut self) -> PResult<Expr> {
        let mut links = 0;
        let r = self.postfix_chain(&mut links);
        self.unlink(links);
        r
    }

    fn postfix_chain(&mut self, links: &mut usize) -> PResult<Expr> {
        let mut e = self.primary()?;
        loop {
            if matches!(self.peek().tok, Tok::Dot | Tok::LBracket | Tok::LParen) {
                self.link(links)?;
            }
            match self.peek().tok {
                Tok::Dot => {
                    self.bump();
                    match self.peek().tok.clone() {
                        Tok::Int(n) => {
                            let t = self.bump();
                            let span = e.span.to(t.span);
                            e = Expr {
                                kind: ExprKind::Bit(Box::new(e), n.min(u32::MAX as u128) as u32),
                                span,
                            };
                        }
                        Tok::Direct(text) => {
                            // x.%X3: partial access.
                            let t = self.bump();
                            let bit = text
                                .strip_prefix(['X', 'x'])
                                .and_then(|d| d.parse::<u32>().ok());
                            let Some(bit) = bit else {
                                self.error_at(
                                    diag::UNSUPPORTED,
                                    t.span,
                                    "only bit access (.%X3 or .3) is supported after a variable",
                                );
                                return Err(Reported);
                            };
                            let span = e.span.to(t.span);
                            e = Expr {
                                kind: ExprKind::Bit(Box::new(e), bit),
                                span,
                            };
                        }
                        _ => {
                            let f = self.ident("a field name after `.`")?;
                            let span = e.span.to(f.span);
                            e = Expr {
                                kind: ExprKind::Field(Box::new(e), f),
                                span,
                            };
                        }
                    }
                }
                Tok::LBracket => {
                    self.bump();
                    let mut idx = Vec::new();
                    loop {
                        idx.push(self.expr()?);
                        if self.eat(&Tok::Comma).is_none() {
                            break;
                        }
                    }
                    let end = self.expect(&Tok::RBracket, "`]` after the index")?;
                    let span = e.span.to(end.span);
                    e = Expr {
                        kind: ExprKind::Index(Box::new(e), idx),
                        span,
                    };
                }
                Tok::LParen => {
                    if !matches!(
                        e.kind,
                        ExprKind::Name(_) | ExprKind::Field(..) | ExprKind::Index(..)
                    ) {
                        break;
                    }
                    let (args, end) = self.args()?;
                    let span = e.span.to(end);
                    e = Expr {
                        kind: ExprKind::Call(Call {
                            callee: Box::new(e),
                            args,
                            span,
                        }),
                        span,
                    };
                }
                Tok::Caret => {
                    let t = self.bump();
                    self.error_at(
                        diag::UNSUPPORTED,
                        t.span,
                        "pointers and references (^) are not supported",
                    );
                    return Err(Reported);
                }
                _ => break,
            }
        }
        Ok(e)
    }

    /// `( [arg {, arg}] )`; returns the closing parenthesis's span.
    fn args(&mut self) -> PResult<(Vec<Arg>, Span)> {
        self.expect(&Tok::LParen, "`(`")?;
        let mut args = Vec::new();
        if !self.at(&Tok::RParen) {
            loop {
                args.push(self.arg()?);
                if self.eat(&Tok::Comma).is_none() {
                    break;
                }
                if self.at(&Tok::RParen) {
                    break;
                }
            }
        }
        let end = self.expect(&Tok::RParen, "`)` or `,` in the argument list")?;
        Ok((args, end.span))
    }

    fn arg(&mut self) -> PResult<Arg> {
        let start = self.peek().span;
        let negated = self.at_kw(Kw::Not)
            && self.peek_at(1).tok == Tok::Ident
            && self.peek_at(2).tok == Tok::Arrow;
        if negated {
            self.bump();
        }
        if self.at(&Tok::Ident) && matches!(self.peek_at(1).tok, Tok::Assign | Tok::Arrow) {
            let name = self.ident("a parameter name")?;
            let output = self.bump().tok == Tok::Arrow;
            let value = if output && matches!(self.peek().tok, Tok::Comma | Tok::RParen) {
                None
            } else if output {
                Some(self.postfix()?)
            } else {
                Some(self.expr()?)
            };
            return Ok(Arg {
                name: Some(name),
                output,
                negated,
                value,
                span: start.to(self.prev_span()),
            });
        }
        let v = self.expr()?;
        Ok(Arg {
            name: None,
            output: false,
            negated: false,
            span: v.span,
            value: Some(v),
        })
    }

    fn primary(&mut self) -> PResult<Expr> {
        let t = self.peek().clone();
        let lit = |kind| Ok(Expr { kind, span: t.span });
        match t.tok {
            Tok::Int(v) => {
                self.bump();
                lit(ExprKind::Literal(Literal::Int {
                    value: v as i128,
                    ty: None,
                }))
            }
            Tok::Real(v) => {
                self.bump();
                lit(ExprKind::Literal(Literal::Real { value: v, ty: None }))
            }
            Tok::Kw(Kw::True) | Tok::Kw(Kw::False) => {
                self.bump();
                lit(ExprKind::Literal(Literal::Bool {
                    value: t.tok == Tok::Kw(Kw::True),
                    ty: None,
                }))
            }
            Tok::Str { bytes, wide } => {
                self.bump();
                lit(ExprKind::Literal(Literal::String { bytes, wide }))
            }
            Tok::Time { kind, nanos } => {
                self.bump();
                lit(ExprKind::Literal(Literal::Time { kind, nanos }))
            }
            Tok::Direct(text) => {
                self.bump();
                lit(ExprKind::Direct(text))
            }
            Tok::TypedPrefix => self.typed_literal(),
            Tok::Ident => {
                let id = self.ident("a name")?;
                Ok(Expr {
                    span: id.span,
                    kind: ExprKind::Name(id),
                })
            }
            Tok::LParen => {
                self.bump();
                let e = self.expr()?;
                let end = self.expect(&Tok::RParen, "`)`")?;
                Ok(Expr {
                    kind: ExprKind::Paren(Box::new(e)),
                    span: t.span.to(end.span),
                })
            }
            Tok::Error => {
                self.bump();
                Err(Reported)
            }
            _ => Err(self.expected("an expression")),
        }
    }

    /// `INT#5`, `INT#-5`, `REAL#1.5`, `BOOL#TRUE`, `WORD#16#FF`, `Color#Red`.
    fn typed_literal(&mut self) -> PResult<Expr> {
        let p = self.bump();
        let name_span = Span::new(self.file, p.span.start as usize, p.span.end as usize - 1);
        let ty = Ident::new(self.text_of(name_span), name_span);
        let neg = match self.peek().tok {
            Tok::Minus => {
                self.bump();
                true
            }
            Tok::Plus => {
                self.bump();
                false
            }
            _ => false,
        };
        let t = self.peek().clone();
        let kind = match t.tok {
            Tok::Int(v) => Literal::Int {
                value: if neg { -(v as i128) } else { v as i128 },
                ty: Some(ty),
            },
            Tok::Real(v) => Literal::Real {
                value: if neg { -v } else { v },
                ty: Some(ty),
            },
            Tok::Kw(Kw::True | Kw::False) if !neg => Literal::Bool {
                value: t.tok == Tok::Kw(Kw::True),
                ty: Some(ty),
            },
            Tok::Ident if !neg => Literal::Enum {
                ty,
                value: Ident::new(self.text_of(t.span), t.span),
            },
            Tok::Str { bytes, wide } if !neg => {
                // STRING#'abc'
                self.bump();
                return Ok(Expr {
                    kind: ExprKind::Literal(Literal::String { bytes, wide }),
                    span: p.span.to(t.span),
                });
            }
            _ => {
                return Err(self.expected(&format!(
                    "a value after `{}#` (e.g. {}#5)",
                    ty.name, ty.name
                )))
            }
        };
        self.bump();
        Ok(Expr {
            kind: ExprKind::Literal(kind),
            span: p.span.to(t.span),
        })
    }
}

mod il;
pub use il::parse_il_body;

#[cfg(test)]
mod tests;
