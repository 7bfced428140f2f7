//! Instruction List bodies: one instruction per line (`[label:] OPERATOR[N|C|CN][(] [operand]`),
//! labels alone on their line or before an instruction, a deferred operation's `)` on a line
//! of its own, CAL argument lists across lines. Operands are read by the Structured Text
//! expression parser (constants, variables, fields, elements, bits), so they mean the same.
//!
//! A line that is not an instruction is reported (`E020`) and skipped; the rest of the body is
//! still read, so one run reports every error.

use super::*;

/// Parses an IL body alone (a PLCopen `<IL>` body).
pub fn parse_il_body(file: FileId, text: &str, diags: &mut Diagnostics) -> Vec<IlInstr> {
    let tokens = lexer::lex(file, text, diags);
    let mut p = Parser::new(file, text, tokens, diags);
    let mut code = p.il_instructions(Kw::EndProgram);
    while !p.at(&Tok::Eof) {
        let t = p.peek().clone();
        let msg = format!(
            "{} is not an IL instruction; an <IL> body holds instructions only",
            p.describe(&t)
        );
        p.error_at(diag::IL_SYNTAX, t.span, msg);
        let line = p.line_at(0);
        p.bump();
        p.skip_line(line);
        code.extend(p.il_instructions(Kw::EndProgram));
    }
    code
}

/// What an operator word is, its modifiers apart.
enum Word {
    Op(IlOp, bool),
    Jump(IlCond),
    Call(IlCond),
    Return(IlCond),
    FbInput,
    Function,
}

fn word(upper: &str) -> Word {
    use IlOp::*;
    match upper {
        "LD" => Word::Op(Ld, false),
        "LDN" => Word::Op(Ld, true),
        "ST" => Word::Op(St, false),
        "STN" => Word::Op(St, true),
        "S" => Word::Op(S, false),
        "R" => Word::Op(R, false),
        "AND" | "&" => Word::Op(And, false),
        "ANDN" | "&N" => Word::Op(And, true),
        "OR" => Word::Op(Or, false),
        "ORN" => Word::Op(Or, true),
        "XOR" => Word::Op(Xor, false),
        "XORN" => Word::Op(Xor, true),
        "NOT" => Word::Op(Not, false),
        "ADD" => Word::Op(Add, false),
        "SUB" => Word::Op(Sub, false),
        "MUL" => Word::Op(Mul, false),
        "DIV" => Word::Op(Div, false),
        "MOD" => Word::Op(Mod, false),
        "GT" => Word::Op(Gt, false),
        "GE" => Word::Op(Ge, false),
        "EQ" => Word::Op(Eq, false),
        "NE" => Word::Op(Ne, false),
        "LE" => Word::Op(Le, false),
        "LT" => Word::Op(Lt, false),
        "JMP" => Word::Jump(None),
        "JMPC" => Word::Jump(Some(true)),
        "JMPCN" => Word::Jump(Some(false)),
        "CAL" => Word::Call(None),
        "CALC" => Word::Call(Some(true)),
        "CALCN" => Word::Call(Some(false)),
        "RET" => Word::Return(None),
        "RETC" => Word::Return(Some(true)),
        "RETCN" => Word::Return(Some(false)),
        "S1" | "R1" | "CLK" | "CU" | "CD" | "PV" | "IN" | "PT" => Word::FbInput,
        _ => Word::Function,
    }
}

impl Parser<'_, '_> {
    fn compute_lines(&mut self) {
        if self.tok_lines.len() == self.toks.len() {
            return;
        }
        let bytes = self.text.as_bytes();
        let mut line = 0u32;
        let mut at = 0usize;
        let mut lines = Vec::with_capacity(self.toks.len());
        for t in &self.toks {
            let to = (t.span.start as usize).min(bytes.len());
            if to > at {
                line += bytes[at..to].iter().filter(|&&b| b == b'\n').count() as u32;
                at = to;
            }
            lines.push(line);
        }
        self.tok_lines = lines;
    }

    fn line_at(&self, k: usize) -> u32 {
        let i = (self.pos + k).min(self.toks.len() - 1);
        self.tok_lines.get(i).copied().unwrap_or(0)
    }

    /// The next token is on line `line` (and is not the end).
    fn on_line(&self, line: u32) -> bool {
        self.peek().tok != Tok::Eof && self.line_at(0) == line
    }

    fn skip_line(&mut self, line: u32) {
        while self.on_line(line) {
            self.bump();
        }
    }

    /// Instructions up to `END_…` (not consumed), a declaration keyword or the end.
    pub(super) fn il_instructions(&mut self, end_kw: Kw) -> Vec<IlInstr> {
        self.compute_lines();
        let mut out = Vec::new();
        while !self.is_stmt_list_end(&[end_kw]) {
            let line = self.line_at(0);
            let start = self.pos;
            if self.il_line(line, &mut out).is_err() {
                if self.pos == start {
                    self.bump();
                }
                self.skip_line(line);
            }
        }
        out
    }

    fn il_line(&mut self, line: u32, out: &mut Vec<IlInstr>) -> PResult<()> {
        // `label:` (not `name :=`).
        if self.at(&Tok::Ident) && self.peek_at(1).tok == Tok::Colon && self.line_at(1) == line {
            let id = self.ident("a label")?;
            self.bump();
            let span = id.span;
            out.push(IlInstr {
                kind: IlKind::Label(id),
                span,
            });
            if !self.on_line(line) || self.is_stmt_list_end(&[]) {
                return Ok(());
            }
        }
        if let Some(t) = self.eat(&Tok::RParen) {
            out.push(IlInstr {
                kind: IlKind::Close,
                span: t.span,
            });
            return self.il_eol(line, out);
        }
        let t = self.peek().clone();
        let text = match &t.tok {
            Tok::Ident => self.text_of(t.span).to_ascii_uppercase(),
            Tok::Kw(k @ (Kw::And | Kw::Or | Kw::Xor | Kw::Not | Kw::Mod)) => k.text().to_string(),
            Tok::Amp => {
                // `&` and `&N`.
                if self.peek_at(1).tok == Tok::Ident
                    && self.text_of(self.peek_at(1).span).eq_ignore_ascii_case("N")
                    && self.peek_at(1).span.start == t.span.end
                {
                    self.bump();
                    "&N".into()
                } else {
                    "&".into()
                }
            }
            _ => {
                if self.quiet_at(&t) {
                    return Err(Reported);
                }
                let msg = format!(
                    "expected an IL instruction (LD, ST, AND, JMP, CAL, a function…) or a label, found {}",
                    self.describe(&t)
                );
                self.error_at(diag::IL_SYNTAX, t.span, msg);
                return Err(Reported);
            }
        };
        let op_tok = self.bump();
        let op_span = if text == "&N" {
            t.span.to(self.prev_span())
        } else {
            op_tok.span
        };
        let kind = match word(&text) {
            Word::Op(op, negated) => {
                let deferred = self.on_line(line) && self.at(&Tok::LParen);
                if deferred {
                    if op.binary().is_none() {
                        self.error_at(
                            diag::IL_SYNTAX,
                            self.peek().span,
                            format!("{text} takes no parenthesised operand; only AND, OR, XOR, ADD, SUB, MUL, DIV, MOD and the comparisons do"),
                        );
                        return Err(Reported);
                    }
                    self.bump();
                }
                let operand = if op == IlOp::Not {
                    None
                } else if deferred {
                    // `AND( x` or `AND(` followed by LD on the next line.
                    if self.on_line(line) && !self.at(&Tok::RParen) {
                        Some(self.il_operand(&text)?)
                    } else {
                        None
                    }
                } else if self.on_line(line) {
                    Some(self.il_operand(&text)?)
                } else {
                    self.error_at(
                        diag::IL_SYNTAX,
                        op_span,
                        format!("{text} needs an operand on its line (a variable or a constant)"),
                    );
                    return Err(Reported);
                };
                IlKind::Op {
                    op,
                    negated,
                    deferred,
                    operand,
                }
            }
            Word::Jump(cond) => {
                if !self.on_line(line) {
                    self.error_at(
                        diag::IL_SYNTAX,
                        op_span,
                        format!("{text} needs the label to jump to: {text} name"),
                    );
                    return Err(Reported);
                }
                let label = self.ident("a label")?;
                IlKind::Jump { cond, label }
            }
            Word::Call(cond) => {
                if !self.on_line(line) {
                    self.error_at(
                        diag::IL_SYNTAX,
                        op_span,
                        format!("{text} needs the instance to call: {text} name or {text} name(IN := x)"),
                    );
                    return Err(Reported);
                }
                let e = self.postfix()?;
                match e.kind {
                    ExprKind::Call(call) => IlKind::Call {
                        cond,
                        instance: *call.callee,
                        args: call.args,
                    },
                    _ => IlKind::Call {
                        cond,
                        instance: e,
                        args: Vec::new(),
                    },
                }
            }
            Word::Return(cond) => IlKind::Return { cond },
            Word::FbInput => {
                if !self.on_line(line) {
                    self.error_at(
                        diag::IL_SYNTAX,
                        op_span,
                        format!("{text} needs the function block instance whose input it sets: {text} name"),
                    );
                    return Err(Reported);
                }
                let instance = self.postfix()?;
                IlKind::FbInput {
                    input: Ident::new(text.clone(), op_span),
                    instance,
                }
            }
            Word::Function => {
                let name = Ident::new(self.text_of(op_span), op_span);
                if self.on_line(line) && self.at(&Tok::LParen) {
                    let (args, _) = self.args()?;
                    let formal = args.iter().any(|a| a.name.is_some());
                    IlKind::Function { name, args, formal }
                } else {
                    let mut args = Vec::new();
                    while self.on_line(line) {
                        let v = self.il_operand(&text)?;
                        args.push(Arg {
                            name: None,
                            output: false,
                            negated: false,
                            span: v.span,
                            value: Some(v),
                        });
                        if self.on_line(line) && self.eat(&Tok::Comma).is_none() {
                            break;
                        }
                    }
                    IlKind::Function {
                        name,
                        args,
                        formal: false,
                    }
                }
            }
        };
        let span = op_span.to(self.prev_span());
        out.push(IlInstr { kind, span });
        self.il_eol(line, out)
    }

    /// An operand: a constant or a variable (with fields, elements and bits).
    fn il_operand(&mut self, op: &str) -> PResult<Expr> {
        match self.peek().tok {
            Tok::Kw(k) if !matches!(k, Kw::True | Kw::False | Kw::Not) => {
                let t = self.peek().clone();
                self.error_at(
                    diag::IL_SYNTAX,
                    t.span,
                    format!(
                        "{} cannot be an operand of {op}; one instruction per line",
                        self.describe(&t)
                    ),
                );
                Err(Reported)
            }
            _ => self.unary(),
        }
    }

    /// The end of an instruction's line (a `)` may close a deferred operation there too).
    fn il_eol(&mut self, line: u32, out: &mut Vec<IlInstr>) -> PResult<()> {
        while self.on_line(line) && self.at(&Tok::RParen) {
            let t = self.bump();
            out.push(IlInstr {
                kind: IlKind::Close,
                span: t.span,
            });
        }
        if self.on_line(line) && !self.is_stmt_list_end(&[]) {
            let t = self.peek().clone();
            if !self.quiet_at(&t) {
                let msg = format!(
                    "{} after the instruction; IL has one instruction per line",
                    self.describe(&t)
                );
                self.error_at(diag::IL_SYNTAX, t.span, msg);
            }
            return Err(Reported);
        }
        Ok(())
    }
}
