//! Object orientation in text (IEC 61131-3 third edition as CODESYS and TwinCAT write it):
//! a FUNCTION_BLOCK's modifiers, `EXTENDS`/`IMPLEMENTS`, and its members `METHOD`,
//! `PROPERTY` (with `GET`/`SET`) and `ACTION`.
//!
//! The words are not reserved (CODESYS code uses `Method`, `Action` as names): each is read
//! as a keyword only where a name follows it, which no statement or declaration allows. A
//! member is accepted where the standard puts it (after the variable blocks), after the body
//! before `END_FUNCTION_BLOCK`, and after `END_FUNCTION_BLOCK` (the layout of TwinCAT text
//! exports and blark's grammar), where it belongs to the POU before it.

use crate::ast::*;
use crate::diag;
use crate::lexer::{Kw, Tok};
use crate::source::Span;

use super::{PResult, Parser, Reported};

/// The words that end a member's body, besides the POU keywords.
const MEMBER_ENDS: &[&str] = &[
    "END_METHOD",
    "END_PROPERTY",
    "END_ACTION",
    "END_GET",
    "END_SET",
];

impl<'a, 'd> Parser<'a, 'd> {
    /// The current token is the identifier `w` (any case).
    pub(super) fn at_word(&self, w: &str) -> bool {
        self.word_at(0).is_some_and(|t| t.eq_ignore_ascii_case(w))
    }

    fn word_at(&self, k: usize) -> Option<&'a str> {
        let t = self.peek_at(k);
        (t.tok == Tok::Ident).then(|| self.text_of(t.span))
    }

    /// `METHOD name`, `PROPERTY name`, `ACTION name`.
    pub(super) fn at_member_start(&self) -> bool {
        ["METHOD", "PROPERTY", "ACTION"]
            .iter()
            .any(|w| self.at_word(w))
            && Self::is_name(&self.peek_at(1).tok)
    }

    /// A word that ends a statement list: a member's end or the next member.
    pub(super) fn at_member_boundary(&self) -> bool {
        MEMBER_ENDS.iter().any(|w| self.at_word(w))
            || self.at_member_start()
            || ((self.at_word("GET") || self.at_word("SET"))
                && !matches!(
                    self.peek_at(1).tok,
                    Tok::Assign | Tok::Dot | Tok::LParen | Tok::LBracket | Tok::Caret
                ))
    }

    /// `INTERFACE name`.
    pub(super) fn at_interface(&self) -> bool {
        self.at_word("INTERFACE") && Self::is_name(&self.peek_at(1).tok)
    }

    /// `INTERFACE name [EXTENDS I_A, I_B]`, its METHODs and PROPERTYs (declarations only),
    /// `END_INTERFACE`: a FUNCTION_BLOCK without variables or body marked `interface`, its
    /// bases in `implements`. A method ends with `END_METHOD`; a property's `GET`/`SET`
    /// (each optional, with or without `END_GET`/`END_SET`) say which accessors it has (both
    /// when neither is written), `END_PROPERTY` optional as TwinCAT exports write it.
    /// `decl_only`: a TwinCAT `<Declaration>`, where END_INTERFACE may be left out.
    pub(super) fn interface(&mut self, decl_only: bool) -> PResult<Pou> {
        let start = self.bump().span;
        let name = self.ident("the interface's name")?;
        let mut oop = PouOop {
            interface: true,
            ..PouOop::default()
        };
        if self.at_word("EXTENDS") {
            self.bump();
            loop {
                let i = self.dotted_name("an interface's name")?;
                oop.implements.push(i);
                if self.eat(&Tok::Comma).is_none() {
                    break;
                }
            }
        }
        self.eat(&Tok::Semi);
        self.interface_members(&mut oop)?;
        let end = if decl_only && self.at(&Tok::Eof) {
            self.prev_span()
        } else if !self.at_word("END_INTERFACE") {
            let t = self.peek().clone();
            if !self.quiet_at(&t) {
                let msg = format!(
                    "INTERFACE {} has no END_INTERFACE; found {} (an interface holds METHOD and PROPERTY declarations only)",
                    name.name,
                    self.describe(&t)
                );
                self.error_at(diag::MISSING_END, t.span, msg);
            }
            return Err(Reported);
        } else {
            let end = self.bump().span;
            self.eat(&Tok::Semi);
            end
        };
        Ok(Pou {
            kind: PouKind::FunctionBlock,
            name,
            return_type: None,
            var_blocks: Vec::new(),
            body: Body::St(Vec::new()),
            span: start.to(end),
            oop: Box::new(oop),
        })
    }

    /// The METHOD and PROPERTY declarations of an interface (also a TwinCAT `<Itf>`'s
    /// members, one at a time).
    pub(super) fn interface_members(&mut self, oop: &mut PouOop) -> PResult<()> {
        while self.at_member_start() {
            if self.at_word("ACTION") {
                let t = self.peek().clone();
                self.error_at(
                    diag::SYNTAX,
                    t.span,
                    "an INTERFACE declares METHODs and PROPERTYs, not ACTIONs; move the action to a FUNCTION_BLOCK",
                );
                return Err(Reported);
            }
            let method = self.at_word("METHOD");
            self.member(oop, true)?;
            if method {
                if let Some(m) = oop.methods.last_mut() {
                    m.modifiers.is_abstract = true;
                }
                if !self.at_word("END_METHOD")
                    && !self.at_member_start()
                    && !self.at_word("END_INTERFACE")
                    && !self.is_top_start()
                {
                    let t = self.peek().clone();
                    let name = oop
                        .methods
                        .last()
                        .map_or(String::new(), |m| m.pou.name.name.clone());
                    self.error_at(
                        diag::SYNTAX,
                        t.span,
                        format!("METHOD {name} of an INTERFACE is a declaration without a body; found {}: write the code in the FUNCTION_BLOCKs that implement it", self.describe(&t)),
                    );
                    while !self.at(&Tok::Eof) && !self.at_word("END_METHOD") && !self.is_top_start()
                    {
                        self.bump();
                    }
                }
                if self.at_word("END_METHOD") {
                    self.bump();
                    self.eat(&Tok::Semi);
                }
                continue;
            }
            let (mut get, mut set) = (false, false);
            while self.at_word("GET") || self.at_word("SET") {
                let is_get = self.at_word("GET");
                self.bump();
                self.eat(&Tok::Semi);
                let end = if is_get { "END_GET" } else { "END_SET" };
                let _ = self.member_var_blocks();
                if self.at_word(end) {
                    self.bump();
                    self.eat(&Tok::Semi);
                }
                get |= is_get;
                set |= !is_get;
            }
            if !get && !set {
                (get, set) = (true, true);
            }
            if self.at_word("END_PROPERTY") {
                self.bump();
                self.eat(&Tok::Semi);
            }
            if let Some(p) = oop.properties.last_mut() {
                p.modifiers.is_abstract = true;
                let span = p.name.span;
                if get {
                    p.get = Some(accessor(p, true, Vec::new(), Body::St(Vec::new()), span));
                }
                if set {
                    p.set = Some(accessor(p, false, Vec::new(), Body::St(Vec::new()), span));
                }
            }
        }
        Ok(())
    }

    /// `VAR_INST` (a METHOD's variables kept in the instance).
    /// `VAR_INST` (a METHOD's variables kept in the instance) or `VAR_STAT` (CODESYS and
    /// TwinCAT: one variable shared by every call and instance), words rather than keywords
    /// so that code naming a variable so still reads.
    pub(super) fn at_var_inst(&self) -> bool {
        self.at_word("VAR_INST") || self.at_word("VAR_STAT")
    }

    /// Modifiers written before a name: `ABSTRACT`, `FINAL`, an access specifier. A word
    /// is a modifier only when another name follows it.
    pub(super) fn modifiers(&mut self) -> Modifiers {
        let mut m = Modifiers::default();
        while let Some(w) = self.word_at(0) {
            if !Self::is_name(&self.peek_at(1).tok) {
                break;
            }
            if let Some(a) = Access::from_word(w) {
                m.access = a;
            } else if w.eq_ignore_ascii_case("ABSTRACT") {
                m.is_abstract = true;
            } else if w.eq_ignore_ascii_case("FINAL") {
                m.is_final = true;
            } else {
                break;
            }
            self.bump();
        }
        m
    }

    /// `EXTENDS base` and `IMPLEMENTS I1, I2` after a FUNCTION_BLOCK's name.
    pub(super) fn extends_implements(&mut self, oop: &mut PouOop) -> PResult<()> {
        loop {
            if self.at_word("EXTENDS") {
                self.bump();
                oop.extends = Some(self.dotted_name("the name of the function block extended")?);
            } else if self.at_word("IMPLEMENTS") {
                self.bump();
                loop {
                    let i = self.dotted_name("an interface's name")?;
                    oop.implements.push(i);
                    if self.eat(&Tok::Comma).is_none() {
                        break;
                    }
                }
            } else {
                return Ok(());
            }
        }
    }

    /// A name, possibly qualified by a library's namespace (`TcUnit.FB_TestSuite`), kept
    /// whole: the checker looks the last part up and names the library when it is missing.
    fn dotted_name(&mut self, what: &str) -> PResult<Ident> {
        let mut id = self.ident(what)?;
        while self.at(&Tok::Dot) && Self::is_name(&self.peek_at(1).tok) {
            self.bump();
            let next = self.ident(what)?;
            id = Ident::new(format!("{}.{}", id.name, next.name), id.span.to(next.span));
        }
        Ok(id)
    }

    /// Members in a row (where `at_member_start`), added to `oop`.
    pub(super) fn members(&mut self, oop: &mut PouOop) {
        while self.at_member_start() {
            let start = self.pos;
            if self.member(oop, false).is_err() {
                if self.pos == start {
                    self.bump();
                }
                while !self.is_top_start()
                    && !self.at_member_start()
                    && !matches!(
                        self.peek().tok,
                        Tok::Kw(Kw::EndFunctionBlock | Kw::EndProgram | Kw::EndFunction)
                    )
                {
                    if MEMBER_ENDS.iter().any(|w| self.at_word(w)) {
                        self.bump();
                        self.eat(&Tok::Semi);
                        break;
                    }
                    self.bump();
                }
            }
        }
    }

    /// A member after `END_FUNCTION_BLOCK`/`END_PROGRAM`: it belongs to the POU before it.
    pub(super) fn member_after(&mut self, lib: &mut Library) {
        let at = self.peek().span;
        let mut oop = PouOop::default();
        let after_interface =
            matches!(lib.elements.last(), Some(Element::Pou(p)) if p.oop.interface);
        if after_interface {
            // blark's layout: an interface's members after its END_INTERFACE.
            if self.interface_members(&mut oop).is_err() {
                self.bump();
            }
        } else {
            self.members(&mut oop);
        }
        match lib.elements.last_mut() {
            Some(Element::Pou(p)) if p.kind != PouKind::Function => {
                p.oop.methods.append(&mut oop.methods);
                p.oop.properties.append(&mut oop.properties);
                p.oop.actions.append(&mut oop.actions);
            }
            _ => self.error_at(
                diag::SYNTAX,
                at,
                "a METHOD, PROPERTY or ACTION belongs to a FUNCTION_BLOCK (an ACTION also to a PROGRAM): write it inside the POU, or right after its END_FUNCTION_BLOCK",
            ),
        }
    }

    /// One METHOD, PROPERTY or ACTION. With `decl_only` (a TwinCAT `<Declaration>`), only the
    /// header and variable blocks are there: no body, no END_….
    pub(super) fn member(&mut self, oop: &mut PouOop, decl_only: bool) -> PResult<()> {
        if self.at_word("METHOD") {
            let m = self.method(decl_only)?;
            oop.methods.push(m);
        } else if self.at_word("PROPERTY") {
            let p = self.property(decl_only)?;
            oop.properties.push(p);
        } else {
            let a = self.action(decl_only)?;
            oop.actions.push(a);
        }
        Ok(())
    }

    fn method(&mut self, decl_only: bool) -> PResult<Method> {
        let start = self.bump().span;
        let modifiers = self.modifiers();
        let name = self.member_name("the method's name")?;
        let return_type = if self.eat(&Tok::Colon).is_some() {
            Some(self.type_spec(false)?)
        } else {
            None
        };
        self.eat(&Tok::Semi);
        let var_blocks = self.member_var_blocks();
        let (body, end) = self.member_body(decl_only, "END_METHOD", &name)?;
        Ok(Method {
            modifiers,
            pou: Pou {
                kind: PouKind::Function,
                name,
                return_type,
                var_blocks,
                body,
                span: start.to(end),
                oop: Box::default(),
            },
        })
    }

    /// A member's name: `M`, or blark's qualified `FB.M` (the last part).
    fn member_name(&mut self, what: &str) -> PResult<Ident> {
        let id = self.dotted_name(what)?;
        Ok(match id.name.rsplit_once('.') {
            Some((_, last)) => Ident::new(last, id.span),
            None => id,
        })
    }

    /// Variable blocks of a member (VAR_INST included).
    pub(super) fn member_var_blocks(&mut self) -> Vec<VarBlock> {
        self.var_blocks_until(Self::at_member_boundary)
    }

    /// The statements up to `end` (a word) and the span of `end`.
    fn member_body(&mut self, decl_only: bool, end: &str, name: &Ident) -> PResult<(Body, Span)> {
        if decl_only {
            return Ok((Body::St(Vec::new()), self.prev_span()));
        }
        let body = self.statements(&[]);
        self.end_word(end, name)?;
        Ok((Body::St(body), self.prev_span()))
    }

    fn end_word(&mut self, end: &str, name: &Ident) -> PResult<()> {
        if self.at_word(end) {
            self.bump();
            self.eat(&Tok::Semi);
            return Ok(());
        }
        let t = self.peek().clone();
        if self.quiet_at(&t) {
            return Err(Reported);
        }
        let msg = format!("{} has no {end}; found {}", name.name, self.describe(&t));
        self.error_at(diag::MISSING_END, t.span, msg);
        Err(Reported)
    }

    /// `PROPERTY name : type` then `GET … END_GET` and/or `SET … END_SET`, `END_PROPERTY`.
    fn property(&mut self, decl_only: bool) -> PResult<Property> {
        let start = self.bump().span;
        let modifiers = self.modifiers();
        let name = self.member_name("the property's name")?;
        self.expect(&Tok::Colon, "`:` and the property's type")?;
        let ty = self.type_spec(false)?;
        self.eat(&Tok::Semi);
        let mut prop = Property {
            modifiers,
            name: name.clone(),
            ty,
            get: None,
            set: None,
            span: start,
        };
        if decl_only {
            return Ok(prop);
        }
        loop {
            let get = self.at_word("GET");
            if !get && !self.at_word("SET") {
                break;
            }
            let at = self.bump().span;
            self.eat(&Tok::Semi);
            let var_blocks = self.member_var_blocks();
            let body = self.statements(&[]);
            self.end_word(if get { "END_GET" } else { "END_SET" }, &name)?;
            let acc = accessor(
                &prop,
                get,
                var_blocks,
                Body::St(body),
                at.to(self.prev_span()),
            );
            if get {
                prop.get = Some(acc);
            } else {
                prop.set = Some(acc);
            }
        }
        if prop.get.is_none() && prop.set.is_none() {
            let t = self.peek().clone();
            if !self.quiet_at(&t) {
                self.error_at(
                    diag::SYNTAX,
                    t.span,
                    format!(
                        "property {} needs a GET … END_GET or SET … END_SET section; found {}",
                        name.name,
                        self.describe(&t)
                    ),
                );
            }
            return Err(Reported);
        }
        self.end_word("END_PROPERTY", &name)?;
        prop.span = start.to(self.prev_span());
        Ok(prop)
    }

    /// `ACTION name: … END_ACTION` (the colon optional, as CODESYS writes it too).
    fn action(&mut self, decl_only: bool) -> PResult<Action> {
        let start = self.bump().span;
        let name = self.member_name("the action's name")?;
        self.eat(&Tok::Colon);
        let (body, end) = self.member_body(decl_only, "END_ACTION", &name)?;
        Ok(Action {
            name,
            body,
            span: start.to(end),
        })
    }
}

/// A property's GET (a function returning the property's type, its result named as the
/// property) or SET (the new value an input named as the property).
pub fn accessor(
    prop: &Property,
    get: bool,
    mut var_blocks: Vec<VarBlock>,
    body: Body,
    span: Span,
) -> Pou {
    if !get {
        var_blocks.insert(
            0,
            VarBlock {
                kind: VarKind::Input,
                constant: false,
                retain: Retain::Unspecified,
                vars: vec![VarDecl {
                    names: vec![prop.name.clone()],
                    location: None,
                    ty: prop.ty.clone(),
                    init: None,
                    edge: None,
                    fb_init: None,
                    span: prop.name.span,
                }],
                list: None,
                span: prop.name.span,
            },
        );
    }
    Pou {
        kind: PouKind::Function,
        name: prop.name.clone(),
        return_type: get.then(|| prop.ty.clone()),
        var_blocks,
        body,
        span,
        oop: Box::default(),
    }
}
