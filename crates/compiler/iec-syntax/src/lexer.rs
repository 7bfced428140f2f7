//! The Structured Text lexer: case-insensitive keywords, identifiers, numbers in any base,
//! typed-literal prefixes (`INT#`), duration and date literals (`T#1m30s`,
//! `DT#2024-01-02-12:00:00`), strings with `$` escapes, direct variables (`%IX0.1`, and
//! MatPLC's `%point`), nested `(* *)` and `/* */` comments, `//` lines and `{pragmas}`.
//!
//! Every problem becomes a diagnostic and lexing goes on, so one run reports them all.

use crate::diag::{self, Diagnostics};
use crate::source::{FileId, Span};

mod namespace;
mod pragma;
#[cfg(test)]
mod tests;
mod time;

pub use namespace::is_library_namespace;
pub use time::{
    civil_from_days, days_from_civil, parse_date, parse_dt, parse_duration, parse_tod,
    NANOS_PER_DAY,
};

/// Reserved words (compared case-insensitively). Type names such as `INT` are identifiers:
/// the checker resolves them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kw {
    And,
    Or,
    Xor,
    Not,
    Mod,
    If,
    Then,
    Elsif,
    Else,
    EndIf,
    Case,
    Of,
    EndCase,
    For,
    To,
    By,
    Do,
    EndFor,
    While,
    EndWhile,
    Repeat,
    Until,
    EndRepeat,
    Exit,
    Continue,
    Return,
    Program,
    EndProgram,
    Function,
    EndFunction,
    FunctionBlock,
    EndFunctionBlock,
    Var,
    VarInput,
    VarOutput,
    VarInOut,
    VarTemp,
    VarExternal,
    VarGlobal,
    VarAccess,
    VarConfig,
    EndVar,
    Constant,
    Retain,
    NonRetain,
    At,
    Type,
    EndType,
    Struct,
    EndStruct,
    Array,
    Configuration,
    EndConfiguration,
    Resource,
    EndResource,
    On,
    Task,
    With,
    True,
    False,
    REdge,
    FEdge,
}

const KEYWORDS: &[(&str, Kw)] = &[
    ("AND", Kw::And),
    ("OR", Kw::Or),
    ("XOR", Kw::Xor),
    ("NOT", Kw::Not),
    ("MOD", Kw::Mod),
    ("IF", Kw::If),
    ("THEN", Kw::Then),
    ("ELSIF", Kw::Elsif),
    ("ELSE", Kw::Else),
    ("END_IF", Kw::EndIf),
    ("CASE", Kw::Case),
    ("OF", Kw::Of),
    ("END_CASE", Kw::EndCase),
    ("FOR", Kw::For),
    ("TO", Kw::To),
    ("BY", Kw::By),
    ("DO", Kw::Do),
    ("END_FOR", Kw::EndFor),
    ("WHILE", Kw::While),
    ("END_WHILE", Kw::EndWhile),
    ("REPEAT", Kw::Repeat),
    ("UNTIL", Kw::Until),
    ("END_REPEAT", Kw::EndRepeat),
    ("EXIT", Kw::Exit),
    ("CONTINUE", Kw::Continue),
    ("RETURN", Kw::Return),
    ("PROGRAM", Kw::Program),
    ("END_PROGRAM", Kw::EndProgram),
    ("FUNCTION", Kw::Function),
    ("END_FUNCTION", Kw::EndFunction),
    ("FUNCTION_BLOCK", Kw::FunctionBlock),
    ("END_FUNCTION_BLOCK", Kw::EndFunctionBlock),
    ("VAR", Kw::Var),
    ("VAR_INPUT", Kw::VarInput),
    ("VAR_OUTPUT", Kw::VarOutput),
    ("VAR_IN_OUT", Kw::VarInOut),
    ("VAR_TEMP", Kw::VarTemp),
    ("VAR_EXTERNAL", Kw::VarExternal),
    ("VAR_GLOBAL", Kw::VarGlobal),
    ("VAR_ACCESS", Kw::VarAccess),
    ("VAR_CONFIG", Kw::VarConfig),
    ("END_VAR", Kw::EndVar),
    ("CONSTANT", Kw::Constant),
    ("RETAIN", Kw::Retain),
    ("NON_RETAIN", Kw::NonRetain),
    ("AT", Kw::At),
    ("TYPE", Kw::Type),
    ("END_TYPE", Kw::EndType),
    ("STRUCT", Kw::Struct),
    ("END_STRUCT", Kw::EndStruct),
    ("ARRAY", Kw::Array),
    ("CONFIGURATION", Kw::Configuration),
    ("END_CONFIGURATION", Kw::EndConfiguration),
    ("RESOURCE", Kw::Resource),
    ("END_RESOURCE", Kw::EndResource),
    ("ON", Kw::On),
    ("TASK", Kw::Task),
    ("WITH", Kw::With),
    ("TRUE", Kw::True),
    ("FALSE", Kw::False),
    ("R_EDGE", Kw::REdge),
    ("F_EDGE", Kw::FEdge),
];

impl Kw {
    /// The keyword a word spells, if any.
    pub fn of(word: &str) -> Option<Kw> {
        KEYWORDS
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(word))
            .map(|&(_, kw)| kw)
    }

    /// The keyword as the standard spells it.
    pub fn text(self) -> &'static str {
        KEYWORDS
            .iter()
            .find(|&&(_, k)| k == self)
            .map_or("?", |&(s, _)| s)
    }
}

/// Whether a word is reserved (a keyword).
pub fn is_keyword(word: &str) -> bool {
    Kw::of(word).is_some()
}

/// What a duration, date or time literal denotes, in nanoseconds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeKind {
    /// `T#`/`TIME#`.
    Time,
    /// `LT#`/`LTIME#`.
    LTime,
    /// `D#`/`DATE#` (and `LD#`/`LDATE#`): nanoseconds since 1970-01-01.
    Date,
    /// `TOD#`/`TIME_OF_DAY#` (and `LTOD#`): nanoseconds since midnight.
    Tod,
    /// `DT#`/`DATE_AND_TIME#` (and `LDT#`): nanoseconds since 1970-01-01T00:00.
    Dt,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Tok {
    Ident,
    Kw(Kw),
    /// An unsigned integer literal in any base.
    Int(u128),
    Real(f64),
    /// A string literal's bytes (`wide`: double-quoted WSTRING).
    Str {
        bytes: Vec<u8>,
        wide: bool,
    },
    /// `NAME#` before a literal (`INT#5`, `Color#Red`); the span covers `NAME#`.
    TypedPrefix,
    Time {
        kind: TimeKind,
        nanos: i128,
    },
    /// `%…` after the percent sign.
    Direct(String),
    LParen,
    RParen,
    LBracket,
    RBracket,
    Comma,
    Semi,
    Colon,
    Assign,
    Arrow,
    Dot,
    DotDot,
    Plus,
    Minus,
    Star,
    Slash,
    Power,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    Amp,
    Caret,
    /// A character that starts no token (already reported): the parser stays quiet on it.
    Error,
    Eof,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Token {
    pub tok: Tok,
    pub span: Span,
}

/// Splits a source text into tokens; problems go to `diags`. A STRING literal holds one
/// Latin-1 byte per character, whether the text came from a UTF-8 file or from a single-byte
/// one decoded byte for byte (CODESYS and TwinCAT save .st sources in the Windows code page);
/// a WSTRING literal holds its characters in UTF-8.
pub fn lex(file: FileId, text: &str, diags: &mut Diagnostics) -> Vec<Token> {
    let mut lx = Lexer {
        file,
        src: text.as_bytes(),
        text,
        pos: 0,
        out: Vec::new(),
        pragmas: Vec::new(),
        diags,
    };
    lx.run();
    pragma::report(file, text, &lx.pragmas, lx.diags);
    namespace::unqualify(text, lx.out)
}

struct Lexer<'a, 'd> {
    file: FileId,
    src: &'a [u8],
    text: &'a str,
    pos: usize,
    out: Vec<Token>,
    /// Where each `{…}` pragma is: they are skipped, then reported together.
    pragmas: Vec<(usize, usize)>,
    diags: &'d mut Diagnostics,
}

/// The byte of `c` in STRING's code page, Windows-1252 (what CODESYS and TwinCAT store): the
/// Latin-1 characters U+0000–U+00FF are their own byte, and 27 others (`€` is 16#80) take
/// the places 16#80–16#9F, whose control characters a file read byte for byte also gives.
pub fn single_byte(c: char) -> Option<u8> {
    CP1252_HIGH
        .iter()
        .find(|(h, _)| *h == c)
        .map(|&(_, b)| b)
        .or_else(|| u8::try_from(u32::from(c)).ok())
}

/// The character a STRING byte stands for in Windows-1252 (STRING_TO_WSTRING): 16#80–16#9F
/// are `€` `‚` … where the code page has a character, their control character elsewhere.
pub fn cp1252_char(b: u8) -> char {
    CP1252_HIGH
        .iter()
        .find(|(_, x)| *x == b)
        .map_or(char::from(b), |&(c, _)| c)
}

const CP1252_HIGH: [(char, u8); 27] = [
    ('\u{20ac}', 0x80),
    ('\u{201a}', 0x82),
    ('\u{0192}', 0x83),
    ('\u{201e}', 0x84),
    ('\u{2026}', 0x85),
    ('\u{2020}', 0x86),
    ('\u{2021}', 0x87),
    ('\u{02c6}', 0x88),
    ('\u{2030}', 0x89),
    ('\u{0160}', 0x8a),
    ('\u{2039}', 0x8b),
    ('\u{0152}', 0x8c),
    ('\u{017d}', 0x8e),
    ('\u{2018}', 0x91),
    ('\u{2019}', 0x92),
    ('\u{201c}', 0x93),
    ('\u{201d}', 0x94),
    ('\u{2022}', 0x95),
    ('\u{2013}', 0x96),
    ('\u{2014}', 0x97),
    ('\u{02dc}', 0x98),
    ('\u{2122}', 0x99),
    ('\u{0161}', 0x9a),
    ('\u{203a}', 0x9b),
    ('\u{0153}', 0x9c),
    ('\u{017e}', 0x9e),
    ('\u{0178}', 0x9f),
];

fn is_ident_start(b: u8) -> bool {
    b.is_ascii_alphabetic() || b == b'_'
}

fn is_ident_char(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_'
}

impl Lexer<'_, '_> {
    fn peek(&self, k: usize) -> u8 {
        self.src.get(self.pos + k).copied().unwrap_or(0)
    }

    fn span(&self, start: usize) -> Span {
        Span::new(self.file, start, self.pos)
    }

    fn push(&mut self, tok: Tok, start: usize) {
        let span = self.span(start);
        self.out.push(Token { tok, span });
    }

    fn error(&mut self, code: diag::Code, start: usize, end: usize, msg: impl Into<String>) {
        self.diags
            .error(code, Span::new(self.file, start, end), msg);
    }

    fn run(&mut self) {
        // Editors on Windows may start a file with a byte order mark; it is not text.
        if self.text.starts_with('\u{feff}') {
            self.pos = '\u{feff}'.len_utf8();
        }
        while self.pos < self.src.len() {
            let start = self.pos;
            let b = self.src[self.pos];
            match b {
                b' ' | b'\t' | b'\r' | b'\n' | 0x0c | 0x0b => self.pos += 1,
                b'(' if self.peek(1) == b'*' => self.block_comment(b'(', b')'),
                b'/' if self.peek(1) == b'*' => self.block_comment(b'/', b'/'),
                b'/' if self.peek(1) == b'/' => {
                    while self.pos < self.src.len() && self.src[self.pos] != b'\n' {
                        self.pos += 1;
                    }
                }
                b'{' => self.pragma(),
                b'\'' | b'"' => self.string(b),
                b'%' => self.direct(),
                b'0'..=b'9' => self.number(),
                _ if is_ident_start(b) => self.word(),
                _ => self.punct(),
            }
            debug_assert!(self.pos > start || self.pos >= self.src.len());
        }
        let end = self.src.len();
        self.out.push(Token {
            tok: Tok::Eof,
            span: Span::new(self.file, end, end),
        });
    }

    /// `(* … *)` or `/* … */`, nested.
    fn block_comment(&mut self, open: u8, close: u8) {
        let start = self.pos;
        self.pos += 2;
        let mut depth = 1;
        while self.pos < self.src.len() {
            let (a, b) = (self.src[self.pos], self.peek(1));
            if a == open && b == b'*' {
                depth += 1;
                self.pos += 2;
            } else if a == b'*' && b == close {
                depth -= 1;
                self.pos += 2;
                if depth == 0 {
                    return;
                }
            } else {
                self.pos += 1;
            }
        }
        let end = if open == b'(' { "*)" } else { "*/" };
        // Read nested, the comment has no end; read as the standard and matiec (so OpenPLC
        // and Beremiz) read comments, it ends at the first close: an opening inside it is
        // text (OSCAT as OpenPLC builds it has `(*From OSCAT Library *` before the next
        // comment's end). Taken so, with a warning: what it swallows is not code.
        let close_at = self.src[start + 2..]
            .windows(2)
            .position(|w| w[0] == b'*' && w[1] == close);
        if let Some(k) = close_at {
            self.pos = start + 2 + k + 2;
            let line = 1 + self.src[..self.pos].iter().filter(|&&c| c == b'\n').count();
            self.diags.warning(
                diag::COMMENT_NOT_NESTED,
                Span::new(self.file, start, start + 2),
                format!("this comment holds an opening `{}` that is never closed; it is read as ending at the first `{end}` (line {line}), as the standard and matiec read comments: close each inner comment, or the code up to there is part of the comment", if open == b'(' { "(*" } else { "/*" }),
            );
            return;
        }
        self.error(
            diag::UNTERMINATED_COMMENT,
            start,
            start + 2,
            format!("this comment has no end; close it with `{end}`"),
        );
    }

    /// `{…}`, nested (Beremiz's `{{ C code }}` holds braces of its own).
    fn pragma(&mut self) {
        let start = self.pos;
        let mut depth = 0usize;
        while self.pos < self.src.len() {
            match self.src[self.pos] {
                b'{' => depth += 1,
                b'}' => {
                    depth -= 1;
                    if depth == 0 {
                        break;
                    }
                }
                _ => {}
            }
            self.pos += 1;
        }
        if self.pos < self.src.len() {
            self.pos += 1;
            self.pragmas.push((start, self.pos));
        } else {
            self.error(
                diag::UNTERMINATED_COMMENT,
                start,
                start + 1,
                "this pragma has no end; close it with `}`",
            );
        }
    }

    fn string(&mut self, quote: u8) {
        let start = self.pos;
        self.pos += 1;
        let wide = quote == b'"';
        let mut bytes = Vec::new();
        loop {
            if self.pos >= self.src.len() {
                let q = quote as char;
                self.error(
                    diag::UNTERMINATED_STRING,
                    start,
                    start + 1,
                    format!("this string has no closing {q}; end it with {q} (write $$ for a dollar sign and ${q} for the quote)"),
                );
                break;
            }
            let b = self.src[self.pos];
            if b == quote {
                self.pos += 1;
                break;
            }
            if b == b'\n' {
                // A string does not go past its line (a line break is written $N): the
                // rest of the file is read as code, not swallowed.
                let q = quote as char;
                self.error(
                    diag::UNTERMINATED_STRING,
                    start,
                    start + 1,
                    format!("this string has no closing {q} on its line; end it with {q} (write $N for a line break, $$ for a dollar sign, ${q} for the quote)"),
                );
                break;
            }
            if b == b'$' {
                let esc = self.peek(1);
                let simple = match esc.to_ascii_uppercase() {
                    b'$' => Some(b'$'),
                    b'\'' => Some(b'\''),
                    b'"' => Some(b'"'),
                    b'L' | b'N' => Some(b'\n'),
                    b'P' => Some(0x0c),
                    b'R' => Some(b'\r'),
                    b'T' => Some(b'\t'),
                    _ => None,
                };
                if let Some(v) = simple {
                    bytes.push(v);
                    self.pos += 2;
                    continue;
                }
                let digits = if wide { 4 } else { 2 };
                let hex = self.src.get(self.pos + 1..self.pos + 1 + digits);
                if let Some(h) = hex.filter(|h| h.iter().all(u8::is_ascii_hexdigit)) {
                    let v =
                        u32::from_str_radix(std::str::from_utf8(h).unwrap_or("0"), 16).unwrap_or(0);
                    if wide {
                        let mut buf = [0u8; 4];
                        let c = char::from_u32(v).unwrap_or('\u{fffd}');
                        bytes.extend_from_slice(c.encode_utf8(&mut buf).as_bytes());
                    } else {
                        bytes.push(v as u8);
                    }
                    self.pos += 1 + digits;
                    continue;
                }
                let end = (self.pos + 2).min(self.src.len());
                self.error(
                    diag::BAD_ESCAPE,
                    self.pos,
                    end,
                    format!("unknown escape in a string; write $$ for a dollar sign, ${} for the quote, $L $N $P $R $T, or ${} hex digits", quote as char, digits),
                );
                self.pos += 1;
                continue;
            }
            if !wide && b >= 0x80 {
                // STRING is single-byte (Windows-1252, as CODESYS's and TwinCAT's): a
                // character is one byte whatever the file's encoding (a TwinCAT XML file is
                // UTF-8, a .st file may be in the code page), so a length counts characters.
                let c = self.text[self.pos..].chars().next().unwrap_or('\u{fffd}');
                let n = c.len_utf8();
                match single_byte(c) {
                    Some(v) => bytes.push(v),
                    None if c == '\u{fffd}' => {
                        self.diags.warning(
                            diag::REPLACEMENT_CHAR,
                            Span::new(self.file, self.pos, self.pos + n),
                            "U+FFFD, the replacement character a conversion to UTF-8 leaves for a byte it could not read, is not a character of STRING: stored as '?'; write the character meant, or its byte as $XX",
                        );
                        bytes.push(b'?');
                    }
                    None => {
                        self.error(
                            diag::NOT_LATIN1,
                            self.pos,
                            self.pos + n,
                            format!("`{c}` (U+{:04X}) is not a character of STRING, which holds one byte per character (Windows-1252: Latin-1 and `€` `‚` `„` `…` `™` …); write the literal in double quotes, as a WSTRING (\"…\"), or write its bytes as $XX escapes", u32::from(c)),
                        );
                        bytes.push(b'?');
                    }
                }
                self.pos += n;
                continue;
            }
            bytes.push(b);
            self.pos += 1;
        }
        self.push(Tok::Str { bytes, wide }, start);
    }

    fn direct(&mut self) {
        let start = self.pos;
        self.pos += 1;
        while self.pos < self.src.len()
            && (is_ident_char(self.src[self.pos])
                || (self.src[self.pos] == b'.' && is_ident_char(self.peek(1)))
                || self.src[self.pos] == b'*')
        {
            self.pos += 1;
        }
        if self.pos == start + 1 {
            self.error(
                diag::BAD_CHAR,
                start,
                start + 1,
                "`%` must start a direct variable such as %IX0.1, %QW2 or %point",
            );
            return;
        }
        let text = self.text[start + 1..self.pos].to_string();
        self.push(Tok::Direct(text), start);
    }

    /// Digits with single `_` separators; returns the digits without them.
    fn digits(&mut self, radix: u32) -> String {
        let mut s = String::new();
        while self.pos < self.src.len() {
            let b = self.src[self.pos];
            if (b as char).is_digit(radix) || (b == b'_' && !s.is_empty()) {
                if b != b'_' {
                    s.push(b as char);
                }
                self.pos += 1;
            } else if radix == 10 && b.is_ascii_alphanumeric() {
                // 12ab: take the rest so the message shows the whole word.
                s.push(b as char);
                self.pos += 1;
            } else if radix != 10 && b.is_ascii_alphanumeric() {
                s.push(b as char);
                self.pos += 1;
            } else {
                break;
            }
        }
        s
    }

    fn number(&mut self) {
        let start = self.pos;
        let mut int = String::new();
        while self.pos < self.src.len()
            && (self.src[self.pos].is_ascii_digit() || self.src[self.pos] == b'_')
        {
            if self.src[self.pos] != b'_' {
                int.push(self.src[self.pos] as char);
            }
            self.pos += 1;
        }
        // Based integer: 2#, 8#, 16#.
        if self.peek(0) == b'#' {
            self.pos += 1;
            let radix = match int.parse::<u32>() {
                Ok(r @ (2 | 8 | 16)) => r,
                _ => {
                    let body = self.digits(16);
                    self.error(
                        diag::BAD_NUMBER,
                        start,
                        self.pos,
                        format!(
                            "`{int}#{body}`: the base of a number must be 2, 8 or 16 (e.g. 16#FF)"
                        ),
                    );
                    self.push(Tok::Int(0), start);
                    return;
                }
            };
            let body = self.digits(radix);
            let value = if body.is_empty() || !body.chars().all(|c| c.is_digit(radix)) {
                self.error(
                    diag::BAD_NUMBER,
                    start,
                    self.pos,
                    format!(
                        "`{}` is not a base-{radix} number; digits are {}",
                        &self.text[start..self.pos],
                        match radix {
                            2 => "0 and 1",
                            8 => "0 to 7",
                            _ => "0 to 9 and A to F",
                        }
                    ),
                );
                0
            } else {
                match u128::from_str_radix(&body, radix) {
                    Ok(v) if v <= u64::MAX as u128 => v,
                    _ => {
                        self.error(
                            diag::BAD_NUMBER,
                            start,
                            self.pos,
                            "this number does not fit 64 bits (the largest type, LWORD/ULINT)",
                        );
                        0
                    }
                }
            };
            self.push(Tok::Int(value), start);
            return;
        }
        // Real: digits . digits [E [+-] digits], or digits E digits.
        let dot = self.peek(0) == b'.' && self.peek(1).is_ascii_digit();
        let exp_follows = |lx: &Self, at: usize| {
            let e = lx.peek(at);
            (e == b'e' || e == b'E')
                && (lx.peek(at + 1).is_ascii_digit()
                    || (matches!(lx.peek(at + 1), b'+' | b'-') && lx.peek(at + 2).is_ascii_digit()))
        };
        if dot || exp_follows(self, 0) {
            let mut text = int.clone();
            if dot {
                self.pos += 1;
                text.push('.');
                while self.pos < self.src.len()
                    && (self.src[self.pos].is_ascii_digit() || self.src[self.pos] == b'_')
                {
                    if self.src[self.pos] != b'_' {
                        text.push(self.src[self.pos] as char);
                    }
                    self.pos += 1;
                }
            }
            if exp_follows(self, 0) {
                text.push('e');
                self.pos += 1;
                if matches!(self.peek(0), b'+' | b'-') {
                    text.push(self.src[self.pos] as char);
                    self.pos += 1;
                }
                while self.pos < self.src.len() && self.src[self.pos].is_ascii_digit() {
                    text.push(self.src[self.pos] as char);
                    self.pos += 1;
                }
            }
            let value = text.parse::<f64>().unwrap_or(0.0);
            if !value.is_finite() {
                self.error(
                    diag::BAD_NUMBER,
                    start,
                    self.pos,
                    "this number is too large for LREAL",
                );
            }
            self.trailing_letters(start);
            self.push(Tok::Real(value), start);
            return;
        }
        let value = match int.parse::<u128>() {
            Ok(v) if v <= u64::MAX as u128 => v,
            _ => {
                self.error(
                    diag::BAD_NUMBER,
                    start,
                    self.pos,
                    "this number does not fit 64 bits (the largest type, ULINT)",
                );
                0
            }
        };
        self.trailing_letters(start);
        self.push(Tok::Int(value), start);
    }

    /// `12ab`: a number glued to letters.
    fn trailing_letters(&mut self, start: usize) {
        if is_ident_start(self.peek(0)) {
            while is_ident_char(self.peek(0)) {
                self.pos += 1;
            }
            self.error(
                diag::BAD_NUMBER,
                start,
                self.pos,
                format!(
                    "`{}` is not a number; identifiers start with a letter or `_`, and a typed literal is written TYPE#value (e.g. INT#5, T#5s)",
                    &self.text[start..self.pos]
                ),
            );
        }
    }

    fn word(&mut self) {
        let start = self.pos;
        while self.pos < self.src.len() && is_ident_char(self.src[self.pos]) {
            self.pos += 1;
        }
        let word = &self.text[start..self.pos];
        if self.peek(0) == b'#' {
            let kind = time_prefix(word);
            self.pos += 1;
            if let Some(kind) = kind {
                self.time_literal(start, kind);
            } else {
                self.push(Tok::TypedPrefix, start);
            }
            return;
        }
        let tok = match Kw::of(word) {
            Some(kw) => Tok::Kw(kw),
            None => Tok::Ident,
        };
        self.push(tok, start);
    }

    fn time_literal(&mut self, start: usize, kind: TimeKind) {
        let body_start = self.pos;
        match kind {
            TimeKind::Time | TimeKind::LTime => {
                if matches!(self.peek(0), b'+' | b'-') {
                    self.pos += 1;
                }
                while is_ident_char(self.peek(0))
                    || (self.peek(0) == b'.' && self.peek(1).is_ascii_digit())
                {
                    self.pos += 1;
                }
            }
            _ => {
                while self.peek(0).is_ascii_digit()
                    || matches!(self.peek(0), b'-' | b':' | b'_')
                    || (self.peek(0) == b'.' && self.peek(1).is_ascii_digit())
                {
                    self.pos += 1;
                }
            }
        }
        let body = &self.text[body_start..self.pos];
        let parsed = match kind {
            TimeKind::Time | TimeKind::LTime => parse_duration(body),
            TimeKind::Date => parse_date(body).map(|d| d as i128 * NANOS_PER_DAY),
            TimeKind::Tod => parse_tod(body),
            TimeKind::Dt => parse_dt(body),
        };
        let nanos = match parsed {
            Ok(n) if (i64::MIN as i128..=i64::MAX as i128).contains(&n) => n,
            Ok(_) => {
                self.error(
                    diag::BAD_TIME,
                    start,
                    self.pos,
                    "this time does not fit 64 bits of nanoseconds (about ±292 years)",
                );
                0
            }
            Err(why) => {
                self.error(
                    diag::BAD_TIME,
                    start,
                    self.pos,
                    format!("`{}`: {why}", &self.text[start..self.pos]),
                );
                0
            }
        };
        self.push(Tok::Time { kind, nanos }, start);
    }

    fn punct(&mut self) {
        let start = self.pos;
        let (tok, len) = match (self.src[self.pos], self.peek(1)) {
            (b':', b'=') => (Tok::Assign, 2),
            (b'=', b'>') => (Tok::Arrow, 2),
            (b'.', b'.') => (Tok::DotDot, 2),
            (b'*', b'*') => (Tok::Power, 2),
            (b'<', b'=') => (Tok::Le, 2),
            (b'>', b'=') => (Tok::Ge, 2),
            (b'<', b'>') => (Tok::Ne, 2),
            (b'(', _) => (Tok::LParen, 1),
            (b')', _) => (Tok::RParen, 1),
            (b'[', _) => (Tok::LBracket, 1),
            (b']', _) => (Tok::RBracket, 1),
            (b',', _) => (Tok::Comma, 1),
            (b';', _) => (Tok::Semi, 1),
            (b':', _) => (Tok::Colon, 1),
            (b'.', _) => (Tok::Dot, 1),
            (b'+', _) => (Tok::Plus, 1),
            (b'-', _) => (Tok::Minus, 1),
            (b'*', _) => (Tok::Star, 1),
            (b'/', _) => (Tok::Slash, 1),
            (b'=', _) => (Tok::Eq, 1),
            (b'<', _) => (Tok::Lt, 1),
            (b'>', _) => (Tok::Gt, 1),
            (b'&', _) => (Tok::Amp, 1),
            (b'^', _) => (Tok::Caret, 1),
            _ => {
                let ch = self.text[self.pos..].chars().next().unwrap_or('?');
                self.pos += ch.len_utf8().max(1);
                self.error(
                    diag::BAD_CHAR,
                    start,
                    self.pos,
                    format!("unexpected character `{ch}`"),
                );
                self.push(Tok::Error, start);
                return;
            }
        };
        self.pos += len;
        self.push(tok, start);
    }
}

fn time_prefix(word: &str) -> Option<TimeKind> {
    let w = word.to_ascii_uppercase();
    Some(match w.as_str() {
        "T" | "TIME" => TimeKind::Time,
        "LT" | "LTIME" => TimeKind::LTime,
        "D" | "DATE" | "LD" | "LDATE" => TimeKind::Date,
        "TOD" | "TIME_OF_DAY" | "LTOD" | "LTIME_OF_DAY" => TimeKind::Tod,
        "DT" | "DATE_AND_TIME" | "LDT" | "LDATE_AND_TIME" => TimeKind::Dt,
        _ => return None,
    })
}
