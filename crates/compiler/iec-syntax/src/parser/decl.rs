//! The library's top level, TYPE blocks, type specifications and initial values.

use crate::ast::*;
use crate::diag;
use crate::lexer::{Kw, Tok};
use crate::source::Span;

use super::{EnumValues, PResult, Parser, Reported};

impl<'a, 'd> Parser<'a, 'd> {
    pub(super) fn library(&mut self) -> Library {
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
                Tok::Ident if self.at_member_start() => {
                    self.member_after(&mut lib);
                    continue;
                }
                Tok::Ident if self.at_interface() => self.interface(false).map(Element::Pou),
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
    pub(super) fn sync_decl(&mut self, start: usize) {
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
        // TwinCAT's `TYPE name EXTENDS base : STRUCT … END_STRUCT`.
        let extends = if self.at_word("EXTENDS") {
            self.bump();
            Some(self.ident("the base structure's name")?)
        } else {
            None
        };
        self.expect(&Tok::Colon, "`:` after the type name")?;
        let mut spec = self.type_spec(true)?;
        if let Some(b) = extends {
            match &mut spec {
                TypeSpec::Struct { base, .. } => *base = Some(b),
                TypeSpec::Unsupported { .. } => {}
                TypeSpec::Union { span, .. } => {
                    self.error_at(
                        diag::UNSUPPORTED,
                        *span,
                        "a UNION that EXTENDS another is not supported yet; list all its members",
                    );
                }
                other => {
                    self.error_at(
                        diag::BAD_DECLARATION,
                        other.span(),
                        "only a STRUCT extends a base structure; write `TYPE name EXTENDS base : STRUCT … END_STRUCT`",
                    );
                }
            }
        }
        let init = if self.eat(&Tok::Assign).is_some() {
            Some(self.init()?)
        } else {
            None
        };
        // TwinCAT and CODESYS write `END_STRUCT` (and the last declaration) without `;`
        // before `END_TYPE`: the keyword ends the declaration.
        let closed = matches!(
            spec,
            TypeSpec::Struct { .. } | TypeSpec::Union { .. } | TypeSpec::Unsupported { .. }
        ) && init.is_none();
        if !(closed || self.at_kw(Kw::EndType)) {
            self.expect_semi()?;
        } else {
            self.eat(&Tok::Semi);
        }
        let span = name.span.to(self.prev_span());
        Ok(TypeDecl {
            name,
            spec,
            init,
            span,
        })
    }

    /// A type specification; `in_type` allows STRUCT.
    pub(super) fn type_spec(&mut self, in_type: bool) -> PResult<TypeSpec> {
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
                // `ARRAY[*, *] OF T`: dimensions whose bounds the caller's array gives.
                if self.at(&Tok::Star) {
                    let mut dims = 0u32;
                    loop {
                        if self.at(&Tok::Star) {
                            self.bump();
                            dims += 1;
                        } else {
                            return Err(
                                self.expected("`*` (every dimension of ARRAY[*, …] is `*`)")
                            );
                        }
                        if self.eat(&Tok::Comma).is_none() {
                            break;
                        }
                    }
                    self.expect(&Tok::RBracket, "`]` after the array's dimensions")?;
                    self.expect_kw(Kw::Of)?;
                    let elem = self.type_spec(false)?;
                    let span = start.to(self.prev_span());
                    return Ok(TypeSpec::ArrayStar {
                        dims,
                        elem: Box::new(elem),
                        span,
                    });
                }
                let mut ranges = Vec::new();
                loop {
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
            // CODESYS's and TwinCAT's UNION … END_UNION: every member starts at byte 0.
            Tok::Ident if in_type && self.at_word("UNION") => {
                self.bump();
                let mut members = Vec::new();
                while !self.at_word("END_UNION") && !self.is_top_start() && !self.at_kw(Kw::EndType)
                {
                    let s = self.pos;
                    match self.var_decl() {
                        Ok(d) => members.push(d),
                        Err(Reported) => self.sync_decl(s),
                    }
                }
                if !self.at_word("END_UNION") {
                    return Err(self.expected("`END_UNION`"));
                }
                self.bump();
                Ok(TypeSpec::Union {
                    members,
                    span: start.to(self.prev_span()),
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
                Ok(TypeSpec::Struct {
                    base: None,
                    fields,
                    span,
                })
            }
            Tok::LParen => {
                let (values, span) = self.enum_values()?;
                // CODESYS and TwinCAT write the base type after the values: `(A, B) BYTE`.
                let base = self.enum_base_after();
                let end = if base.is_some() {
                    self.prev_span()
                } else {
                    span
                };
                Ok(TypeSpec::Enum {
                    base,
                    values,
                    span: start.to(end),
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
                let kind = if name.is("REF_TO") {
                    Some(RefKind::RefTo)
                } else if (name.is("POINTER") || name.is("REFERENCE")) && self.at_kw(Kw::To) {
                    self.bump();
                    Some(if name.is("POINTER") {
                        RefKind::PointerTo
                    } else {
                        RefKind::ReferenceTo
                    })
                } else {
                    None
                };
                if let Some(kind) = kind {
                    let target = self.type_spec(false)?;
                    return Ok(TypeSpec::Ref {
                        kind,
                        target: Box::new(target),
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

    /// CODESYS's `(A, B) DINT`: an integer type's name right after an enumeration's `)`
    /// (where nothing else may stand) is its base type.
    fn enum_base_after(&mut self) -> Option<Ident> {
        const INTEGERS: [&str; 12] = [
            "SINT", "INT", "DINT", "LINT", "USINT", "UINT", "UDINT", "ULINT", "BYTE", "WORD",
            "DWORD", "LWORD",
        ];
        if !self.at(&Tok::Ident) {
            return None;
        }
        let text = self.text_of(self.peek().span);
        if !INTEGERS.iter().any(|t| t.eq_ignore_ascii_case(text)) {
            return None;
        }
        self.ident("a type").ok()
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

    pub(super) fn init(&mut self) -> PResult<Init> {
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
        if self.at(&Tok::LParen) && self.peek_at(1).tok == Tok::RParen {
            // CODESYS's and TwinCAT's `fb : FB_X := ();`: no value given (FB_init's
            // arguments, none here), so every member keeps its declared initial value.
            self.bump();
            self.bump();
            return Ok(Init::Struct {
                fields: Vec::new(),
                span: start.to(self.prev_span()),
            });
        }
        if self.at(&Tok::LParen)
            && Self::is_name(&self.peek_at(1).tok)
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
}

/// Whether a type's name is an elementary type's (after which `(…)` is a subrange or an
/// enumeration's values, not a block's FB_init arguments).
pub(super) fn is_elementary_name(name: &str) -> bool {
    const ELEMENTARY: [&str; 33] = [
        "SINT",
        "INT",
        "DINT",
        "LINT",
        "USINT",
        "UINT",
        "UDINT",
        "ULINT",
        "BYTE",
        "WORD",
        "DWORD",
        "LWORD",
        "BOOL",
        "BIT",
        "REAL",
        "LREAL",
        "TIME",
        "LTIME",
        "DATE",
        "LDATE",
        "TIME_OF_DAY",
        "TOD",
        "LTOD",
        "DATE_AND_TIME",
        "DT",
        "LDT",
        "STRING",
        "WSTRING",
        "CHAR",
        "WCHAR",
        "__XWORD",
        "__UXINT",
        "__XINT",
    ];
    ELEMENTARY.iter().any(|e| e.eq_ignore_ascii_case(name))
}
