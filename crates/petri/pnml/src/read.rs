//! Reading: PNML text to a checked [`Net`](petriplc_net::Net) and its [`Layout`], collecting
//! every problem with its file position instead of stopping at the first.

use std::collections::HashMap;

use petriplc_net::guard::{self, Expr};
use petriplc_net::{
    time, ArcKind, ArcSpec, Evolution, PlaceSpec, SignalDirection, SignalType, StepRule,
};

use crate::diag::{self, Code, Diagnostic, LineIndex, Location, Severity};
use crate::layout::{Extras, Layout};
use crate::vocab;
use crate::xml::{self, Element, LeadingBlanks};
use crate::{Document, Naming, PnmlError, ReadOptions};

/// Reads one net from `text`; `source` names the file in diagnostics.
pub(crate) fn read(text: &str, source: &str, opts: &ReadOptions) -> Result<Document, PnmlError> {
    let mut r = Reader::new(text, source, opts.naming);
    // A byte-order mark is not content; skip it but keep offsets true to the file.
    let base = if text.starts_with('\u{feff}') {
        '\u{feff}'.len_utf8()
    } else {
        0
    };
    match xml::parse_at(text.get(base..).unwrap_or(""), base, LeadingBlanks::Keep) {
        Ok(root) => r.document(&root),
        Err(e) if e.message.starts_with("elements are nested") => {
            let msg = format!("{}; PNML needs far fewer", e.message);
            r.error(diag::XML, e.offset, None, msg)
        }
        Err(e) => r.error(diag::XML, e.offset, None, e.message),
    }
    r.finish()
}

/// Reports bytes that are not UTF-8, at the first bad byte.
pub(crate) fn not_utf8(bytes: &[u8], err: &std::str::Utf8Error, source: &str) -> PnmlError {
    let valid = bytes.get(..err.valid_up_to()).unwrap_or(&[]);
    let text = std::str::from_utf8(valid).unwrap_or("");
    let (line, column) = LineIndex::new(text).position(text.len());
    PnmlError::Invalid(vec![Diagnostic::new(
        Severity::Error,
        Code(diag::XML),
        Location::new(source, line, column),
        "the file is not UTF-8 text; save it as UTF-8",
    )])
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Net,
    Page,
    Place,
    Transition,
    Arc,
    RefPlace,
    RefTransition,
}

impl Kind {
    fn noun(self) -> &'static str {
        match self {
            Kind::Net => "net",
            Kind::Page => "page",
            Kind::Place => "place",
            Kind::Transition => "transition",
            Kind::Arc => "arc",
            Kind::RefPlace => "reference place",
            Kind::RefTransition => "reference transition",
        }
    }
}

struct Node {
    kind: Kind,
    at: usize,
}

struct PlaceRead {
    spec: PlaceSpec,
    explicit_signal: bool,
    explicit_capacity: bool,
    at: usize,
}

struct TransitionRead {
    id: String,
    name: String,
    name_at: usize,
    guard: Option<Expr<String>>,
    deadline: Option<std::time::Duration>,
}

struct RefRead {
    id: String,
    target: String,
    kind: Kind,
}

/// Where a signal is named, so a model error about the signal can point there.
struct SignalUse {
    /// The order the builder meets uses in: declarations, places, transitions.
    stage: u8,
    name: String,
    direction: SignalDirection,
    declared: Option<SignalType>,
    at: usize,
    element: String,
}

struct Reader<'a> {
    src: &'a str,
    file: &'a str,
    naming: Naming,
    lines: LineIndex<'a>,
    diags: Vec<Problem>,
    ids: HashMap<String, Node>,
    net_id: String,
    net_name: String,
    step: Option<StepRule>,
    evolve: Option<Evolution>,
    signals: Vec<(String, SignalDirection, SignalType)>,
    places: Vec<PlaceRead>,
    transitions: Vec<TransitionRead>,
    arcs: Vec<ArcSpec>,
    refs: Vec<RefRead>,
    uses: Vec<SignalUse>,
    layout: Layout,
    net_read: bool,
}

/// A diagnostic before its position is worked out.
struct Problem {
    at: usize,
    code: &'static str,
    element: Option<String>,
    message: String,
    /// Another place that explains this one (byte offset and why), a secondary label.
    label: Option<(usize, &'static str)>,
}

/// Remembers which once-only children an element has had, to report repeats.
#[derive(Default)]
struct Once(Vec<String>);

impl Once {
    fn first(&mut self, name: &str) -> bool {
        if self.0.iter().any(|n| n == name) {
            return false;
        }
        self.0.push(name.to_string());
        true
    }
}

/// Shortens a value quoted in a message, so a huge attribute cannot flood the terminal.
fn shown(s: &str) -> String {
    const MAX: usize = 60;
    match s.char_indices().nth(MAX) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s.to_string(),
    }
}

/// Records a label's extras; a label without any leaves no entry, so layouts compare equal
/// whether or not the label was written.
fn put_label(extras: &mut Extras, label: &str, fragments: Vec<String>) {
    if !fragments.is_empty() {
        extras.labels.insert(label.to_string(), fragments);
    }
}

fn is_ours(el: &Element) -> bool {
    el.name == "toolspecific"
        && el
            .attr("tool")
            .is_some_and(|t| t.trim().eq_ignore_ascii_case(vocab::TOOL))
}

fn starts_with_default(name: &str) -> bool {
    name.get(..7)
        .is_some_and(|p| p.eq_ignore_ascii_case("default"))
}

/// Parses a count as PNML spells it (`xsd:nonNegativeInteger`: optional `+`, leading zeros,
/// even `-0`); the error completes "initial marking `x` …".
fn parse_count(text: &str) -> Result<u32, &'static str> {
    let t = text.trim();
    if t.is_empty() {
        return Err("is empty");
    }
    let (negative, digits) = match t.as_bytes().first() {
        Some(b'-') => (true, t.get(1..).unwrap_or("")),
        Some(b'+') => (false, t.get(1..).unwrap_or("")),
        _ => (false, t),
    };
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return Err("is not a whole number");
    }
    let significant = digits.trim_start_matches('0');
    match (negative, significant.is_empty()) {
        (_, true) => Ok(0),
        (true, false) => Err("is negative"),
        // Ten digits or fewer cannot overflow a u64, so parsing cannot fail.
        (false, false) if significant.len() <= 10 => significant
            .parse::<u64>()
            .ok()
            .and_then(|v| u32::try_from(v).ok())
            .ok_or("is larger than 4294967295"),
        (false, false) => Err("is larger than 4294967295"),
    }
}

impl<'a> Reader<'a> {
    fn new(src: &'a str, file: &'a str, naming: Naming) -> Self {
        Reader {
            src,
            file,
            naming,
            lines: LineIndex::new(src),
            diags: Vec::new(),
            ids: HashMap::new(),
            net_id: String::new(),
            net_name: String::new(),
            step: None,
            evolve: None,
            signals: Vec::new(),
            places: Vec::new(),
            transitions: Vec::new(),
            arcs: Vec::new(),
            refs: Vec::new(),
            uses: Vec::new(),
            layout: Layout::default(),
            net_read: false,
        }
    }

    /// Records a problem at byte offset `at`; lines and columns are worked out at the end,
    /// in file order.
    fn error(&mut self, code: &'static str, at: usize, element: Option<&str>, message: String) {
        self.diags.push(Problem {
            at,
            code,
            element: element.map(str::to_string),
            message,
            label: None,
        });
    }

    /// As [`Reader::error`], with a secondary label at byte offset `other`.
    fn error_with(
        &mut self,
        code: &'static str,
        at: usize,
        element: Option<&str>,
        message: String,
        other: (usize, &'static str),
    ) {
        self.error(code, at, element, message);
        if let Some(p) = self.diags.last_mut() {
            p.label = Some(other);
        }
    }

    fn document(&mut self, root: &Element) {
        if root.name != "pnml" {
            let msg = format!(
                "the root element is `<{}>`, not `<pnml>`; this is not a PNML file",
                shown(&root.name)
            );
            self.error(diag::NOT_PNML, root.start, None, msg);
            return;
        }
        let mut nets = root.children.iter().filter(|c| c.name == "net");
        let Some(net) = nets.next() else {
            let msg = "`<pnml>` holds no `<net>`; a PNML file describes at least one net".into();
            self.error(diag::NOT_PNML, root.start, None, msg);
            return;
        };
        for extra in nets {
            let msg = format!(
                "a second `<net>`{}; petriplc reads one net per file, so split the file",
                extra
                    .attr("id")
                    .map(|id| format!(" (`{}`)", shown(id)))
                    .unwrap_or_default()
            );
            self.error(diag::SEVERAL_NETS, extra.start, extra.attr("id"), msg);
        }
        self.net(net);
    }

    fn net(&mut self, net: &Element) {
        self.net_id = self.node_id(net, Kind::Net).unwrap_or_default();
        let id = self.net_id.clone();
        match net.attr("type") {
            None => {
                let msg = format!(
                    "net `{}` has no `type` attribute; a P/T net has type=\"{}\"",
                    shown(&id),
                    vocab::PTNET
                );
                self.error(diag::MISSING_ATTRIBUTE, net.start, Some(&id), msg);
            }
            Some(t) if vocab::is_pt_net_type(t) => {}
            Some(t) => {
                let msg = format!(
                    "net `{}` has type `{}`; petriplc reads place/transition nets (type {} \
                     or an extension such as {})",
                    shown(&id),
                    shown(t),
                    vocab::PTNET,
                    vocab::INHIBITOR_PTNET
                );
                // Reading another net type as a P/T net would only add confusing errors.
                return self.error(diag::NET_TYPE, net.start, Some(&id), msg);
            }
        }
        self.net_read = true;
        let mut once = Once::default();
        let mut first_page = true;
        for c in &net.children {
            match c.name.as_str() {
                "name" => {
                    if self.once(&mut once, c, Kind::Net, &id) {
                        self.net_name = c.child("text").map(|t| t.text.clone()).unwrap_or_default();
                        let extras = self.label_extras(c);
                        put_label(&mut self.layout.net, "name", extras);
                    }
                }
                "page" => {
                    self.page(c, first_page);
                    first_page = false;
                }
                "toolspecific" if is_ours(c) => self.net_tool(c, &id, &mut once),
                _ if self.node(c) => {}
                _ => self.layout.net.children.push(c.raw(self.src).to_string()),
            }
        }
    }

    /// Reads `el` if it is a place, transition, arc or reference node.
    fn node(&mut self, el: &Element) -> bool {
        match el.name.as_str() {
            "place" => self.place(el),
            "transition" => self.transition(el),
            "arc" => self.arc(el),
            "referencePlace" => self.reference(el, Kind::RefPlace),
            "referenceTransition" => self.reference(el, Kind::RefTransition),
            _ => return false,
        }
        true
    }

    fn page(&mut self, page: &Element, keep: bool) {
        let id = self.node_id(page, Kind::Page);
        if keep {
            self.layout.page_id = id;
        }
        for c in &page.children {
            if c.name == "page" {
                // Nesting is bounded by xml::MAX_DEPTH, so this recursion is too.
                self.page(c, false);
            } else if !self.node(c) && keep {
                self.layout.page.children.push(c.raw(self.src).to_string());
            }
        }
    }

    /// The element's id, registered; `None` (after a diagnostic) when it is missing or taken.
    fn node_id(&mut self, el: &Element, kind: Kind) -> Option<String> {
        let Some(id) = el.attr("id") else {
            let msg = format!(
                "this `<{}>` has no `id` attribute; every {} needs an id of its own",
                el.name,
                kind.noun()
            );
            self.error(diag::MISSING_ATTRIBUTE, el.start, None, msg);
            return None;
        };
        if let Some(first) = self.ids.get(id) {
            let (line, column) = self.lines.position(first.at);
            let msg = format!(
                "id `{}` of this {} is already the id of the {} at line {line}, column {column}; \
                 every element needs its own id",
                shown(id),
                kind.noun(),
                first.kind.noun()
            );
            let first = (first.at, "the element that has this id first");
            self.error_with(diag::DUPLICATE_ID, el.start, Some(id), msg, first);
            return None;
        }
        self.ids.insert(id.to_string(), Node { kind, at: el.start });
        Some(id.to_string())
    }

    /// True the first time a once-only child is seen; reports it otherwise.
    fn once(&mut self, once: &mut Once, c: &Element, kind: Kind, id: &str) -> bool {
        if once.first(&c.name) {
            return true;
        }
        let msg = format!(
            "{} `{}` has a second `<{}>`; give it once",
            kind.noun(),
            shown(id),
            c.name
        );
        self.error(diag::REPEATED, c.start, Some(id), msg);
        false
    }

    /// A label's children other than `<text>`, verbatim.
    fn label_extras(&self, label: &Element) -> Vec<String> {
        label
            .children
            .iter()
            .filter(|c| c.name != "text")
            .map(|c| c.raw(self.src).to_string())
            .collect()
    }

    /// A count label such as `<initialMarking><text>3</text></initialMarking>`.
    fn count_label(&mut self, label: &Element, kind: Kind, id: &str, hint: &str) -> Option<u32> {
        let what = match label.name.as_str() {
            "initialMarking" => "initial marking",
            "inscription" => "inscription",
            other => other,
        };
        let Some(text) = label.child("text") else {
            let msg = format!(
                "{} `{}`: its `<{}>` has no `<text>`; write <{2}><text>N</text></{2}>",
                kind.noun(),
                shown(id),
                label.name
            );
            self.error(diag::NUMBER, label.start, Some(id), msg);
            return None;
        };
        self.count(&text.text, text.start, kind, id, what, hint)
    }

    fn count(
        &mut self,
        text: &str,
        at: usize,
        kind: Kind,
        id: &str,
        what: &str,
        hint: &str,
    ) -> Option<u32> {
        match parse_count(text) {
            Ok(n) => Some(n),
            Err(why) => {
                let msg = format!(
                    "{} `{}`: {what} `{}` {why}; {hint}",
                    kind.noun(),
                    shown(id),
                    shown(text.trim())
                );
                self.error(diag::NUMBER, at, Some(id), msg);
                None
            }
        }
    }

    fn place(&mut self, el: &Element) {
        let Some(id) = self.node_id(el, Kind::Place) else {
            return;
        };
        let mut p = PlaceRead {
            spec: PlaceSpec {
                id: id.clone(),
                ..Default::default()
            },
            explicit_signal: false,
            explicit_capacity: false,
            at: el.start,
        };
        let mut extras = Extras::default();
        let mut once = Once::default();
        for c in &el.children {
            match c.name.as_str() {
                "name" => {
                    if self.once(&mut once, c, Kind::Place, &id) {
                        p.spec.name = c.child("text").map(|t| t.text.clone()).unwrap_or_default();
                        put_label(&mut extras, "name", self.label_extras(c));
                    }
                }
                "initialMarking" => {
                    if self.once(&mut once, c, Kind::Place, &id) {
                        let hint = "a marking is a whole number of tokens, 0 or more";
                        p.spec.initial = self.count_label(c, Kind::Place, &id, hint).unwrap_or(0);
                        put_label(&mut extras, "initialMarking", self.label_extras(c));
                    }
                }
                "toolspecific" if is_ours(c) => {
                    for item in self.tool_items(c, Kind::Place, &id, vocab::PLACE_ITEMS, &mut once)
                    {
                        let text = item.text.trim();
                        match item.name.as_str() {
                            "capacity" => {
                                let hint = "a capacity is a whole number from 1";
                                p.spec.capacity = self.count(
                                    &item.text,
                                    item.start,
                                    Kind::Place,
                                    &id,
                                    "capacity",
                                    hint,
                                );
                                p.explicit_capacity = true;
                            }
                            dir => {
                                p.explicit_signal = true;
                                let Some(name) = self.signal_name(item, text, &id) else {
                                    continue;
                                };
                                let direction = if dir == "input" {
                                    p.spec.input = Some(name.clone());
                                    SignalDirection::Input
                                } else {
                                    p.spec.output = Some(name.clone());
                                    SignalDirection::Output
                                };
                                self.uses.push(SignalUse {
                                    stage: 1,
                                    name,
                                    direction,
                                    declared: None,
                                    at: item.start,
                                    element: id.clone(),
                                });
                            }
                        }
                    }
                }
                _ => extras.children.push(c.raw(self.src).to_string()),
            }
        }
        self.keep(&id, extras);
        self.places.push(p);
    }

    fn keep(&mut self, id: &str, extras: Extras) {
        if !extras.is_empty() {
            self.layout.elements.insert(id.to_string(), extras);
        }
    }

    fn transition(&mut self, el: &Element) {
        let Some(id) = self.node_id(el, Kind::Transition) else {
            return;
        };
        let mut t = TransitionRead {
            id: id.clone(),
            name: String::new(),
            name_at: el.start,
            guard: None,
            deadline: None,
        };
        let mut extras = Extras::default();
        let mut once = Once::default();
        for c in &el.children {
            match c.name.as_str() {
                "name" => {
                    if self.once(&mut once, c, Kind::Transition, &id) {
                        t.name = c.child("text").map(|t| t.text.clone()).unwrap_or_default();
                        t.name_at = c.start;
                        put_label(&mut extras, "name", self.label_extras(c));
                    }
                }
                "toolspecific" if is_ours(c) => {
                    let items = self.tool_items(
                        c,
                        Kind::Transition,
                        &id,
                        vocab::TRANSITION_ITEMS,
                        &mut once,
                    );
                    for item in items {
                        if item.name == "deadline" {
                            match time::parse_duration(&item.text) {
                                Ok(d) => t.deadline = Some(d),
                                Err(e) => {
                                    // `e` names the text and says what it is not.
                                    let msg = format!("transition `{}`: deadline: {e}", shown(&id));
                                    self.error(diag::DELAY, item.start, Some(&id), msg);
                                }
                            }
                            continue;
                        }
                        // An unparsable guard still counts as given: the name must not
                        // stand in for it under SIPN naming and add a second error.
                        t.guard = Some(
                            self.guard(&item.text, item.start, &id, "guard", "")
                                .unwrap_or(Expr::Const(true)),
                        );
                    }
                }
                _ => extras.children.push(c.raw(self.src).to_string()),
            }
        }
        self.keep(&id, extras);
        self.transitions.push(t);
    }

    /// Parses a guard, recording the signals it reads.
    fn guard(
        &mut self,
        text: &str,
        at: usize,
        id: &str,
        what: &str,
        why: &str,
    ) -> Option<Expr<String>> {
        let result = match vocab::guard_too_complex(text) {
            Some(reason) => Err(reason),
            None => guard::parse(text).map_err(|e| format!("column {}: {}", e.column, e.message)),
        };
        match result {
            Ok(expr) => {
                let mut names = Vec::new();
                expr.visit_signals(&mut |s: &String| names.push(s.clone()));
                for name in names {
                    self.uses.push(SignalUse {
                        stage: 2,
                        name,
                        direction: SignalDirection::Input,
                        declared: None,
                        at,
                        element: id.to_string(),
                    });
                }
                Some(expr)
            }
            Err(reason) => {
                let msg = format!(
                    "transition `{}`: {what} `{}` is not valid{why}: {reason}",
                    shown(id),
                    shown(text.trim())
                );
                self.error(diag::GUARD, at, Some(id), msg);
                None
            }
        }
    }

    fn arc(&mut self, el: &Element) {
        let Some(id) = self.node_id(el, Kind::Arc) else {
            return;
        };
        let mut ends = [None, None];
        for (slot, end) in ends.iter_mut().zip(["source", "target"]) {
            *slot = el.attr(end).map(str::to_string);
            if slot.is_none() {
                let msg = format!(
                    "arc `{}` has no `{end}` attribute; give the id of the place or transition \
                     it starts from or goes to",
                    shown(&id)
                );
                self.error(diag::MISSING_ATTRIBUTE, el.start, Some(&id), msg);
            }
        }
        let mut weight = 1;
        let mut delay = None;
        let mut kinds: Vec<(&'static str, String, usize)> = Vec::new();
        if let Some(t) = el.attr("type") {
            kinds.push(("its `type` attribute", t.to_string(), el.start));
        }
        let mut extras = Extras::default();
        let mut once = Once::default();
        // petriplc's `<type>` is checked apart from PNML's: the two may agree.
        let mut ours = Once::default();
        for c in &el.children {
            match c.name.as_str() {
                "inscription" => {
                    if self.once(&mut once, c, Kind::Arc, &id) {
                        let hint = "an arc weight is a whole number from 1";
                        weight = self.count_label(c, Kind::Arc, &id, hint).unwrap_or(1);
                        put_label(&mut extras, "inscription", self.label_extras(c));
                    }
                }
                "type" if self.once(&mut once, c, Kind::Arc, &id) => {
                    let value = c
                        .attr("value")
                        .map_or_else(|| c.text.clone(), str::to_string);
                    kinds.push(("`<type>`", value, c.start));
                }
                "arctype" if self.once(&mut once, c, Kind::Arc, &id) => {
                    let value = c.child("text").map_or(&c.text, |t| &t.text).clone();
                    kinds.push(("`<arctype>`", value, c.start));
                }
                "type" | "arctype" => {}
                "toolspecific" if is_ours(c) => {
                    for item in self.tool_items(c, Kind::Arc, &id, vocab::ARC_ITEMS, &mut ours) {
                        if item.name == "type" {
                            let value = item
                                .attr("value")
                                .map_or_else(|| item.text.clone(), str::to_string);
                            kinds.push(("petriplc's `<type>`", value, item.start));
                        } else {
                            match time::parse_duration(&item.text) {
                                Ok(d) => delay = Some(d),
                                Err(e) => {
                                    let msg = format!("arc `{}`: delay: {e}", shown(&id));
                                    self.error(diag::DELAY, item.start, Some(&id), msg);
                                }
                            }
                        }
                    }
                }
                _ => extras.children.push(c.raw(self.src).to_string()),
            }
        }
        let kind = self.arc_kind(&id, &kinds);
        self.keep(&id, extras);
        if let [Some(source), Some(target)] = ends {
            self.arcs.push(ArcSpec {
                id,
                source,
                target,
                kind,
                weight,
                delay,
            });
        }
    }

    /// The arc's kind from every spelling given, which must agree.
    fn arc_kind(&mut self, id: &str, kinds: &[(&'static str, String, usize)]) -> ArcKind {
        let mut agreed: Option<(ArcKind, &str, &str)> = None;
        for (how, value, at) in kinds {
            let kind = match value.trim().to_ascii_lowercase().as_str() {
                "normal" => ArcKind::Normal,
                "inhibitor" => ArcKind::Inhibitor,
                "read" | "test" => ArcKind::Read,
                "reset" => {
                    let msg = format!(
                        "arc `{}` is a reset arc; reset arcs are not supported (petriplc reads \
                         normal, read and inhibitor arcs)",
                        shown(id)
                    );
                    self.error(diag::RESET_ARC, *at, Some(id), msg);
                    continue;
                }
                _ => {
                    let msg = format!(
                        "arc `{}`: arc type `{}` ({how}) is unknown; use normal, read (or test) \
                         or inhibitor",
                        shown(id),
                        shown(value.trim())
                    );
                    self.error(diag::ARC_TYPE, *at, Some(id), msg);
                    continue;
                }
            };
            match agreed {
                None => agreed = Some((kind, how, value)),
                Some((k, first_how, first_value)) if k != kind => {
                    let msg = format!(
                        "arc `{}`: {first_how} says `{}` but {how} says `{}`; give the arc one type",
                        shown(id),
                        shown(first_value.trim()),
                        shown(value.trim())
                    );
                    self.error(diag::ARC_TYPE_CONFLICT, *at, Some(id), msg);
                }
                Some(_) => {}
            }
        }
        agreed.map_or(ArcKind::Normal, |(k, _, _)| k)
    }

    fn reference(&mut self, el: &Element, kind: Kind) {
        let Some(id) = self.node_id(el, kind) else {
            return;
        };
        match el.attr("ref") {
            Some(target) => self.refs.push(RefRead {
                id,
                target: target.to_string(),
                kind,
            }),
            None => {
                let msg = format!(
                    "{} `{}` has no `ref` attribute; give the id of the node it stands for",
                    kind.noun(),
                    shown(&id)
                );
                self.error(diag::MISSING_ATTRIBUTE, el.start, Some(&id), msg);
            }
        }
    }
}

mod build;
mod petriplc;
#[cfg(test)]
mod tests;
