//! Configurations: resources, tasks and program instances with their connections.

use crate::ast::*;
use crate::diag;
use crate::lexer::{Kw, Tok};

use super::{PResult, Parser};

impl<'a, 'd> Parser<'a, 'd> {
    pub(super) fn configuration(&mut self) -> PResult<Configuration> {
        let start = self.bump().span;
        let name = self.ident("the configuration's name")?;
        let mut globals = Vec::new();
        let mut resources = Vec::new();
        let mut var_config = Vec::new();
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
                Tok::Kw(Kw::VarConfig) => self.var_config().map(|mut v| var_config.append(&mut v)),
                Tok::Kw(Kw::VarGlobal | Kw::VarAccess) => self.var_block().map(|b| globals.push(b)),
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
            var_config,
            span: start.to(end.span),
        })
    }

    /// `VAR_CONFIG path [AT %loc] : type [:= init]; … END_VAR`.
    fn var_config(&mut self) -> PResult<Vec<VarConfigItem>> {
        self.bump();
        let mut items = Vec::new();
        while !self.at_kw(Kw::EndVar) {
            let start = self.peek().span;
            let mut path = vec![self.ident("an instance path (resource.instance.variable)")?];
            while self.eat(&Tok::Dot).is_some() {
                path.push(self.ident("a name after `.` in the path")?);
            }
            let location = if self.eat_kw(Kw::At).is_some() {
                match self.peek().tok.clone() {
                    Tok::Direct(text) => {
                        let t = self.bump();
                        Some(Location { text, span: t.span })
                    }
                    _ => return Err(self.expected("a location such as %QB1 after AT")),
                }
            } else {
                None
            };
            self.expect(&Tok::Colon, "`:` and the variable's type")?;
            let ty = self.type_spec(false)?;
            let init = if self.eat(&Tok::Assign).is_some() {
                Some(self.init()?)
            } else {
                None
            };
            self.expect_semi()?;
            items.push(VarConfigItem {
                path,
                location,
                ty,
                init,
                span: start.to(self.prev_span()),
            });
        }
        self.expect_kw(Kw::EndVar)?;
        self.eat(&Tok::Semi);
        Ok(items)
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
}
