//! TwinCAT 3 files read into the same tree as Structured Text: `.TcPOU` (a POU's declaration
//! and its `<Implementation><ST>` body), `.TcDUT` (a type; `.TcTLEO`, an enumeration with a text list), `.TcGVL` (a global variable
//! list), `.TcTTO` (a task: cycle time, priority, the programs it calls), and the list of
//! files a `.plcproj` project compiles.
//!
//! Each declaration and body is a source of its own placed where its CDATA starts in the XML
//! file (as the PLCopen reader places ST bodies), so a diagnostic points at the line of the
//! `.TcPOU` a person opens. Every such source is marked as coming from a TwinCAT file, for the
//! choice of dialect. A POU's methods, properties (`<Get>`, `<Set>`) and actions are read into
//! its [`PouOop`]; transitions are reported as not supported yet, the rest of the file read.

use crate::ast::*;
use crate::diag::{self, Diagnostics};
use crate::parser;
use crate::source::{FileId, SourceMap, Span};
use crate::xml::{self, Element as X};

/// The extensions of the TwinCAT files read as sources (lower case, without the dot).
pub const EXTENSIONS: &[&str] = &["tcpou", "tcdut", "tcgvl", "tctto", "tcio", "tctleo"];

/// The configuration the tasks of `.TcTTO` files are gathered in (one per project).
pub const TASKS_CONFIGURATION: &str = "TwinCAT";

/// Whether a file is a TwinCAT source: by its extension, or a `<TcPlcObject` root.
pub fn is_twincat(name: &str, text: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    if EXTENSIONS.iter().any(|e| lower.ends_with(&format!(".{e}"))) {
        return true;
    }
    let mut end = text.len().min(1024);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    text[..end].contains("<TcPlcObject")
}

/// Reads a TwinCAT 3 object file. `name` is the path printed in messages.
pub fn read(map: &mut SourceMap, name: &str, text: &str, diags: &mut Diagnostics) -> Library {
    let file = map.add(name, text);
    map.mark_twincat(file);
    let mut lib = Library::default();
    let root = match xml::parse(text) {
        Ok(r) => r,
        Err(e) => {
            diags.error(diag::XML, Span::new(file, e.offset, e.offset), e.message);
            return lib;
        }
    };
    let mut r = Reader {
        map,
        name: name.to_string(),
        file,
        diags,
    };
    if root.name != "TcPlcObject" {
        let span = r.span(&root);
        r.diags.error(
            diag::TWINCAT_STRUCTURE,
            span,
            format!(
                "the root element is <{}>, not TwinCAT's <TcPlcObject>; give a .TcPOU, .TcDUT, .TcGVL or .TcTTO file as TwinCAT 3 saves it",
                root.name
            ),
        );
        return lib;
    }
    for obj in &root.children {
        match obj.name.as_str() {
            "POU" => {
                if let Some(p) = r.pou(obj) {
                    lib.elements.push(Element::Pou(p));
                }
            }
            // `.TcTLEO`: an enumeration with a text list (its texts are for the HMI).
            "DUT" | "GVL" | "EnumerationTextList" => {
                if let Some((text, at)) = r.declaration(obj) {
                    let f = r.embed(&text, at);
                    let got = parser::parse(f, &text, r.diags);
                    // A GVL's name qualifies its variables (`GVL_Main.x`).
                    let list = (obj.name == "GVL").then(|| {
                        let span = r.span(obj);
                        Ident::new(Reader::object_name(obj), span)
                    });
                    for mut e in got.elements {
                        if let (Element::Globals(b), Some(l)) = (&mut e, &list) {
                            b.list = Some(l.clone());
                        }
                        lib.elements.push(e);
                    }
                }
            }
            "Task" => {
                if let Some(c) = r.task(obj) {
                    lib.elements.push(Element::Configuration(c));
                }
            }
            "Itf" => {
                if let Some(p) = r.itf(obj) {
                    lib.elements.push(Element::Pou(p));
                }
            }
            other => {
                let span = r.span(obj);
                r.diags.error(
                    diag::TWINCAT_STRUCTURE,
                    span,
                    format!("<{other}> is not a TwinCAT object petriplc reads; a TwinCAT file holds a <POU>, <DUT>, <GVL>, <Itf> or <Task>"),
                );
            }
        }
    }
    lib
}

/// The files a `.plcproj` compiles: each `<Compile Include="…">` whose extension is one of
/// [`EXTENSIONS`], with the backslashes of its path turned into `/`, and the byte offset of its
/// element (for a diagnostic about it). Malformed XML or another root is an error here.
pub fn project_files(
    map: &mut SourceMap,
    name: &str,
    text: &str,
    diags: &mut Diagnostics,
) -> Vec<(String, Span)> {
    let file = map.add(name, text);
    map.mark_twincat(file);
    let root = match xml::parse(text) {
        Ok(r) => r,
        Err(e) => {
            diags.error(diag::XML, Span::new(file, e.offset, e.offset), e.message);
            return Vec::new();
        }
    };
    if root.name != "Project" {
        diags.error(
            diag::TWINCAT_STRUCTURE,
            Span::new(file, root.start, root.start),
            format!(
                "the root element is <{}>, not the <Project> of a TwinCAT .plcproj",
                root.name
            ),
        );
        return Vec::new();
    }
    let mut files = Vec::new();
    for group in root.children_named("ItemGroup") {
        for c in group.children_named("Compile") {
            let Some(inc) = c.attr("Include") else {
                continue;
            };
            let path = inc.replace('\\', "/");
            let lower = path.to_ascii_lowercase();
            if EXTENSIONS.iter().any(|e| lower.ends_with(&format!(".{e}"))) {
                files.push((path, Span::new(file, c.start, c.start)));
            }
        }
    }
    files
}

struct Reader<'a> {
    map: &'a mut SourceMap,
    name: String,
    file: FileId,
    diags: &'a mut Diagnostics,
}

impl Reader<'_> {
    fn span(&self, el: &X) -> Span {
        Span::new(self.file, el.start, el.start)
    }

    /// A source for a piece of text found at `offset` in the XML file.
    fn embed(&mut self, text: &str, offset: usize) -> FileId {
        let (line, col) = self.map.file(self.file).line_col(offset);
        let f = self
            .map
            .add_embedded(self.name.clone(), text, line - 1, col - 1);
        self.map.mark_twincat(f);
        f
    }

    fn object_name(el: &X) -> String {
        el.attr("Name").unwrap_or("?").to_string()
    }

    /// The `<Declaration>` text of an object and where it starts; reported when missing.
    fn declaration(&mut self, obj: &X) -> Option<(String, usize)> {
        let Some(d) = obj.child("Declaration") else {
            let span = self.span(obj);
            self.diags.error(
                diag::TWINCAT_STRUCTURE,
                span,
                format!(
                    "<{} Name=\"{}\"> has no <Declaration>",
                    obj.name,
                    Self::object_name(obj)
                ),
            );
            return None;
        };
        Some((d.text.clone(), d.text_start.unwrap_or(d.start)))
    }

    fn pou(&mut self, el: &X) -> Option<Pou> {
        let (text, at) = self.declaration(el)?;
        let f = self.embed(&text, at);
        let mut pou = parser::parse_declaration(f, &text, self.diags)?;
        pou.body = self.implementation(el, &pou.name);
        for c in &el.children {
            match c.name.as_str() {
                "Method" | "Property" => {
                    if let Some(oop) = self.member(c) {
                        pou.oop.methods.extend(oop.methods);
                        pou.oop.properties.extend(oop.properties);
                    }
                }
                "Action" => {
                    let name = Ident::new(Self::object_name(c), self.span(c));
                    let body = self.implementation(c, &name);
                    let span = name.span;
                    pou.oop.actions.push(Action { name, body, span });
                }
                "Transition" => {
                    let owner = Self::object_name(el);
                    let span = self.span(c);
                    self.diags.error(
                        diag::UNSUPPORTED,
                        span,
                        format!(
                            "TRANSITION {} of {owner} is not supported yet; the rest of the file is checked",
                            Self::object_name(c)
                        ),
                    );
                }
                _ => {}
            }
        }
        Some(pou)
    }

    /// An `<Itf>`: its declaration (`INTERFACE I_X EXTENDS I_A`), its `<Method>`s and
    /// `<Property>`s (declarations only; a property's `<Get>`/`<Set>` say which accessors it
    /// has).
    fn itf(&mut self, el: &X) -> Option<Pou> {
        let (text, at) = self.declaration(el)?;
        let f = self.embed(&text, at);
        let mut pou = parser::parse_interface_declaration(f, &text, self.diags)?;
        for c in &el.children {
            if !matches!(c.name.as_str(), "Method" | "Property") {
                continue;
            }
            let Some((text, at)) = self.declaration(c) else {
                continue;
            };
            let f = self.embed(&text, at);
            let Some(mut oop) = parser::parse_member_declaration(f, &text, self.diags) else {
                continue;
            };
            for m in &mut oop.methods {
                m.modifiers.is_abstract = true;
            }
            for p in &mut oop.properties {
                p.modifiers.is_abstract = true;
                let span = self.span(c);
                let (mut get, mut set) = (c.child("Get").is_some(), c.child("Set").is_some());
                if !get && !set {
                    (get, set) = (true, true);
                }
                if get {
                    p.get = Some(parser::accessor(
                        p,
                        true,
                        Vec::new(),
                        Body::St(Vec::new()),
                        span,
                    ));
                }
                if set {
                    p.set = Some(parser::accessor(
                        p,
                        false,
                        Vec::new(),
                        Body::St(Vec::new()),
                        span,
                    ));
                }
            }
            pou.oop.methods.extend(oop.methods);
            pou.oop.properties.extend(oop.properties);
        }
        Some(pou)
    }

    /// A `<Method>` (its declaration and body) or a `<Property>` (its declaration, `<Get>`
    /// and `<Set>`, each with variable blocks and a body).
    fn member(&mut self, c: &X) -> Option<PouOop> {
        let (text, at) = self.declaration(c)?;
        let f = self.embed(&text, at);
        let mut oop = parser::parse_member_declaration(f, &text, self.diags)?;
        if let Some(m) = oop.methods.first_mut() {
            let name = m.pou.name.clone();
            m.pou.body = self.implementation(c, &name);
        }
        if let Some(p) = oop.properties.first_mut() {
            for (tag, get) in [("Get", true), ("Set", false)] {
                let Some(acc) = c.child(tag) else {
                    continue;
                };
                let blocks = match acc.child("Declaration") {
                    Some(d) => {
                        let text = blank_access(&d.text);
                        let f = self.embed(&text, d.text_start.unwrap_or(d.start));
                        parser::parse_var_blocks(f, &text, self.diags)
                    }
                    None => Vec::new(),
                };
                let body = self.implementation(acc, &p.name);
                let pou = parser::accessor(p, get, blocks, body, self.span(acc));
                if get {
                    p.get = Some(pou);
                } else {
                    p.set = Some(pou);
                }
            }
        }
        Some(oop)
    }

    fn implementation(&mut self, el: &X, name: &Ident) -> Body {
        let Some(imp) = el.child("Implementation") else {
            return Body::St(Vec::new());
        };
        let Some(lang) = imp.children.first() else {
            return Body::St(Vec::new());
        };
        if lang.name != "ST" {
            let span = self.span(lang);
            self.diags.error(
                diag::UNSUPPORTED,
                span,
                format!(
                    "POU {}: TwinCAT's <{}> body is not read; write the body in ST, or export the POU as PLCopen XML",
                    name.name, lang.name
                ),
            );
            return Body::Missing(span);
        }
        let at = lang.text_start.unwrap_or(lang.start);
        let f = self.embed(&lang.text, at);
        Body::St(parser::parse_body(f, &lang.text, self.diags))
    }

    /// A task object: its cycle time (microseconds), priority and called programs, as a
    /// configuration with one resource that [`TASKS_CONFIGURATION`]'s merging gathers.
    fn task(&mut self, t: &X) -> Option<Configuration> {
        let span = self.span(t);
        let Some(name) = t.attr("Name").filter(|n| !n.trim().is_empty()) else {
            self.diags.error(
                diag::TWINCAT_STRUCTURE,
                span,
                "<Task> has no Name attribute",
            );
            return None;
        };
        let name = Ident::new(name.trim(), span);
        let number = |el: &X, what: &str, diags: &mut Diagnostics| -> Option<u64> {
            let s = el.text.trim();
            match s.parse::<u64>() {
                Ok(v) => Some(v),
                Err(_) => {
                    diags.error(
                        diag::TWINCAT_STRUCTURE,
                        Span::new(span.file, el.start, el.start),
                        format!("task {}: <{what}> is `{s}`, not a whole number", name.name),
                    );
                    None
                }
            }
        };
        let interval = t.child("CycleTime").and_then(|c| {
            let us = number(c, "CycleTime", self.diags)?;
            Some(Expr {
                kind: ExprKind::Literal(Literal::Time {
                    kind: crate::lexer::TimeKind::Time,
                    nanos: i128::from(us) * 1_000,
                }),
                span: Span::new(self.file, c.start, c.start),
            })
        });
        let priority = t.child("Priority").and_then(|c| {
            let p = number(c, "Priority", self.diags)?;
            Some(Expr {
                kind: ExprKind::Literal(Literal::Int {
                    value: i128::from(p),
                    ty: None,
                }),
                span: Span::new(self.file, c.start, c.start),
            })
        });
        let programs = t
            .children_named("PouCall")
            .filter_map(|pc| {
                let n = pc.child("Name")?;
                let pname = n.text.trim();
                let at = Span::new(self.file, n.start, n.start);
                Some(ProgramConfig {
                    name: Ident::new(pname, at),
                    retain: Retain::Unspecified,
                    task: Some(name.clone()),
                    type_name: Ident::new(pname, at),
                    args: Vec::new(),
                    span: at,
                })
            })
            .collect();
        Some(Configuration {
            var_config: Vec::new(),
            name: Ident::new(TASKS_CONFIGURATION, span),
            globals: Vec::new(),
            resources: vec![Resource {
                name: Ident::new("PLC", span),
                on: None,
                globals: Vec::new(),
                tasks: vec![Task {
                    name: name.clone(),
                    interval,
                    single: None,
                    priority,
                    span,
                }],
                programs,
                span,
            }],
            span,
        })
    }
}

#[cfg(test)]
mod tests;

/// A `<Get>`/`<Set>` declaration without the access specifier TwinCAT lets it start with
/// (`PROTECTED`): blanked (columns kept), the property's own access applying to both.
fn blank_access(text: &str) -> String {
    let lead = text.len() - text.trim_start().len();
    let word: String = text[lead..]
        .chars()
        .take_while(|c| c.is_ascii_alphabetic())
        .collect();
    if crate::ast::Access::from_word(&word).is_none() {
        return text.to_string();
    }
    format!(
        "{}{}{}",
        &text[..lead],
        " ".repeat(word.len()),
        &text[lead + word.len()..]
    )
}
