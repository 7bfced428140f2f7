//! A small XML tree with byte offsets for the PLCopen reader, built from quick-xml events
//! without recursion. Graphical bodies are kept as these trees for their front ends.

use quick_xml::events::{BytesStart, Event};
use quick_xml::{Reader, XmlVersion};

/// Deeper nesting is refused (PLCopen needs a few dozen levels); a bounded depth keeps every
/// walk over the tree far from the stack limit.
pub const MAX_DEPTH: usize = 256;

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Element {
    /// The local name (namespace prefixes dropped: `xhtml:p` is `p`).
    pub name: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    /// The element's own character data, concatenated, entities resolved.
    pub text: String,
    /// Byte offset in the file of the first character of `text`.
    pub text_start: Option<usize>,
    /// Byte offset of the `<` that opens the element.
    pub start: usize,
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

    /// Drops the tree iteratively (a deep tree dropped recursively could overflow the stack).
    pub fn into_children(self) -> Vec<Element> {
        self.children
    }
}

/// A well-formedness error at a byte offset.
#[derive(Debug)]
pub struct XmlError {
    pub offset: usize,
    pub message: String,
}

fn allowed(c: char) -> bool {
    matches!(c, '\t' | '\n' | '\r' | '\u{20}'..='\u{d7ff}' | '\u{e000}'..='\u{fffd}' | '\u{10000}'..)
}

/// Parses a document into its root element.
pub fn parse(src: &str) -> Result<Element, XmlError> {
    if let Some((at, c)) = src.char_indices().find(|(_, c)| !allowed(*c)) {
        return Err(XmlError {
            offset: at,
            message: format!("character U+{:04X} is not allowed in XML", u32::from(c)),
        });
    }
    let mut reader = Reader::from_str(src);
    let mut stack: Vec<Element> = Vec::new();
    let mut root: Option<Element> = None;
    let err = |offset: usize, message: String| XmlError { offset, message };
    loop {
        let before = pos(reader.buffer_position());
        let event = match reader.read_event() {
            Ok(e) => e,
            Err(e) => {
                return Err(err(
                    pos(reader.error_position()),
                    format!("malformed XML: {e}"),
                ))
            }
        };
        let after = pos(reader.buffer_position());
        match event {
            Event::Start(_) | Event::Empty(_) if stack.len() >= MAX_DEPTH => {
                return Err(err(
                    before,
                    format!("elements are nested more than {MAX_DEPTH} deep"),
                ));
            }
            Event::Start(s) => stack.push(element(&s, before).map_err(|m| err(before, m))?),
            Event::Empty(s) => {
                let mut el = element(&s, before).map_err(|m| err(before, m))?;
                el.end = after;
                attach(&mut stack, &mut root, el).map_err(|m| err(before, m))?;
            }
            Event::End(_) => {
                let Some(mut el) = stack.pop() else {
                    return Err(err(before, "a closing tag without an opening tag".into()));
                };
                el.end = after;
                attach(&mut stack, &mut root, el).map_err(|m| err(before, m))?;
            }
            Event::Text(t) => {
                text(&mut stack, &t.xml10_content(), before).map_err(|m| err(before, m))?
            }
            Event::CData(t) => {
                text(&mut stack, &t.xml10_content(), before + 9).map_err(|m| err(before, m))?
            }
            Event::GeneralRef(r) => {
                let resolved = match r.resolve_char_ref() {
                    Ok(Some(c)) if allowed(c) => c.to_string(),
                    Ok(Some(c)) => {
                        return Err(err(
                            before,
                            format!("character U+{:04X} is not allowed in XML", u32::from(c)),
                        ))
                    }
                    Ok(None) => match &*r.xml10_content() {
                        "lt" => "<".into(),
                        "gt" => ">".into(),
                        "amp" => "&".into(),
                        "apos" => "'".into(),
                        "quot" => "\"".into(),
                        other => {
                            return Err(err(
                                before,
                                format!("unknown entity `&{other};`; only &lt; &gt; &amp; &apos; &quot; and character references are defined"),
                            ))
                        }
                    },
                    Err(e) => return Err(err(before, format!("bad character reference: {e}"))),
                };
                text(&mut stack, &resolved, before).map_err(|m| err(before, m))?;
            }
            Event::Eof => break,
            Event::Comment(_) | Event::Decl(_) | Event::PI(_) | Event::DocType(_) => {}
        }
    }
    if let Some(open) = stack.last() {
        return Err(err(
            open.start,
            format!("`<{}>` is never closed", open.name),
        ));
    }
    root.ok_or_else(|| err(src.len(), "the file holds no XML element".into()))
}

fn pos(p: u64) -> usize {
    usize::try_from(p).unwrap_or(usize::MAX)
}

fn element(s: &BytesStart<'_>, start: usize) -> Result<Element, String> {
    let mut attrs = Vec::new();
    for a in s.attributes() {
        let a = a.map_err(|e| format!("malformed attribute: {e}"))?;
        let key = a.key.local_name().into_inner().to_string();
        let value = a.normalized_value(XmlVersion::Implicit1_0).map_err(|_| {
            format!("attribute `{key}` holds an unknown entity or a bad character reference")
        })?;
        attrs.push((key, value.into_owned()));
    }
    Ok(Element {
        name: s.local_name().into_inner().to_string(),
        attrs,
        children: Vec::new(),
        text: String::new(),
        text_start: None,
        start,
        end: start,
    })
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

fn text(stack: &mut [Element], s: &str, at: usize) -> Result<(), String> {
    match stack.last_mut() {
        Some(top) => {
            if top.text_start.is_none() {
                // Whitespace before the first real text is dropped, so `text` starts exactly
                // at `text_start`.
                if s.trim().is_empty() {
                    return Ok(());
                }
                top.text.clear();
                top.text_start = Some(at);
            }
            top.text.push_str(s);
        }
        None if s.trim().is_empty() => {}
        None => return Err("text outside the root element".into()),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tree_with_text_offsets() {
        let src = "<a x=\"1&amp;2\"><p:b><![CDATA[x := 1;]]></p:b><c>t &lt; u</c></a>";
        let a = parse(src).unwrap();
        assert_eq!(a.attr("x"), Some("1&2"));
        let b = a.child("b").unwrap();
        assert_eq!(b.text, "x := 1;");
        assert_eq!(&src[b.text_start.unwrap()..][..7], "x := 1;");
        assert_eq!(a.child("c").unwrap().text, "t < u");
    }

    #[test]
    fn malformed() {
        assert!(parse("<a><b></a>").is_err());
        assert!(parse("<a>").is_err());
        assert!(parse("").is_err());
        assert!(parse("<a>&nope;</a>").is_err());
    }
}
