//! PLCopen XML (TC6 v2.01) projects read into the same tree as Structured Text: data types,
//! POUs with their interface and body, configurations with resources, tasks, program
//! instances and global variables.
//!
//! An ST body becomes a source of its own placed where it starts in the XML file, so its
//! diagnostics point into the XML; values held in attributes (initial values, bounds, task
//! intervals) are parsed the same way at their element. IL text and graphical bodies (LD, FBD,
//! SFC) are kept for their front ends. Beremiz and CODESYS write the same schema with small
//! differences (an `<xhtml>` wrapper instead of `<xhtml:p>`, `<derived>` for standard FB
//! types, `pouInstance` directly in a resource); all of these are read.

use crate::ast::*;
use crate::diag::{self, Diagnostics};
use crate::parser;
use crate::source::{FileId, SourceMap, Span};
use crate::xml::{self, Element as X};

/// The namespaces of TC6 v2.01 and of the older 2.00 draft some tools still write.
pub const NAMESPACES: &[&str] = &[
    "http://www.plcopen.org/xml/tc6_0201",
    "http://www.plcopen.org/xml/tc6_0200",
];

/// Whether a text looks like a PLCopen project (a `<project` root in a PLCopen namespace).
pub fn is_plcopen(text: &str) -> bool {
    let mut end = text.len().min(4096);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    let head = &text[..end];
    head.contains("<project") && NAMESPACES.iter().any(|ns| head.contains(ns))
}

/// Whether a PLCopen XML project was written by Beremiz: its fileHeader names Beremiz
/// (as product, company or in its description), or holds the values Beremiz gives a new
/// project (`companyName="Unknown"`, `productName="Unnamed"`, ProjectController.py), or the
/// root element declares the `ns1` prefix Beremiz's XML writer (xmlclass) adds.
pub fn written_by_beremiz(text: &str) -> bool {
    let Some(start) = text.find("<fileHeader") else {
        return false;
    };
    let root = &text[..start];
    let header = &text[start..];
    let header = &header[..header.find('>').unwrap_or(header.len())];
    let attr = |name: &str| {
        let key = format!("{name}=\"");
        header.find(&key).map(|i| {
            let v = &header[i + key.len()..];
            &v[..v.find('"').unwrap_or(v.len())]
        })
    };
    header.to_ascii_lowercase().contains("beremiz")
        || (attr("companyName") == Some("Unknown") && attr("productName") == Some("Unnamed"))
        || root.contains("xmlns:ns1=\"http://www.plcopen.org/xml/tc6")
}

/// Reads a PLCopen project. `name` is the path printed in messages.
pub fn read(map: &mut SourceMap, name: &str, text: &str, diags: &mut Diagnostics) -> Library {
    let file = map.add(name, text);
    let mut lib = Library::default();
    let root = match xml::parse(text) {
        Ok(r) => r,
        Err(e) => {
            diags.error(diag::XML, Span::new(file, e.offset, e.offset), e.message);
            return lib;
        }
    };
    if root.name != "project" {
        diags.error(
            diag::NOT_PLCOPEN,
            Span::new(file, root.start, root.start),
            format!(
                "the root element is <{}>, not a PLCopen <project>; give a TC6 v2.01 project (xmlns=\"{}\") or a .st file",
                root.name, NAMESPACES[0]
            ),
        );
        return lib;
    }
    let mut r = Reader {
        map,
        name: name.to_string(),
        file,
        diags,
        hidden: Vec::new(),
        steps: false,
        found: Vec::new(),
        strings: vec!["HMI_STRING".into()],
        beremiz: written_by_beremiz(text),
    };
    if let Some(types) = root.child("types") {
        if let Some(dts) = types.child("dataTypes") {
            // The string types first, for the initial values that name them (`quoted`).
            for dt in dts.children_named("dataType") {
                if let (Some(name), Some(base)) = (dt.attr("name"), dt.child("baseType")) {
                    if r.is_string(base) {
                        r.strings.push(name.trim().to_string());
                    }
                }
            }
            let decls: Vec<TypeDecl> = dts
                .children_named("dataType")
                .filter_map(|dt| r.data_type(dt))
                .collect();
            if !decls.is_empty() {
                lib.elements.push(Element::Types(decls));
            }
        }
        if let Some(pous) = types.child("pous") {
            for pou in pous.children_named("pou") {
                if let Some(p) = r.pou(pou) {
                    lib.elements.push(Element::Pou(p));
                }
            }
        }
    }
    if r.steps {
        let span = Span::new(file, root.start, root.start);
        lib.elements.push(Element::Types(crate::sfc::types(span)));
    }
    if let Some(configs) = root
        .child("instances")
        .and_then(|i| i.child("configurations"))
    {
        for c in configs.children_named("configuration") {
            if let Some(c) = r.configuration(c) {
                lib.elements.push(Element::Configuration(c));
            }
        }
    }
    r.project_add_data(&root);
    lib.elements.append(&mut r.found);
    lib
}

struct Reader<'a> {
    map: &'a mut SourceMap,
    name: String,
    file: FileId,
    diags: &'a mut Diagnostics,
    /// Hidden variables of the graphical body just lowered, for its POU's interface.
    hidden: Vec<VarDecl>,
    /// Whether an SFC body needs the step structure type.
    steps: bool,
    /// Elements CODESYS keeps in `<addData>` (global variable lists, a resource's POUs).
    found: Vec<Element>,
    /// Whether Beremiz (or OpenPLC Editor) wrote the project: its string initial values may
    /// be unquoted ([`Reader::initial_of`]).
    beremiz: bool,
    /// The names of string types: the project's aliases of STRING and Beremiz SVGHMI's
    /// HMI_STRING (the `beremiz` library's), whose initial values Beremiz writes unquoted.
    strings: Vec<String>,
}

impl Reader<'_> {
    fn span(&self, el: &X) -> Span {
        Span::new(self.file, el.start, el.start)
    }

    /// 0-based line and column of a byte offset in the XML file (for embedded sources).
    fn base_of(&self, offset: usize) -> (u32, u32) {
        let (line, col) = self.map.file(self.file).line_col(offset);
        (line - 1, col - 1)
    }

    /// A source for a piece of text found at `offset` in the XML file.
    fn embed(&mut self, text: &str, offset: usize) -> FileId {
        let (l, c) = self.base_of(offset);
        self.map.add_embedded(self.name.clone(), text, l, c)
    }

    fn missing(&mut self, el: &X, what: &str) {
        let span = self.span(el);
        self.diags.error(
            diag::PLCOPEN_STRUCTURE,
            span,
            format!("<{}> has no {what}", el.name),
        );
    }

    fn name_attr(&mut self, el: &X) -> Option<Ident> {
        match el.attr("name") {
            Some(n) if !n.trim().is_empty() => Some(Ident::new(n.trim(), self.span(el))),
            _ => {
                self.missing(el, "name attribute");
                None
            }
        }
    }

    fn expr_at(&mut self, text: &str, el: &X) -> Option<Expr> {
        let f = self.embed(text, el.start);
        parser::parse_expression(f, text, self.diags)
    }

    fn data_type(&mut self, dt: &X) -> Option<TypeDecl> {
        let name = self.name_attr(dt)?;
        let Some(base) = dt.child("baseType") else {
            self.missing(dt, "<baseType>");
            return None;
        };
        let spec = self.type_of(base)?;
        let init = dt
            .child("initialValue")
            .and_then(|iv| self.initial_of(iv, base));
        Some(TypeDecl {
            span: name.span,
            name,
            spec,
            init,
        })
    }

    /// The type held by a `<type>`/`<baseType>`/`<returnType>` element.
    fn type_of(&mut self, holder: &X) -> Option<TypeSpec> {
        let Some(t) = holder.children.first() else {
            self.missing(holder, "type element inside it");
            return None;
        };
        self.type_element(t)
    }

    fn type_element(&mut self, t: &X) -> Option<TypeSpec> {
        let span = self.span(t);
        const ELEMENTARY: &[&str] = &[
            "BOOL", "BYTE", "WORD", "DWORD", "LWORD", "SINT", "INT", "DINT", "LINT", "USINT",
            "UINT", "UDINT", "ULINT", "REAL", "LREAL", "TIME", "DATE", "DT", "TOD", "LTIME",
            "LDATE", "LDT", "LTOD", "CHAR", "WCHAR",
            // Not TC6 elements (`<string>`, `<wstring>` are), but what some exporters write.
            "STRING", "WSTRING",
        ];
        let n = t.name.as_str();
        if ELEMENTARY.contains(&n) {
            return Some(TypeSpec::Named(Ident::new(n, span)));
        }
        match n {
            "derived" => {
                let name = self.name_attr(t)?;
                Some(TypeSpec::Named(name))
            }
            "string" | "wstring" => {
                let len = match t.attr("length") {
                    Some(l) => Some(Box::new(self.expr_at(l, t)?)),
                    None => None,
                };
                Some(TypeSpec::String {
                    wide: n == "wstring",
                    len,
                    span,
                })
            }
            "array" => {
                let mut ranges = Vec::new();
                for d in t.children_named("dimension") {
                    let (Some(lo), Some(hi)) = (d.attr("lower"), d.attr("upper")) else {
                        self.missing(d, "lower and upper attributes");
                        return None;
                    };
                    let lo = self.expr_at(lo, d)?;
                    let hi = self.expr_at(hi, d)?;
                    ranges.push((lo, hi));
                }
                if ranges.is_empty() {
                    self.missing(t, "<dimension>");
                    return None;
                }
                let Some(base) = t.child("baseType") else {
                    self.missing(t, "<baseType>");
                    return None;
                };
                let elem = self.type_of(base)?;
                Some(TypeSpec::Array {
                    ranges,
                    elem: Box::new(elem),
                    span,
                })
            }
            "enum" => {
                let mut values = Vec::new();
                for v in t
                    .child("values")
                    .into_iter()
                    .flat_map(|v| v.children_named("value"))
                {
                    let name = self.name_attr(v)?;
                    let val = match v.attr("value") {
                        Some(x) => Some(self.expr_at(x, v)?),
                        None => None,
                    };
                    values.push((name, val));
                }
                let base = t
                    .child("baseType")
                    .and_then(|b| b.children.first())
                    .map(|e| Ident::new(e.name.clone(), self.span(e)));
                Some(TypeSpec::Enum { base, values, span })
            }
            "struct" => {
                let fields = t
                    .children_named("variable")
                    .filter_map(|v| self.variable(v))
                    .collect();
                Some(TypeSpec::Struct {
                    base: None,
                    fields,
                    span,
                })
            }
            "subrangeSigned" | "subrangeUnsigned" => {
                let Some(range) = t.child("range") else {
                    self.missing(t, "<range>");
                    return None;
                };
                let (Some(lo), Some(hi)) = (range.attr("lower"), range.attr("upper")) else {
                    self.missing(range, "lower and upper attributes");
                    return None;
                };
                let lo = self.expr_at(lo, range)?;
                let hi = self.expr_at(hi, range)?;
                let base = t
                    .child("baseType")
                    .and_then(|b| b.children.first())
                    .map(|e| Ident::new(e.name.clone(), self.span(e)))
                    .unwrap_or_else(|| Ident::new("DINT", span));
                Some(TypeSpec::Subrange {
                    base,
                    lo: Box::new(lo),
                    hi: Box::new(hi),
                    span,
                })
            }
            "pointer" => {
                // CODESYS exports POINTER TO T so (TC6 v2.01's <pointer>).
                let Some(base) = t.child("baseType") else {
                    self.missing(t, "<baseType>");
                    return None;
                };
                let target = self.type_of(base)?;
                Some(TypeSpec::Ref {
                    kind: RefKind::PointerTo,
                    target: Box::new(target),
                    span,
                })
            }
            other => {
                self.diags.error(
                    diag::PLCOPEN_TYPE,
                    span,
                    format!("<{other}> is not a PLCopen TC6 v2.01 type element; write an elementary type such as <INT/>, <derived name=\"…\"/>, <array>, <string>, <enum>, <struct> or a subrange"),
                );
                None
            }
        }
    }

    /// Whether a `<type>` or `<baseType>` holds a string type.
    fn is_string(&self, ty: &X) -> bool {
        match ty.children.first() {
            Some(t) if matches!(t.name.as_str(), "string" | "wstring") => true,
            Some(t) if t.name == "derived" => t.attr("name").is_some_and(|n| {
                self.strings
                    .iter()
                    .any(|s| s.eq_ignore_ascii_case(n.trim()))
            }),
            _ => false,
        }
    }

    /// The initial value `iv` of something of type `ty`. Beremiz keeps a string's initial
    /// value as typed, quotes and all or not, and quotes it when it writes Structured Text
    /// (PLCGenerator.py, `ComputeValue`): `<simpleValue value="blup"/>` is `'blup'`. Other
    /// writers (CODESYS) keep an expression there (`CONCAT(prefix, '#')`, a constant's
    /// name), read as written.
    fn initial_of(&mut self, iv: &X, ty: &X) -> Option<Init> {
        let simple = iv
            .children
            .first()
            .filter(|v| self.beremiz && v.name == "simpleValue");
        if let (Some(v), true) = (simple, self.is_string(ty)) {
            if let Some(text) = v.attr("value") {
                let wide = ty.children.first().is_some_and(|t| t.name == "wstring");
                let q = if wide { '"' } else { '\'' };
                if !text.starts_with(q) && !text.ends_with(q) {
                    let text = format!("{q}{text}{q}");
                    let f = self.embed(&text, v.start);
                    return parser::parse_init(f, &text, self.diags);
                }
            }
        }
        self.initial(iv)
    }

    fn initial(&mut self, iv: &X) -> Option<Init> {
        let Some(v) = iv.children.first() else {
            self.missing(iv, "value inside it");
            return None;
        };
        self.value(v)
    }

    fn value(&mut self, v: &X) -> Option<Init> {
        match v.name.as_str() {
            "simpleValue" => {
                let Some(text) = v.attr("value") else {
                    self.missing(v, "value attribute");
                    return None;
                };
                let text = text.to_string();
                let f = self.embed(&text, v.start);
                parser::parse_init(f, &text, self.diags)
            }
            "arrayValue" => {
                let mut items = Vec::new();
                for item in v.children_named("value") {
                    let repeat = match item.attr("repeatCount") {
                        Some(n) => Some(self.expr_at(n, item)?),
                        None => None,
                    };
                    let value = match item.children.first() {
                        Some(inner) => Some(self.value(inner)?),
                        None => None,
                    };
                    items.push(ArrayInitItem {
                        repeat,
                        value,
                        span: self.span(item),
                    });
                }
                Some(Init::Array {
                    items,
                    span: self.span(v),
                })
            }
            "structValue" => {
                let mut fields = Vec::new();
                for item in v.children_named("value") {
                    let Some(member) = item.attr("member") else {
                        self.missing(item, "member attribute");
                        return None;
                    };
                    let name = Ident::new(member, self.span(item));
                    let Some(inner) = item.children.first() else {
                        self.missing(item, "value inside it");
                        return None;
                    };
                    fields.push((name, self.value(inner)?));
                }
                Some(Init::Struct {
                    fields,
                    span: self.span(v),
                })
            }
            other => {
                let span = self.span(v);
                self.diags.error(
                    diag::PLCOPEN_STRUCTURE,
                    span,
                    format!("<{other}> is not an initial value; write <simpleValue>, <arrayValue> or <structValue>"),
                );
                None
            }
        }
    }

    fn variable(&mut self, v: &X) -> Option<VarDecl> {
        let name = self.name_attr(v)?;
        let Some(ty) = v.child("type") else {
            self.missing(v, "<type>");
            return None;
        };
        let init = v
            .child("initialValue")
            .and_then(|iv| self.initial_of(iv, ty));
        let ty = self.type_of(ty)?;
        let location = v.attr("address").map(|a| Location {
            text: a.trim().trim_start_matches('%').to_string(),
            span: self.span(v),
        });
        Some(VarDecl {
            span: name.span,
            names: vec![name],
            location,
            ty,
            init,
            edge: None,
            fb_init: None,
        })
    }

    fn var_block(&mut self, b: &X, kind: VarKind) -> VarBlock {
        let flag = |n: &str| matches!(b.attr(n), Some("true" | "1"));
        VarBlock {
            kind,
            constant: flag("constant"),
            retain: if flag("retain") || flag("persistent") {
                Retain::Retain
            } else if flag("nonretain") {
                Retain::NonRetain
            } else {
                Retain::Unspecified
            },
            vars: b
                .children_named("variable")
                .filter_map(|v| self.variable(v))
                .collect(),
            list: None,
            span: self.span(b),
        }
    }

    fn pou(&mut self, el: &X) -> Option<Pou> {
        let name = self.name_attr(el)?;
        let kind = match el.attr("pouType") {
            Some("program") => PouKind::Program,
            Some("functionBlock") => PouKind::FunctionBlock,
            Some("function") => PouKind::Function,
            other => {
                let span = self.span(el);
                self.diags.error(
                    diag::PLCOPEN_STRUCTURE,
                    span,
                    format!(
                        "POU {}: pouType is {}; it must be program, functionBlock or function",
                        name.name,
                        other.map_or("missing".to_string(), |o| format!("`{o}`"))
                    ),
                );
                return None;
            }
        };
        let (mut var_blocks, return_type) = self.interface_of(el);
        if kind == PouKind::Function && return_type.is_none() {
            let span = self.span(el);
            self.diags.error(
                diag::PLCOPEN_STRUCTURE,
                span,
                format!(
                    "FUNCTION {} has no <returnType> in its <interface>",
                    name.name
                ),
            );
        }
        let body = self.body(el, &name);
        let oop = self.pou_add_data(el, &name);
        if !self.hidden.is_empty() {
            var_blocks.push(VarBlock {
                kind: VarKind::Local,
                constant: false,
                retain: Retain::Unspecified,
                vars: std::mem::take(&mut self.hidden),
                list: None,
                span: name.span,
            });
        }
        Some(Pou {
            kind,
            span: name.span,
            name,
            return_type,
            var_blocks,
            body,
            oop: Box::new(oop),
        })
    }

    /// The variable blocks and result type of an `<interface>` (a POU's, a method's).
    fn interface_of(&mut self, el: &X) -> (Vec<VarBlock>, Option<TypeSpec>) {
        let mut var_blocks = Vec::new();
        let mut return_type = None;
        if let Some(iface) = el.child("interface") {
            for b in &iface.children {
                let kind = match b.name.as_str() {
                    "inputVars" => VarKind::Input,
                    "outputVars" => VarKind::Output,
                    "inOutVars" => VarKind::InOut,
                    "externalVars" => VarKind::External,
                    "globalVars" => VarKind::Global,
                    "localVars" => VarKind::Local,
                    "tempVars" => VarKind::Temp,
                    "accessVars" => VarKind::Other,
                    "returnType" => {
                        return_type = self.type_of(b);
                        continue;
                    }
                    _ => continue,
                };
                let block = self.var_block(b, kind);
                var_blocks.push(block);
            }
        }
        (var_blocks, return_type)
    }

    fn body(&mut self, pou: &X, name: &Ident) -> Body {
        let Some(body) = pou.child("body") else {
            return Body::Missing(self.span(pou));
        };
        let Some(lang) = body.children.iter().find(|c| c.name != "documentation") else {
            return Body::Missing(self.span(body));
        };
        let span = self.span(lang);
        match lang.name.as_str() {
            "ST" | "IL" => {
                let (text, at) = text_of(lang);
                let f = self.embed(&text, at.unwrap_or(lang.start));
                if lang.name == "IL" {
                    let code = parser::il::parse_il_body(f, &text, self.diags);
                    return Body::Il { code, span };
                }
                Body::St(parser::parse_body(f, &text, self.diags))
            }
            "LD" | "SFC" | "FBD" => {
                let lowered = if lang.name != "SFC" {
                    graphical::ld::ld(self, &name.name, lang)
                } else {
                    graphical::sfc::sfc(self, &name.name, pou, lang)
                };
                self.hidden = lowered.vars;
                self.steps |= lowered.steps;
                Body::St(lowered.stmts)
            }
            other => {
                self.diags.error(
                    diag::PLCOPEN_STRUCTURE,
                    span,
                    format!("POU {}: <{other}> is not a body language; PLCopen bodies are <ST>, <IL>, <LD>, <FBD> or <SFC>", name.name),
                );
                Body::Missing(span)
            }
        }
    }

    fn configuration(&mut self, c: &X) -> Option<Configuration> {
        let name = self.name_attr(c)?;
        let globals = c
            .children_named("globalVars")
            .flat_map(|b| self.global_vars(b))
            .collect();
        let mut resources = Vec::new();
        for r in c.children_named("resource") {
            let Some(rname) = self.name_attr(r) else {
                continue;
            };
            let mut res = Resource {
                name: rname,
                on: None,
                globals: r
                    .children_named("globalVars")
                    .flat_map(|b| self.global_vars(b))
                    .collect(),
                tasks: Vec::new(),
                programs: Vec::new(),
                span: self.span(r),
            };
            for t in r.children_named("task") {
                let Some(tname) = self.name_attr(t) else {
                    continue;
                };
                let interval = t.attr("interval").map(str::to_string);
                let interval = interval.and_then(|i| {
                    match codesys::iso_duration(&i).or_else(|| clock_duration(&i)) {
                        Some(nanos) => Some(Expr {
                            kind: ExprKind::Literal(Literal::Time {
                                kind: crate::lexer::TimeKind::Time,
                                nanos,
                            }),
                            span: self.span(t),
                        }),
                        None => self.expr_at(&i, t),
                    }
                });
                let priority = t.attr("priority").map(str::to_string);
                let priority = priority.and_then(|p| self.expr_at(&p, t));
                let single = t.attr("single").map(str::to_string);
                let single = single.and_then(|s| self.expr_at(&s, t));
                for pi in t.children_named("pouInstance") {
                    if let Some(p) = self.pou_instance(pi, Some(tname.clone())) {
                        res.programs.push(p);
                    }
                }
                res.tasks.push(Task {
                    span: tname.span,
                    name: tname,
                    interval,
                    single,
                    priority,
                });
            }
            for pi in r.children_named("pouInstance") {
                if let Some(p) = self.pou_instance(pi, None) {
                    res.programs.push(p);
                }
            }
            self.resource_add_data(r);
            resources.push(res);
        }
        Some(Configuration {
            var_config: Vec::new(),
            span: name.span,
            name,
            globals,
            resources,
        })
    }

    fn pou_instance(&mut self, pi: &X, task: Option<Ident>) -> Option<ProgramConfig> {
        let name = self.name_attr(pi)?;
        // CODESYS writes `typeName=""` for a program called by its own name.
        // TC6 1.0 (Beremiz's and matiec's older projects) names the type `type`.
        let ty = match pi
            .attr("typeName")
            .or_else(|| pi.attr("type"))
            .map(str::trim)
        {
            Some("") => name.name.clone(),
            Some(t) => t.to_string(),
            None => {
                self.missing(pi, "typeName attribute");
                return None;
            }
        };
        Some(ProgramConfig {
            span: name.span,
            type_name: Ident::new(ty, self.span(pi)),
            name,
            retain: Retain::Unspecified,
            task,
            args: Vec::new(),
        })
    }
}

/// The text of a body element: its `<xhtml:p>`/`<xhtml>` child's or its own, and where it
/// starts in the file.
fn text_of(lang: &X) -> (String, Option<usize>) {
    for c in &lang.children {
        if !c.text.is_empty() {
            return (c.text.clone(), c.text_start);
        }
    }
    (lang.text.clone(), lang.text_start)
}

mod codesys;
mod graphical;
#[cfg(test)]
mod tests;

/// A TC6 1.0 task interval (`interval="00:00:00.100000"`: the schema types it xsd:time, as
/// matiec's test projects write it) in nanoseconds: hours, minutes, seconds with a fraction;
/// `None` for anything else.
fn clock_duration(text: &str) -> Option<i128> {
    let mut parts = text.trim().split(':');
    let (h, m, sec) = (parts.next()?, parts.next()?, parts.next()?);
    if parts.next().is_some() {
        return None;
    }
    let digits = |x: &str| !x.is_empty() && x.bytes().all(|b| b.is_ascii_digit());
    let (whole, frac) = sec.split_once('.').unwrap_or((sec, ""));
    if !digits(h) || !digits(m) || !digits(whole) || !(frac.is_empty() || digits(frac)) {
        return None;
    }
    const S: i128 = 1_000_000_000;
    let mut nanos: i128 = 0;
    let mut scale = S / 10;
    for d in frac.bytes().take(9) {
        nanos += i128::from(d - b'0') * scale;
        scale /= 10;
    }
    let hms = h.parse::<i128>().ok()? * 3_600
        + m.parse::<i128>().ok()? * 60
        + whole.parse::<i128>().ok()?;
    Some(hms * S + nanos)
}
