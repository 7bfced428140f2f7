//! Layer 1: text to sections. Lines become `[section]` headers, `name = value` settings,
//! table rows and `*include` directives; included files are read in place.
//!
//! The rules (MatPLC's, with the choices it leaves open made explicit):
//! - `#` starts a comment at the start of a word, outside quotes; inside a word it is a
//!   character, so IEC literals such as `T#10ms` need no quotes.
//! - `"…"` keeps spaces and `#`; `\"` and `\\` inside quotes are a quote and a backslash.
//! - A line is a setting when its first word is followed by `=` (`confmap_key=20` too);
//!   otherwise it is a table row whose first word is the table name.
//! - `Section: …` puts that one line into `Section`, wherever it is written.
//! - Section names are case-sensitive; repeated sections are merged in file order.
//! - A section does not continue into an included file nor out of it (as in MatPLC): each
//!   file starts outside any section, and a setting or row there without a `Section:`
//!   prefix is an error rather than silently landing in `[PLC]`.
//! - `*include FILE` is relative to the including file's directory. A file already read is
//!   not read again (MatPLC's rule), but a file that includes itself, directly or through
//!   others, is an error naming the chain. Only regular files are read, and includes nest
//!   at most [`MAX_INCLUDE_DEPTH`] files deep (each level is a level of recursion here).
//! - A setting given twice in one section must have the same value both times.
//! - Files that are not UTF-8 are read as Latin-1 (MatPLC's demos have `º` in comments).

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};

use crate::error::{self, ConfigError, Diagnostic};
use crate::model::{Origin, Row, Section, Setting};

/// A configuration as read, before any meaning is given to its tables.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct RawConfig {
    /// The file it was read from.
    pub file: String,
    pub sections: BTreeMap<String, Section>,
}

/// Files a chain of `*include`s may go through (the first file counts).
pub const MAX_INCLUDE_DEPTH: usize = 64;

/// Reads `path` and the files it includes into sections.
pub fn read_raw(path: &Path) -> Result<RawConfig, ConfigError> {
    let name = path.display().to_string();
    let origin = Origin {
        file: name.clone(),
        line: 0,
    };
    let text = read_text(path).map_err(|why| ConfigError {
        diagnostics: vec![error::diagnostic(
            &origin,
            error::UNREADABLE,
            format!("cannot read the configuration: {why}"),
        )],
    })?;
    let id = std::fs::canonicalize(path).ok();
    let dir = path.parent().unwrap_or(Path::new(""));
    Reader::run(&text, &name, dir, id)
}

/// Reads `text` as the file `file` (the name used in messages); `*include`s are resolved
/// relative to `include_dir`.
pub fn parse_raw_str(text: &str, file: &str, include_dir: &Path) -> Result<RawConfig, ConfigError> {
    // When the text is a file in `include_dir`, knowing so lets a file that includes itself
    // be caught at once rather than one round later.
    let id = std::fs::canonicalize(include_dir.join(file)).ok();
    Reader::run(text, file, include_dir, id)
}

/// The largest file read: [`petriplc_files::CONFIG`].
pub const MAX_FILE_BYTES: u64 = petriplc_files::CONFIG.bytes;

/// The bytes of a regular file as text; devices and directories are refused so an include
/// of `/dev/zero` cannot hang the reader, and a file is read up to [`MAX_FILE_BYTES`].
fn read_text(path: &Path) -> Result<String, String> {
    let bytes = petriplc_files::read(path, petriplc_files::CONFIG).map_err(|e| e.reason())?;
    // MatPLC's files are Latin-1 at times: bytes that are not UTF-8 are read as Latin-1.
    Ok(match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => e.into_bytes().iter().map(|&b| char::from(b)).collect(),
    })
}

/// A file being read, and the line of the `*include` it is in the middle of.
struct Frame {
    id: Option<PathBuf>,
    name: String,
    line: usize,
}

struct Reader {
    sections: BTreeMap<String, Section>,
    diags: Vec<Diagnostic>,
    stack: Vec<Frame>,
    read: HashSet<PathBuf>,
    /// (section, name) → first value and where it was set, for conflicting repeats.
    first_set: HashMap<(String, String), Setting>,
}

impl Reader {
    fn run(
        text: &str,
        file: &str,
        dir: &Path,
        id: Option<PathBuf>,
    ) -> Result<RawConfig, ConfigError> {
        let mut r = Reader {
            sections: BTreeMap::new(),
            diags: Vec::new(),
            stack: Vec::new(),
            read: HashSet::new(),
            first_set: HashMap::new(),
        };
        r.file(text, file, dir, id);
        if r.diags.is_empty() {
            Ok(RawConfig {
                file: file.to_string(),
                sections: r.sections,
            })
        } else {
            Err(ConfigError {
                diagnostics: r.diags,
            })
        }
    }

    fn file(&mut self, text: &str, name: &str, dir: &Path, id: Option<PathBuf>) {
        // Editors on Windows may start a file with a byte-order mark; it is not text.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        if let Some(id) = &id {
            self.read.insert(id.clone());
        }
        self.stack.push(Frame {
            id,
            name: name.to_string(),
            line: 0,
        });
        let mut section: Option<String> = None;
        for (i, line) in text.lines().enumerate() {
            let origin = Origin {
                file: name.to_string(),
                line: i + 1,
            };
            match parse_line(line) {
                Ok(Line::Blank) => {}
                Ok(Line::Header(s)) => section = Some(s),
                Ok(Line::Include(f)) => {
                    if let Some(top) = self.stack.last_mut() {
                        top.line = i + 1;
                    }
                    self.include(&f, &origin, dir);
                }
                Ok(Line::Entry(prefix, entry)) => {
                    let Some(target) = prefix.or_else(|| section.clone()) else {
                        self.diags.push(error::diagnostic(
                            &origin,
                            error::OUTSIDE_SECTION,
                            "this line is outside any section (sections do not carry over \
                             from an including file): put a `[PLC]` or `[module]` header \
                             above it, or prefix the line with `Section: `",
                        ));
                        continue;
                    };
                    self.add(target, entry, origin);
                }
                Err((code, message)) => {
                    self.diags.push(error::diagnostic(&origin, code, message));
                }
            }
        }
        self.stack.pop();
    }

    fn include(&mut self, file: &str, origin: &Origin, dir: &Path) {
        let path = dir.join(file);
        let shown = path.display().to_string();
        let id = match std::fs::canonicalize(&path) {
            Ok(id) => id,
            Err(e) => {
                let why = match e.kind() {
                    std::io::ErrorKind::NotFound => "no such file".to_string(),
                    _ => e.to_string(),
                };
                self.diags.push(error::diagnostic(
                    origin,
                    error::UNREADABLE,
                    format!(
                        "cannot read included file `{shown}`: {why}; check the name (it is \
                         relative to the directory of `{}`)",
                        origin.file
                    ),
                ));
                return;
            }
        };
        if let Some(k) = self.stack.iter().position(|f| f.id.as_ref() == Some(&id)) {
            let chain = self.chain(k);
            self.diags.push(error::diagnostic(
                origin,
                error::CIRCULAR_INCLUDE,
                format!("circular include: {chain}; remove one of these `*include` lines"),
            ));
            return;
        }
        if self.read.contains(&id) {
            return;
        }
        if self.stack.len() >= MAX_INCLUDE_DEPTH {
            let first = &self.stack[0];
            self.diags.push(error::diagnostic(
                origin,
                error::INCLUDE_TOO_DEEP,
                format!(
                    "`*include` nested more than {MAX_INCLUDE_DEPTH} files deep (from {}:{}); \
                     include the files from one file rather than each from the one before",
                    first.name, first.line
                ),
            ));
            return;
        }
        match read_text(&path) {
            Ok(text) => {
                let sub = path.parent().unwrap_or(Path::new("")).to_path_buf();
                self.file(&text, &shown, &sub, Some(id));
            }
            Err(why) => self.diags.push(error::diagnostic(
                origin,
                error::UNREADABLE,
                format!("cannot read included file `{shown}`: {why}"),
            )),
        }
    }

    /// `a.conf:12 includes b.conf, which includes c.conf (b.conf:3), which includes
    /// a.conf`: the frames from `k` up, and back to `k`.
    fn chain(&self, k: usize) -> String {
        let frames = &self.stack[k..];
        let next = |j: usize| {
            frames
                .get(j + 1)
                .map_or(frames[0].name.as_str(), |f| f.name.as_str())
        };
        let mut s = format!("{}:{} includes {}", frames[0].name, frames[0].line, next(0));
        for j in 1..frames.len() {
            let f = &frames[j];
            if j + 1 == frames.len() {
                s.push_str(&format!(", which includes {}", next(j)));
            } else {
                s.push_str(&format!(
                    ", which includes {} ({}:{})",
                    next(j),
                    f.name,
                    f.line
                ));
            }
        }
        s
    }

    fn add(&mut self, section: String, entry: Entry, origin: Origin) {
        let sec = self
            .sections
            .entry(section.clone())
            .or_insert_with(|| Section {
                name: section.clone(),
                ..Section::default()
            });
        match entry {
            Entry::Pair(name, value) => {
                let setting = Setting { value, origin };
                match self.first_set.get(&(section.clone(), name.clone())) {
                    Some(first) if first.value != setting.value => {
                        self.diags.push(error::diagnostic(
                            &setting.origin,
                            error::CONFLICTING_SETTING,
                            format!(
                                "`{name}` is set to `{}` here but to `{}` at {} in [{section}]: \
                                 keep one of them",
                                setting.value, first.value, first.origin
                            ),
                        ));
                        return;
                    }
                    Some(_) => {}
                    None => {
                        self.first_set
                            .insert((section, name.clone()), setting.clone());
                    }
                }
                sec.pairs.push((name, setting));
            }
            Entry::Row(table, cells) => sec.rows.push(Row {
                table,
                cells,
                origin,
            }),
        }
    }
}

/// What one line says.
#[derive(Debug, PartialEq, Eq)]
enum Line {
    Blank,
    Header(String),
    Include(String),
    /// An optional `Section:` prefix and the setting or row.
    Entry(Option<String>, Entry),
}

type LineError = (&'static str, String);

fn parse_line(line: &str) -> Result<Line, LineError> {
    let body = line.trim_start();
    if body.is_empty() || body.starts_with('#') {
        return Ok(Line::Blank);
    }
    if let Some(rest) = body.strip_prefix('[') {
        return header(rest).map(Line::Header);
    }
    if body.starts_with('*') {
        return directive(body);
    }
    let (prefix, rest) = split_prefix(body);
    if let Some(p) = &prefix {
        let r = rest.trim_start();
        if r.is_empty() || r.starts_with('#') {
            return Err((
                error::BAD_LINE,
                format!("`{p}:` has nothing after it: write `{p}: name = value`"),
            ));
        }
        if r.starts_with('[') || r.starts_with('*') {
            return Err((
                error::BAD_LINE,
                format!(
                    "a `{p}:` prefix can only be followed by `name = value` or a table row, \
                     not a header or directive"
                ),
            ));
        }
    }
    entry(rest).map(|e| Line::Entry(prefix, e))
}

fn header(rest: &str) -> Result<String, LineError> {
    let bad = |why: &str| {
        Err((
            error::BAD_SECTION_HEADER,
            format!("{why}: write a section header as `[name]` on its own line"),
        ))
    };
    let Some(end) = rest.find(']') else {
        return bad("`]` is missing");
    };
    let name = rest[..end].trim();
    let after = rest[end + 1..].trim_start();
    if !(after.is_empty() || after.starts_with('#')) {
        return bad(&format!("`{after}` follows the header"));
    }
    if name.is_empty() {
        return bad("the section name is empty");
    }
    if name
        .chars()
        .any(|c| c.is_whitespace() || "[\"#:=".contains(c))
    {
        return bad(&format!(
            "`{name}` is not a section name (no spaces, quotes, `[`, `#`, `:` or `=`)"
        ));
    }
    Ok(name.to_string())
}

fn directive(body: &str) -> Result<Line, LineError> {
    let words = Lexer::new(body).rest()?;
    let (head, args) = words
        .split_first()
        .expect("a line starting with `*` has a word");
    if head != "*include" {
        return Err((
            error::BAD_DIRECTIVE,
            format!("`{head}` is not a directive: the only one is `*include FILE`"),
        ));
    }
    match args {
        [file] if !file.is_empty() => Ok(Line::Include(file.clone())),
        [] | [_] => Err((
            error::BAD_DIRECTIVE,
            "`*include` needs a file name: `*include FILE`".into(),
        )),
        _ => Err((
            error::BAD_DIRECTIVE,
            "`*include` takes one file name; quote a name with spaces: `*include \"my file.conf\"`"
                .into(),
        )),
    }
}

/// `Name: rest` when the line starts with an unquoted word followed at once by `:`.
fn split_prefix(body: &str) -> (Option<String>, &str) {
    let end = body
        .find(|c: char| c.is_whitespace() || "\"=:#".contains(c))
        .unwrap_or(body.len());
    if end > 0 && body[end..].starts_with(':') {
        (Some(body[..end].to_string()), &body[end + 1..])
    } else {
        (None, body)
    }
}

/// A line's meaning: a setting or a table row.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Entry {
    /// `name = value`
    Pair(String, String),
    /// `table cell cell …`
    Row(String, Vec<String>),
}

/// What follows `SECTION:` in a `--set`, read as a line of a file reads.
pub(crate) fn setting_or_row(body: &str) -> Result<Entry, String> {
    entry(body).map_err(|(_, why)| why)
}

fn entry(body: &str) -> Result<Entry, LineError> {
    let mut lx = Lexer::new(body);
    lx.skip_ws();
    let starts_quoted = lx.peek() == Some('"');
    let first = lx.word(true)?.unwrap_or_default();
    lx.skip_ws();
    if lx.peek() == Some('=') {
        lx.bump();
        if first.is_empty() {
            return Err((
                error::BAD_LINE,
                "this setting has no name: write `name = value`".into(),
            ));
        }
        let value = lx.rest()?.join(" ");
        return Ok(Entry::Pair(first, value));
    }
    let starts_well = first
        .chars()
        .next()
        .is_some_and(|c| c.is_alphanumeric() || c == '_');
    if !starts_quoted && !starts_well {
        return Err((
            error::BAD_LINE,
            format!(
                "`{}` is not a setting, table row, `[section]` or `*include`: a line must \
                 start with a name (quote it if it starts with punctuation)",
                body.trim()
            ),
        ));
    }
    Ok(Entry::Row(first, lx.rest()?))
}

/// Splits a line into words: whitespace separates, quotes group, `#` at a word's start
/// ends the line.
struct Lexer<'a> {
    chars: std::iter::Peekable<std::str::Chars<'a>>,
}

impl<'a> Lexer<'a> {
    fn new(s: &'a str) -> Self {
        Lexer {
            chars: s.chars().peekable(),
        }
    }

    fn peek(&mut self) -> Option<char> {
        self.chars.peek().copied()
    }

    fn bump(&mut self) {
        self.chars.next();
    }

    fn skip_ws(&mut self) {
        while self.peek().is_some_and(char::is_whitespace) {
            self.bump();
        }
    }

    /// The next word; `None` at the end or at a comment. With `stop_at_eq`, an unquoted `=`
    /// ends the word (it is a setting's name).
    fn word(&mut self, stop_at_eq: bool) -> Result<Option<String>, LineError> {
        self.skip_ws();
        match self.peek() {
            None | Some('#') => return Ok(None),
            _ => {}
        }
        let mut out = String::new();
        let mut quoted = false;
        while let Some(c) = self.peek() {
            if !quoted && (c.is_whitespace() || (stop_at_eq && c == '=')) {
                break;
            }
            self.bump();
            match c {
                '"' => quoted = !quoted,
                '\\' if quoted => match self.peek() {
                    Some(n @ ('"' | '\\')) => {
                        self.bump();
                        out.push(n);
                    }
                    _ => out.push('\\'),
                },
                _ => out.push(c),
            }
        }
        if quoted {
            return Err((
                error::UNTERMINATED_QUOTE,
                "a `\"` is not closed: close it on the same line (write `\\\"` for a quote \
                 inside quotes)"
                    .into(),
            ));
        }
        Ok(Some(out))
    }

    fn rest(&mut self) -> Result<Vec<String>, LineError> {
        let mut words = Vec::new();
        while let Some(w) = self.word(false)? {
            words.push(w);
        }
        Ok(words)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reads `input` as `t.conf` and renders the sections (`[S] name=value`, `[S] table|a|b`
    /// with line numbers) or the diagnostics.
    fn check(input: &str, expect: &str) {
        let got = match parse_raw_str(input, "t.conf", Path::new("/nonexistent-dir")) {
            Ok(raw) => render(&raw),
            Err(e) => e.to_string(),
        };
        assert_eq!(got.trim_end(), expect.trim(), "input:\n{input}");
    }

    fn render(raw: &RawConfig) -> String {
        let mut out = String::new();
        for (name, s) in &raw.sections {
            assert_eq!(&s.name, name);
            for (k, v) in &s.pairs {
                out.push_str(&format!("{}: [{name}] {k}={}\n", v.origin.line, v.value));
            }
            for r in &s.rows {
                out.push_str(&format!(
                    "{}: [{name}] {}|{}\n",
                    r.origin.line,
                    r.table,
                    r.cells.join("|")
                ));
            }
        }
        out
    }

    #[test]
    fn pairs_rows_and_comments() {
        check(
            "# top\n[PLC]\nconfmap_key=20\nname = \"a b # c\" # comment\nmodule Chaser \"../x y\" -v\n\
             point L1\t\"light 1\" Chaser at 0.0\n  # indented comment\nempty =\n",
            "3: [PLC] confmap_key=20\n4: [PLC] name=a b # c\n8: [PLC] empty=\n\
             5: [PLC] module|Chaser|../x y|-v\n6: [PLC] point|L1|light 1|Chaser|at|0.0",
        );
    }

    #[test]
    fn hash_inside_a_word_is_not_a_comment() {
        check(
            "[m]\nscan_period = T#10ms\nx = 5 #c\nshow a <* \" <\"\n",
            "2: [m] scan_period=T#10ms\n3: [m] x=5\n4: [m] show|a|<*| <",
        );
    }

    #[test]
    fn prefix_goes_to_its_section_wherever_written() {
        check(
            "Chaser: delay = 0.3\n[PLC]\nvitrine:  scan_beg = T1\nmodule a b\nKbd: key 38 left\n",
            "1: [Chaser] delay=0.3\n5: [Kbd] key|38|left\n4: [PLC] module|a|b\n\
             3: [vitrine] scan_beg=T1",
        );
    }

    #[test]
    fn repeated_sections_merge_in_order() {
        check(
            "[PLC]\nmodule a x\n[b]\nq = 1\n[PLC]\nmodule b y\n[b]\nq = 1\n",
            "2: [PLC] module|a|x\n6: [PLC] module|b|y\n4: [b] q=1\n8: [b] q=1",
        );
    }

    #[test]
    fn quotes_and_escapes() {
        check(
            r#"[s]
t "a\"b" "c\\d" e\f "" x"y z"w
"#,
            r#"2: [s] t|a"b|c\d|e\f||xy zw"#,
        );
    }

    #[test]
    fn layer_one_errors_are_all_reported() {
        check(
            "x = 1\n[PLC\n[]\n[a b]\n[ok] extra\n[s]\nv = \"open\n*inclde f\n*include\n\
             *include a b\nS:\nS: [x]\n= 3\n-> a\nv = 1\nv = 2\n",
            "t.conf:1: error[C005]: this line is outside any section (sections do not carry over from an including file): put a `[PLC]` or `[module]` header above it, or prefix the line with `Section: `
t.conf:2: error[C004]: `]` is missing: write a section header as `[name]` on its own line
t.conf:3: error[C004]: the section name is empty: write a section header as `[name]` on its own line
t.conf:4: error[C004]: `a b` is not a section name (no spaces, quotes, `[`, `#`, `:` or `=`): write a section header as `[name]` on its own line
t.conf:5: error[C004]: `extra` follows the header: write a section header as `[name]` on its own line
t.conf:7: error[C003]: a `\"` is not closed: close it on the same line (write `\\\"` for a quote inside quotes)
t.conf:8: error[C006]: `*inclde` is not a directive: the only one is `*include FILE`
t.conf:9: error[C006]: `*include` needs a file name: `*include FILE`
t.conf:10: error[C006]: `*include` takes one file name; quote a name with spaces: `*include \"my file.conf\"`
t.conf:11: error[C008]: `S:` has nothing after it: write `S: name = value`
t.conf:12: error[C008]: a `S:` prefix can only be followed by `name = value` or a table row, not a header or directive
t.conf:13: error[C008]: this setting has no name: write `name = value`
t.conf:14: error[C008]: `-> a` is not a setting, table row, `[section]` or `*include`: a line must start with a name (quote it if it starts with punctuation)
t.conf:16: error[C007]: `v` is set to `2` here but to `1` at t.conf:15 in [s]: keep one of them",
        );
    }

    #[test]
    fn missing_include_names_file_and_line() {
        check(
            "[PLC]\n\n*include \"other.conf\"\n",
            "t.conf:3: error[C001]: cannot read included file `/nonexistent-dir/other.conf`: \
             no such file; check the name (it is relative to the \
             directory of `t.conf`)",
        );
    }

    #[test]
    fn long_include_chains_are_refused_at_the_limit() {
        let dir = tempfile::tempdir().unwrap();
        let write_chain = |n: usize| {
            for i in 0..n {
                let next = if i + 1 < n {
                    format!("*include f{}.conf\n", i + 1)
                } else {
                    "[PLC]\nplc_id = deep\n".to_string()
                };
                std::fs::write(dir.path().join(format!("f{i}.conf")), next).unwrap();
            }
        };
        write_chain(MAX_INCLUDE_DEPTH);
        let raw = read_raw(&dir.path().join("f0.conf")).unwrap();
        assert_eq!(raw.sections["PLC"].pairs[0].1.value, "deep");
        write_chain(10_000);
        let e = read_raw(&dir.path().join("f0.conf")).unwrap_err();
        assert_eq!(e.codes(), vec![error::INCLUDE_TOO_DEEP]);
        let msg = e.to_string();
        assert!(
            msg.contains(
                "f63.conf:1: error[C009]: `*include` nested more than 64 files deep (from"
            ) && msg.contains("f0.conf:1)"),
            "{msg}"
        );
    }

    #[test]
    fn byte_order_mark_and_crlf() {
        check("\u{feff}[PLC]\r\nmodule a b\r\n", "2: [PLC] module|a|b");
    }

    #[test]
    fn latin1_files_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("l.conf");
        std::fs::write(&path, b"[PLC]\npoint t \"temp \xba\" m\n").unwrap();
        let raw = read_raw(&path).unwrap();
        assert_eq!(raw.sections["PLC"].rows[0].cells[1], "temp º");
    }
}
