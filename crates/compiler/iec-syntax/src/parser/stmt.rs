//! Statements: lists with resynchronisation, assignments, calls, IF, CASE, loops.

use crate::ast::*;
use crate::diag;
use crate::lexer::{Kw, Tok};
use crate::source::Span;

use super::{PResult, Parser, Reported};

impl<'a, 'd> Parser<'a, 'd> {
    pub(super) fn is_stmt_list_end(&self, extra: &[Kw]) -> bool {
        match self.peek().tok {
            Tok::Eof => true,
            Tok::Ident => self.at_member_boundary(),
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
    pub(super) fn statements(&mut self, extra: &[Kw]) -> Vec<Stmt> {
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
                Ok(s) => {
                    out.push(s);
                    out.append(&mut self.queued);
                }
                Err(Reported) => {
                    self.queued.clear();
                    self.sync_stmt(start, extra)
                }
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
    pub(super) fn looks_like_statement(&self) -> bool {
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
            _ if self.at_name() => matches!(
                self.peek_at(1).tok,
                Tok::Assign | Tok::LBracket | Tok::Dot | Tok::LParen | Tok::Caret
            ),
            _ => false,
        }
    }

    /// `1, 2..5, Red:` at the start of a CASE arm.
    fn looks_like_case_label(&self) -> bool {
        let mut k = 0;
        loop {
            match &self.peek_at(k).tok {
                t if Self::is_name(t) => k += 1,
                Tok::Int(_)
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
                let cond = self.header_expr(Kw::Do)?;
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
                let until = self.header_expr(Kw::EndRepeat)?;
                self.until_rest();
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
            Tok::Direct(_) => self.assign_or_call()?,
            // `(p + 4)^ := 9;`: CODESYS's pointer moved and dereferenced.
            Tok::LParen => self.assign_or_call()?,
            _ if self.at_name() => self.assign_or_call()?,
            _ => return Err(self.expected("a statement")),
        };
        Ok(Stmt {
            kind,
            span: start.to(self.prev_span()),
        })
    }

    /// `target := value;`, `target REF= value;` (CODESYS) or `f(…);`.
    fn assign_or_call(&mut self) -> PResult<StmtKind> {
        Ok({
            let target = self.postfix()?;
            if self.eat(&Tok::Assign).is_some() {
                let mut value = self.expr()?;
                // CODESYS's and TwinCAT's chained assignment `a := b := 0;`: read right to
                // left as `b := 0; a := b;` (each place gets the value the next one holds).
                let mut targets = vec![target];
                while self.at(&Tok::Assign) && is_place(&value) {
                    self.bump();
                    targets.push(value);
                    value = self.expr()?;
                }
                self.expect_semi()?;
                let inner = targets.pop().expect("one target at least");
                let mut from = inner.clone();
                while let Some(t) = targets.pop() {
                    let span = t.span.to(from.span);
                    let next = t.clone();
                    self.queued.push(Stmt {
                        kind: StmtKind::Assign {
                            target: t,
                            value: from,
                        },
                        span,
                    });
                    from = next;
                }
                StmtKind::Assign {
                    target: inner,
                    value,
                }
            } else if self.at_word("REF")
                && self.peek_at(1).tok == Tok::Eq
                && self.peek().span.end == self.peek_at(1).span.start
            {
                self.bump();
                self.bump();
                let value = self.expr()?;
                self.expect_semi()?;
                StmtKind::RefAssign { target, value }
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
        })
    }

    /// A statement's condition or bounds, read up to the keyword after them (`THEN`, `DO`,
    /// `OF`, `END_REPEAT`). When they hold an error, the rest of the header is skipped to that
    /// keyword and an error expression stands for them, so the statement's body and `END_…`
    /// are still read: the block is not reported unclosed because its header was wrong.
    fn header_expr(&mut self, until: Kw) -> PResult<Expr> {
        let start = self.peek().span;
        match self.expr() {
            Ok(e) => Ok(e),
            Err(Reported) if self.too_deep => Err(Reported),
            Err(Reported) => {
                loop {
                    match self.peek().tok {
                        Tok::Kw(k) if k == until => break,
                        Tok::Semi | Tok::Eof => return Err(Reported),
                        _ if self.is_stmt_list_end(&[]) => return Err(Reported),
                        _ => {
                            self.bump();
                        }
                    }
                }
                Ok(Expr {
                    kind: ExprKind::Error,
                    span: start.to(self.prev_span()),
                })
            }
        }
    }

    /// After UNTIL's condition, a stray token before END_REPEAT (`UNTIL x > 1) END_REPEAT`):
    /// it is the one error, skipped to END_REPEAT on the same statement, so the REPEAT is
    /// not reported unclosed and its END_REPEAT orphaned.
    fn until_rest(&mut self) {
        if self.at_kw(Kw::EndRepeat) || matches!(self.peek().tok, Tok::Semi | Tok::Eof) {
            return;
        }
        if self.is_stmt_list_end(&[]) {
            return;
        }
        // On a later line it is the next statement: the REPEAT is unclosed (expect_end).
        let (prev, next) = (self.prev_span(), self.peek().span);
        if next.start >= prev.end
            && self
                .text_of(Span::new(prev.file, prev.end as usize, next.start as usize))
                .contains('\n')
        {
            return;
        }
        let _ = self.expected("END_REPEAT after the UNTIL condition");
        while !self.at_kw(Kw::EndRepeat)
            && !matches!(self.peek().tok, Tok::Semi | Tok::Eof)
            && !self.is_stmt_list_end(&[])
        {
            self.bump();
        }
        if !self.at_kw(Kw::EndRepeat) {
            self.reported_at = self.pos;
        }
    }

    /// `END_xxx` and its `;`, which may be left out as CODESYS, TwinCAT and blark allow (the
    /// keyword ends the statement: nothing is ambiguous without it).
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
        self.eat(&Tok::Semi);
        Ok(())
    }

    fn if_stmt(&mut self) -> PResult<StmtKind> {
        let start = self.bump().span;
        let mut branches = Vec::new();
        let cond = self.header_expr(Kw::Then)?;
        self.soft_kw(Kw::Then);
        let body = self.statements(&[]);
        branches.push((cond, body));
        let mut else_body = None;
        loop {
            if self.eat_kw(Kw::Elsif).is_some() {
                let cond = self.header_expr(Kw::Then)?;
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
        let selector = self.header_expr(Kw::Of)?;
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
        let name = self.ident("the FOR loop's control variable")?;
        let var = Expr {
            span: name.span,
            kind: ExprKind::Name(name),
        };
        // `a[1]`, `s.x`: the rest of the designator after the name (CODESYS, TwinCAT).
        let var = Box::new(if matches!(self.peek().tok, Tok::LBracket | Tok::Dot) {
            self.designator_after(var)?
        } else {
            var
        });
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
        let to = self.header_expr(Kw::Do)?;
        let by = if self.eat_kw(Kw::By).is_some() {
            Some(self.header_expr(Kw::Do)?)
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
}

/// Whether an expression names a place an assignment can write (a variable, an element, a
/// member, a dereference).
fn is_place(e: &Expr) -> bool {
    match &e.kind {
        ExprKind::Name(_) | ExprKind::Direct(_) => true,
        ExprKind::Field(base, _)
        | ExprKind::Bit(base, _)
        | ExprKind::Part(base, _, _)
        | ExprKind::Index(base, _)
        | ExprKind::Deref(base) => is_place(base),
        _ => false,
    }
}
