//! A small XML tree with byte offsets, built from quick-xml events without recursion, so that
//! a reader (PNML, PLCopen XML) can look at elements in any order and point every diagnostic
//! at its element, and a text (an ST body) at its first character. Well-formedness errors
//! carry the offset where they are, and attributes are checked as strictly as text.

use quick_xml::events::attributes::AttrError;
use quick_xml::events::{BytesStart, Event};
use quick_xml::{Reader, XmlVersion};

/// Deeper nesting is refused: PNML needs a dozen levels, PLCopen a few dozen, and a bounded
/// depth keeps every later walk over the tree (and dropping it) far from the stack limit.
pub const MAX_DEPTH: usize = 256;

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Element {
    /// The local name (namespace prefixes dropped: `xhtml:p` is `p`).
    pub name: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    /// The element's own character data, concatenated, entities resolved; blank pieces
    /// before the first other one left out or kept as [`LeadingBlanks`] says.
    pub text: String,
    /// Byte offset in the file of the first character of `text`.
    pub text_start: Option<usize>,
    /// Byte offset of the `<` that opens the element.
    pub start: usize,
    /// Byte offset just after the element ends.
    pub end: usize,
}

impl Element {
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    pub fn child(&self, name: &str) -> Option<&Element> {
        self.children.iter().find(|c| c.name == name)
    }

    pub fn children_named<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a Element> + 'a {
        self.children.iter().filter(move |c| c.name == name)
    }

    /// Takes the children, so that a caller can drop a deep tree level by level (dropped
    /// recursively it could overflow the stack).
    pub fn into_children(self) -> Vec<Element> {
        self.children
    }

    /// The element as written in `src`, for keeping it verbatim.
    pub fn raw<'s>(&self, src: &'s str) -> &'s str {
        src.get(self.start..self.end).unwrap_or("")
    }
}

/// A well-formedness error at a byte offset.
#[derive(Debug)]
pub struct XmlError {
    pub offset: usize,
    pub message: String,
}

/// Whether XML 1.0 allows `c` in a document, raw or as a character reference.
pub fn allowed(c: char) -> bool {
    matches!(c, '\t' | '\n' | '\r' | '\u{20}'..='\u{d7ff}' | '\u{e000}'..='\u{fffd}' | '\u{10000}'..)
}

fn forbidden(c: char) -> String {
    format!("character U+{:04X} is not allowed in XML", u32::from(c))
}

/// What becomes of blank pieces of text (white space between tags, around a CDATA section)
/// before an element's first other piece.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LeadingBlanks {
    /// Dropped, so that `text` starts at `text_start` and can be read as a source placed
    /// there (PLCopen's ST bodies); a blank text is empty.
    Drop,
    /// Kept: `text` is every piece (PNML names are written back as they were read).
    Keep,
}

/// Parses a document into its root element, blank pieces before the text dropped.
pub fn parse(src: &str) -> Result<Element, XmlError> {
    parse_at(src, 0, LeadingBlanks::Drop)
}

/// Parses `src` (whose first byte is at `base` in the file) into its root element.
pub fn parse_at(src: &str, base: usize, blanks: LeadingBlanks) -> Result<Element, XmlError> {
    // quick-xml skips a byte order mark without counting it in its positions (TwinCAT writes
    // one at the start of every file): the offsets stay the file's when it is left out here.
    if let Some(rest) = src.strip_prefix('\u{feff}') {
        return parse_at(rest, base + '\u{feff}'.len_utf8(), blanks);
    }
    // quick-xml does not check characters; text that cannot be written back is refused here.
    if let Some((at, c)) = src.char_indices().find(|(_, c)| !allowed(*c)) {
        return Err(XmlError {
            offset: base + at,
            message: forbidden(c),
        });
    }
    let mut reader = Reader::from_str(src);
    let mut stack: Vec<Element> = Vec::new();
    let mut root: Option<Element> = None;
    let err = |offset: usize, message: String| XmlError {
        offset: base + offset,
        message,
    };
    loop {
        let before = offset(reader.buffer_position());
        let event = match reader.read_event() {
            Ok(e) => e,
            Err(e) => {
                return Err(err(
                    offset(reader.error_position()),
                    format!("malformed XML: {e}"),
                ))
            }
        };
        let after = offset(reader.buffer_position());
        match event {
            Event::Start(s) | Event::Empty(s) if stack.len() >= MAX_DEPTH => {
                let _ = s;
                return Err(err(
                    before,
                    format!("elements are nested more than {MAX_DEPTH} deep"),
                ));
            }
            Event::Start(s) => {
                stack.push(element(&s, src, before, base).map_err(|(at, m)| err(at, m))?)
            }
            Event::Empty(s) => {
                let mut el = element(&s, src, before, base).map_err(|(at, m)| err(at, m))?;
                el.end = after + base;
                attach(&mut stack, &mut root, el).map_err(|m| err(before, m))?;
            }
            Event::End(_) => {
                let Some(mut el) = stack.pop() else {
                    return Err(err(before, "a closing tag without an opening tag".into()));
                };
                el.end = after + base;
                attach(&mut stack, &mut root, el).map_err(|m| err(before, m))?;
            }
            Event::Text(t) => text(&mut stack, &t.xml10_content(), base + before, blanks)
                .map_err(|m| err(before, m))?,
            // The text starts after `<![CDATA[`.
            Event::CData(t) => text(&mut stack, &t.xml10_content(), base + before + 9, blanks)
                .map_err(|m| err(before, m))?,
            Event::GeneralRef(r) => {
                let resolved = match r.resolve_char_ref() {
                    Ok(Some(c)) if allowed(c) => c.to_string(),
                    Ok(Some(c)) => return Err(err(before, forbidden(c))),
                    Ok(None) => match predefined(&r.xml10_content()) {
                        Some(s) => s.to_string(),
                        None => {
                            return Err(err(
                                before,
                                format!(
                                    "unknown entity `&{};`: only &lt; &gt; &amp; &apos; &quot; \
                                     and character references are defined",
                                    r.xml10_content()
                                ),
                            ))
                        }
                    },
                    Err(e) => return Err(err(before, format!("bad character reference: {e}"))),
                };
                text(&mut stack, &resolved, base + before, blanks).map_err(|m| err(before, m))?;
            }
            Event::Eof => break,
            Event::Comment(_) | Event::Decl(_) | Event::PI(_) | Event::DocType(_) => {}
        }
    }
    if let Some(open) = stack.last() {
        return Err(XmlError {
            offset: open.start,
            message: format!("`<{}>` is never closed", open.name),
        });
    }
    root.ok_or_else(|| err(src.len(), "the file holds no XML element".into()))
}

fn offset(pos: u64) -> usize {
    usize::try_from(pos).unwrap_or(usize::MAX)
}

/// Builds an element from its start tag at `start` in `src` (at `base` in the file); an
/// error carries its offset in `src`.
fn element(
    s: &BytesStart<'_>,
    src: &str,
    start: usize,
    base: usize,
) -> Result<Element, (usize, String)> {
    let mut attrs = Vec::new();
    for a in s.attributes() {
        let a = a.map_err(|e| attr_error(&e, src, start))?;
        let key = a.key.local_name().into_inner();
        let value = a.normalized_value(XmlVersion::Implicit1_0).map_err(|_| {
            let msg = format!(
                "attribute `{key}` holds an unknown entity or a bad character reference; only \
                 &lt; &gt; &amp; &apos; &quot; and character references are defined"
            );
            (start, msg)
        })?;
        if let Some(c) = value.chars().find(|c| !allowed(*c)) {
            return Err((start, forbidden(c)));
        }
        attrs.push((key.to_string(), value.into_owned()));
    }
    Ok(Element {
        name: s.local_name().into_inner().to_string(),
        attrs,
        children: Vec::new(),
        text: String::new(),
        text_start: None,
        start: base + start,
        end: base + start,
    })
}

/// Says what is wrong with an attribute, at its offset; quick-xml counts from after the `<`.
fn attr_error(e: &AttrError, src: &str, start: usize) -> (usize, String) {
    let at = |pos: usize| start.saturating_add(pos).saturating_add(1);
    match *e {
        AttrError::ExpectedEq(p) => (at(p), "an attribute name is not followed by `=`".into()),
        AttrError::ExpectedValue(p) => (at(p), "an attribute has no value after `=`".into()),
        AttrError::UnquotedValue(p) => (at(p), "an attribute value is not in quotes".into()),
        AttrError::ExpectedQuote(p, _) => (at(p), "an attribute value is not closed".into()),
        AttrError::Duplicated(p, _) => {
            let name: String = src
                .get(at(p)..)
                .unwrap_or("")
                .chars()
                .take_while(|c| !c.is_whitespace() && *c != '=')
                .take(60)
                .collect();
            (at(p), format!("attribute `{name}` is given twice"))
        }
    }
}

fn attach(stack: &mut [Element], root: &mut Option<Element>, el: Element) -> Result<(), String> {
    match stack.last_mut() {
        Some(parent) => parent.children.push(el),
        None if root.is_none() => *root = Some(el),
        None => {
            return Err(format!(
                "a second top-level element `<{}>`; XML has one root",
                el.name
            ))
        }
    }
    Ok(())
}

/// Adds `s`, at `at` in the file, to the open element's text.
fn text(stack: &mut [Element], s: &str, at: usize, blanks: LeadingBlanks) -> Result<(), String> {
    match stack.last_mut() {
        Some(top) => {
            // Blank pieces before the first real text are dropped, so that `text` starts
            // exactly at `text_start` (an ST body's first line and column).
            if top.text_start.is_none() && blanks == LeadingBlanks::Drop && s.trim().is_empty() {
                return Ok(());
            }
            top.text_start.get_or_insert(at);
            top.text.push_str(s);
        }
        None if s.trim().is_empty() => {}
        None => return Err("text outside the root element".into()),
    }
    Ok(())
}

fn predefined(name: &str) -> Option<&'static str> {
    Some(match name {
        "lt" => "<",
        "gt" => ">",
        "amp" => "&",
        "apos" => "'",
        "quot" => "\"",
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Renders the tree compactly, or the error with its offset.
    fn check(input: &str, expect: &str) {
        fn show(e: &Element, out: &mut String) {
            out.push_str(&format!("{}@{}..{}", e.name, e.start, e.end));
            for (k, v) in &e.attrs {
                out.push_str(&format!(" {k}={v:?}"));
            }
            if !e.text.trim().is_empty() {
                out.push_str(&format!(" {:?}", e.text));
            }
            if !e.children.is_empty() {
                out.push('[');
                for (i, c) in e.children.iter().enumerate() {
                    if i > 0 {
                        out.push(' ');
                    }
                    show(c, out);
                }
                out.push(']');
            }
        }
        let got = match parse_at(input, 0, LeadingBlanks::Keep) {
            Ok(e) => {
                let mut s = String::new();
                show(&e, &mut s);
                s
            }
            Err(e) => format!("error at {}: {}", e.offset, e.message),
        };
        assert_eq!(got, expect, "{input}");
    }

    #[test]
    fn offsets_count_a_byte_order_mark() {
        check(
            "\u{feff}<a>\n <b/><![CDATA[x]]></a>",
            "a@3..29 \"\\n x\"[b@8..12]",
        );
    }

    #[test]
    fn builds_a_tree_with_offsets_text_and_entities() {
        check(
            "<?xml version=\"1.0\"?>\n<a x=\"1&amp;2\"><b/><p:c>t &lt; u&#65;<![CDATA[<z>]]></p:c></a>",
            "a@22..84 x=\"1&2\"[b@37..41 c@41..80 \"t < uA<z>\"]",
        );
        check("<a y='a&#10;b\tc'/>", "a@0..18 y=\"a\\nb c\"");
    }

    #[test]
    fn reports_malformed_xml_with_an_offset() {
        check(
            "<a><b></a>",
            "error at 6: malformed XML: ill-formed document: expected `</b>`, but `</a>` was found",
        );
        check("<a><b>", "error at 3: `<b>` is never closed");
        check(
            "<a/><b/>",
            "error at 4: a second top-level element `<b>`; XML has one root",
        );
        check("<a>&nope;</a>", "error at 3: unknown entity `&nope;`: only &lt; &gt; &amp; &apos; &quot; and character references are defined");
        check("", "error at 0: the file holds no XML element");
        check(
            "<a>\u{1}</a>",
            "error at 3: character U+0001 is not allowed in XML",
        );
        check("<a>&#0;</a>", "error at 3: bad character reference: invalid character reference: 0x0 character is not permitted in XML");
        check(
            "<a>x&#x1F;</a>",
            "error at 4: character U+001F is not allowed in XML",
        );
        check(
            "<a b='&#xFFFE;'/>",
            "error at 0: character U+FFFE is not allowed in XML",
        );
        check("hello", "error at 0: text outside the root element");
        check(
            "<a x=\"1\" x=\"2\"/>",
            "error at 9: attribute `x` is given twice",
        );
        check(
            "<a x/>",
            "error at 4: an attribute name is not followed by `=`",
        );
        check(
            "<a x=1/>",
            "error at 5: an attribute value is not in quotes",
        );
        check("<a x=\"1/>", "error at 0: malformed XML: syntax error: attribute value not closed: `\"` not found before end of input");
        check("<a x=\"&bad;\"/>", "error at 0: attribute `x` holds an unknown entity or a bad character reference; only &lt; &gt; &amp; &apos; &quot; and character references are defined");
    }

    #[test]
    fn refuses_deep_nesting_without_overflowing_the_stack() {
        let deep = "<a>".repeat(100_000);
        check(
            &deep,
            "error at 768: elements are nested more than 256 deep",
        );
    }

    #[test]
    fn text_starts_at_its_first_character() {
        let src = "<a x=\"1&amp;2\"><p:b>\n  <![CDATA[x := 1;]]>\n</p:b><c>t &lt; u</c></a>";
        let a = parse(src).unwrap();
        assert_eq!(a.attr("x"), Some("1&2"));
        let b = a.child("b").unwrap();
        assert_eq!(b.text, "x := 1;\n");
        assert_eq!(&src[b.text_start.unwrap()..][..7], "x := 1;");
        assert_eq!(a.child("c").unwrap().text, "t < u");
        assert_eq!(a.children_named("c").count(), 1);
        // Offsets count from where the text is in its file.
        let inner = parse_at("<d> y</d>", 100, LeadingBlanks::Drop).unwrap();
        assert_eq!(
            (inner.start, inner.end, inner.text_start),
            (100, 109, Some(103))
        );
        assert_eq!(inner.text, " y");
    }

    #[test]
    fn blank_text_is_dropped_or_kept() {
        check("<a>  <b/>\n</a>", "a@0..14[b@5..9]");
        assert_eq!(parse("<a> </a>").unwrap().text, "");
        let kept = parse_at("<a>\r<![CDATA[x]]></a>", 0, LeadingBlanks::Keep).unwrap();
        // XML reads a carriage return as a line feed.
        assert_eq!((kept.text.as_str(), kept.text_start), ("\nx", Some(3)));
        let dropped = parse("<a>\r<![CDATA[x]]></a>").unwrap();
        assert_eq!((dropped.text.as_str(), dropped.text_start), ("x", Some(13)));
    }
}
