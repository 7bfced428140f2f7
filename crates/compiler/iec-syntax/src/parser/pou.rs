//! POUs (programs, functions, function blocks) and their variable blocks.

use crate::ast::*;
use crate::diag;
use crate::lexer::{Kw, Tok};
use crate::source::Span;

use super::{PResult, Parser, Reported};

impl<'a, 'd> Parser<'a, 'd> {
    pub(super) fn pou(&mut self, kind: PouKind) -> PResult<Pou> {
        let start = self.bump().span;
        let mut oop = PouOop {
            modifiers: self.modifiers(),
            ..PouOop::default()
        };
        let name = self.ident("the POU's name")?;
        let return_type = if kind == PouKind::Function {
            // CODESYS and TwinCAT take a FUNCTION without a result type (called as a
            // statement); the checker refuses it in the standard's dialect.
            if self.eat(&Tok::Colon).is_some() {
                Some(self.type_spec(false)?)
            } else {
                None
            }
        } else {
            None
        };
        self.extends_implements(&mut oop)?;
        self.eat(&Tok::Semi);
        let end_kw = match kind {
            PouKind::Program => Kw::EndProgram,
            PouKind::FunctionBlock => Kw::EndFunctionBlock,
            PouKind::Function => Kw::EndFunction,
        };
        let mut var_blocks =
            self.var_blocks_until(|p: &Self| p.at_kw(end_kw) || p.at_member_start());
        // A chart's ACTION blocks are its own (SFC), so a chart's POU reads no member
        // before its body.
        let chart = self.body_is_chart(end_kw);
        if !chart {
            self.members(&mut oop);
        }
        if chart {
            let (stmts, hidden) = self.chart_body(kind, end_kw);
            if !hidden.is_empty() {
                var_blocks.push(VarBlock {
                    kind: VarKind::Local,
                    constant: false,
                    retain: Retain::Unspecified,
                    vars: hidden,
                    list: None,
                    span: name.span,
                });
            }
            let body = Body::St(stmts);
            let mut pou = self.pou_end(kind, name, return_type, var_blocks, body, start, end_kw)?;
            pou.oop = Box::new(oop);
            return Ok(pou);
        }
        if self.il {
            let body_start = self.peek().span;
            let code = self.il_instructions(end_kw);
            let body = Body::Il {
                code,
                span: body_start.at_start(),
            };
            let mut pou = self.pou_end(kind, name, return_type, var_blocks, body, start, end_kw)?;
            pou.oop = Box::new(oop);
            return Ok(pou);
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
            self.members(&mut oop);
        }
        self.members(&mut oop);
        let mut pou = self.pou_end(
            kind,
            name,
            return_type,
            var_blocks,
            Body::St(body),
            start,
            end_kw,
        )?;
        pou.oop = Box::new(oop);
        Ok(pou)
    }

    /// The variable blocks from here; a block with an error is skipped to its END_VAR, or to
    /// where `stop` says what follows has begun (the body, a member), so one bad declaration
    /// does not swallow the code after it.
    pub(super) fn var_blocks_until(&mut self, stop: impl Fn(&Self) -> bool) -> Vec<VarBlock> {
        let mut blocks = Vec::new();
        while self.is_var_block_start() {
            let s = self.pos;
            match self.var_block() {
                Ok(b) => blocks.push(b),
                Err(Reported) => {
                    if self.pos == s {
                        self.bump();
                    }
                    while !self.at_kw(Kw::EndVar) && !self.is_top_start() && !stop(self) {
                        self.bump();
                    }
                    self.eat_kw(Kw::EndVar);
                    self.eat(&Tok::Semi);
                }
            }
        }
        blocks
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
            oop: Box::default(),
        })
    }

    pub(super) fn is_var_block_start(&self) -> bool {
        self.at_var_inst()
            || matches!(
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

    pub(super) fn var_block(&mut self) -> PResult<VarBlock> {
        let t = self.bump();
        let kind = match t.tok {
            Tok::Kw(Kw::Var) => VarKind::Local,
            Tok::Kw(Kw::VarInput) => VarKind::Input,
            Tok::Kw(Kw::VarOutput) => VarKind::Output,
            Tok::Kw(Kw::VarInOut) => VarKind::InOut,
            Tok::Kw(Kw::VarTemp) => VarKind::Temp,
            Tok::Kw(Kw::VarExternal) => VarKind::External,
            Tok::Kw(Kw::VarGlobal) => VarKind::Global,
            Tok::Ident if self.text_of(t.span).eq_ignore_ascii_case("VAR_STAT") => VarKind::Stat,
            Tok::Ident => VarKind::Inst,
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
                        list: None,
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
            list: None,
            span: t.span.to(self.prev_span()),
        })
    }

    pub(super) fn var_decl(&mut self) -> PResult<VarDecl> {
        let start = self.peek().span;
        let mut names = Vec::new();
        // `AT %IX1.1 : BOOL;`: a located variable without a name (the standard's
        // `[variable_name] location`), which code names by its address: named `%IX1.1`,
        // a name no identifier can take (`%IX1.1` in code resolves to it).
        if self.at_kw(Kw::At) && matches!(self.peek_at(1).tok, Tok::Direct(_)) {
            self.bump();
            let t = self.bump();
            let Tok::Direct(text) = t.tok.clone() else {
                unreachable!("checked above")
            };
            names.push(Ident::new(format!("%{text}"), t.span));
            let location = Some(Location { text, span: t.span });
            return self.var_decl_rest(start, names, location);
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
        self.var_decl_rest(start, names, location)
    }

    /// A declaration after its names and location: `: type [R_EDGE] [:= init];`.
    fn var_decl_rest(
        &mut self,
        start: Span,
        names: Vec<Ident>,
        location: Option<Location>,
    ) -> PResult<VarDecl> {
        self.expect(&Tok::Colon, "`:` and the variable's type")?;
        // `fb : FB_X(args)` (CODESYS, TwinCAT): a block's name and its FB_init's arguments;
        // after an elementary type's name the parentheses are a subrange or enumeration.
        let fb_init_args = self.at(&Tok::Ident)
            && self.peek_at(1).tok == Tok::LParen
            && !super::decl::is_elementary_name(self.text_of(self.peek().span));
        let (ty, fb_init) = if fb_init_args {
            let name = self.ident("a type")?;
            let (args, _) = self.args()?;
            (TypeSpec::Named(name), Some(args))
        } else {
            (self.type_spec(false)?, None)
        };
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
            fb_init,
            span: start.to(self.prev_span()),
        })
    }
}
