//! Source texts and positions: every node of the tree carries a [`Span`] (a file and a byte
//! range), and the [`SourceMap`] turns it into the 1-based line and column a person reads.
//!
//! A Structured Text body inside a PLCopen XML file is a source of its own whose text is the
//! body, placed at the line and column where the body starts in the XML file, so messages
//! about it point into the XML file.

pub(crate) mod builtin;

/// Index of a source in its [`SourceMap`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FileId(pub u32);

/// A byte range of one source.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Span {
    pub file: FileId,
    pub start: u32,
    pub end: u32,
}

impl Span {
    pub fn new(file: FileId, start: usize, end: usize) -> Self {
        Span {
            file,
            start: start as u32,
            end: end as u32,
        }
    }

    /// The smallest span covering both (same file).
    pub fn to(self, other: Span) -> Span {
        Span {
            file: self.file,
            start: self.start.min(other.start),
            end: self.end.max(other.end),
        }
    }

    /// An empty span at this one's start.
    pub fn at_start(self) -> Span {
        Span {
            end: self.start,
            ..self
        }
    }
}

/// One source text and where it sits in the file a person opens.
#[derive(Clone, Debug)]
pub struct SourceFile {
    /// The path (or name) printed in messages.
    pub name: String,
    pub text: String,
    /// Byte offset of each line start in `text`.
    line_starts: Vec<usize>,
    /// Lines before this text in the file (0 for a file of its own).
    pub line_base: u32,
    /// Columns before the text's first character on its first line.
    pub col_base: u32,
    /// For a text taken from an element of a graphical body (LD, SFC): the element, printed
    /// in messages instead of a line and column (`LD contact localId 3 (start)`).
    pub element: Option<String>,
    /// Whether the text came from a TwinCAT 3 file (`.TcPOU`, `.plcproj`…), for the choice of
    /// dialect.
    pub from_twincat: bool,
    /// Characters before every [`CHUNK`]th byte, so that a column is counted from the nearest
    /// mark rather than from its line's start: a megabyte on one line with an error every few
    /// bytes would otherwise take quadratic time to render. Empty for ASCII text, whose
    /// columns are byte offsets.
    char_marks: Vec<u32>,
}

/// Bytes between two marks of [`SourceFile::char_marks`].
const CHUNK: usize = 256;

/// Characters that start in `bytes` (those that are not UTF-8 continuation bytes).
fn starts(bytes: &[u8]) -> usize {
    bytes.iter().filter(|&&b| b & 0xC0 != 0x80).count()
}

impl SourceFile {
    pub(crate) fn new(name: String, text: String, line_base: u32, col_base: u32) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(
            text.bytes()
                .enumerate()
                .filter(|&(_, b)| b == b'\n')
                .map(|(i, _)| i + 1),
        );
        let char_marks = if text.is_ascii() {
            Vec::new()
        } else {
            let mut marks = vec![0u32];
            for chunk in text.as_bytes().chunks(CHUNK) {
                let last = *marks.last().unwrap_or(&0);
                marks.push(last + starts(chunk) as u32);
            }
            marks
        };
        SourceFile {
            name,
            text,
            line_starts,
            line_base,
            col_base,
            element: None,
            from_twincat: false,
            char_marks,
        }
    }

    /// Characters before byte `at` (a character boundary).
    fn chars_before(&self, at: usize) -> usize {
        if self.char_marks.is_empty() {
            return at;
        }
        let k = at / CHUNK;
        self.char_marks[k] as usize + starts(&self.text.as_bytes()[k * CHUNK..at])
    }

    /// 1-based line and column (in characters) of a byte offset.
    pub fn line_col(&self, offset: usize) -> (u32, u32) {
        let offset = offset.min(self.text.len());
        let line = match self.line_starts.binary_search(&offset) {
            Ok(i) => i,
            Err(i) => i - 1,
        };
        let mut start = self.line_starts[line];
        let end = floor_char_boundary(&self.text, offset);
        // A byte order mark before the first line is not a column.
        if line == 0 && self.text.starts_with('\u{feff}') {
            start = '\u{feff}'.len_utf8().min(end);
        }
        let col = (self.chars_before(end) - self.chars_before(start)) as u32 + 1;
        let col = if line == 0 { col + self.col_base } else { col };
        (line as u32 + 1 + self.line_base, col)
    }

    /// The text of a span (empty when it is not on character boundaries).
    pub fn slice(&self, span: Span) -> &str {
        self.text
            .get(span.start as usize..span.end as usize)
            .unwrap_or("")
    }
}

fn floor_char_boundary(s: &str, mut i: usize) -> usize {
    while i > 0 && !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// Every source of a compilation.
#[derive(Clone, Debug, Default)]
pub struct SourceMap {
    files: Vec<SourceFile>,
}

impl SourceMap {
    pub fn new() -> Self {
        SourceMap::default()
    }

    /// Adds a file of its own.
    pub fn add(&mut self, name: impl Into<String>, text: impl Into<String>) -> FileId {
        self.add_embedded(name, text, 0, 0)
    }

    /// Adds a text that starts at 1-based `line`, `col` of file `name`.
    pub fn add_embedded(
        &mut self,
        name: impl Into<String>,
        text: impl Into<String>,
        line_base: u32,
        col_base: u32,
    ) -> FileId {
        let id = FileId(self.files.len() as u32);
        self.files.push(SourceFile::new(
            name.into(),
            text.into(),
            line_base,
            col_base,
        ));
        id
    }

    /// Adds a text held by an element of a graphical body (at 1-based `line`, `col` of file
    /// `name`); messages name the element instead of the line and column.
    pub fn add_element(
        &mut self,
        name: impl Into<String>,
        text: impl Into<String>,
        line_base: u32,
        col_base: u32,
        element: String,
    ) -> FileId {
        let id = self.add_embedded(name, text, line_base, col_base);
        self.files[id.0 as usize].element = Some(element);
        id
    }

    /// Marks a source as read from a TwinCAT file.
    pub fn mark_twincat(&mut self, id: FileId) {
        if let Some(f) = self.files.get_mut(id.0 as usize) {
            f.from_twincat = true;
        }
    }

    pub fn file(&self, id: FileId) -> &SourceFile {
        match builtin::file(id) {
            Some(f) => f,
            None => &self.files[id.0 as usize],
        }
    }

    /// A source of this map, or one of the built-in vendor libraries' ([`crate::builtin`]).
    pub fn get(&self, id: FileId) -> Option<&SourceFile> {
        builtin::file(id).or_else(|| self.files.get(id.0 as usize))
    }

    pub fn files(&self) -> impl Iterator<Item = (FileId, &SourceFile)> {
        self.files
            .iter()
            .enumerate()
            .map(|(i, f)| (FileId(i as u32), f))
    }

    /// `file:line:col` of a span's start.
    pub fn position(&self, span: Span) -> Position {
        match self.get(span.file) {
            Some(f) => {
                let (line, column) = f.line_col(span.start as usize);
                Position {
                    file: f.name.clone(),
                    line,
                    column,
                    element: f.element.clone(),
                }
            }
            None => Position {
                file: "?".into(),
                line: 0,
                column: 0,
                element: None,
            },
        }
    }

    /// The 1-based line of a span's start in its file.
    pub fn line(&self, span: Span) -> u32 {
        self.get(span.file)
            .map_or(0, |f| f.line_col(span.start as usize).0)
    }

    pub fn slice(&self, span: Span) -> &str {
        self.get(span.file).map_or("", |f| f.slice(span))
    }
}

/// A resolved position, printed `file:line:col` (or `file: element` in a graphical body).
pub use petriplc_diag::Location as Position;

impl petriplc_diag::Locate<Span> for SourceMap {
    fn locate(&self, span: &Span) -> Position {
        self.position(*span)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str, offset: usize, line_base: u32, col_base: u32, expect: (u32, u32)) {
        let mut map = SourceMap::new();
        let id = map.add_embedded("f", text, line_base, col_base);
        assert_eq!(map.file(id).line_col(offset), expect);
    }

    #[test]
    fn lines_and_columns() {
        check("ab\ncd", 0, 0, 0, (1, 1));
        check("ab\ncd", 4, 0, 0, (2, 2));
        check("ab\ncd", 99, 0, 0, (2, 3));
        check("é\nx", 2, 0, 0, (1, 2));
        check("ab\ncd", 1, 10, 20, (11, 22));
        check("ab\ncd", 3, 10, 20, (12, 1));
    }

    #[test]
    fn columns_of_long_lines_count_characters() {
        let text = format!("{}é{}x", "a".repeat(5000), "é".repeat(5000));
        let at = text.len() - 1;
        check(&text, at, 0, 0, (1, 10_002));
        check(&text, 5000, 0, 0, (1, 5001));
        check(&text, 5002, 0, 0, (1, 5002));
        check(&"a".repeat(10_000), 9_999, 0, 0, (1, 10_000));
    }

    #[test]
    fn a_byte_order_mark_is_no_column() {
        check("\u{feff}ab\ncd", 3, 0, 0, (1, 1));
        check("\u{feff}ab\ncd", 4, 0, 0, (1, 2));
        check("\u{feff}ab\ncd", 0, 0, 0, (1, 1));
        check("\u{feff}ab\ncd", 7, 0, 0, (2, 2));
    }
}
