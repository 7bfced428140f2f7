//! Writing: a [`Net`] (and the [`Layout`] it was read with) as PNML 2009 that validates
//! against the shipped grammars and reads back as the identical net.

use std::collections::HashSet;

use petriplc_net::time::format_iec;
use petriplc_net::{ArcDirection, ArcKind, Evolution, Net, StepRule};

use crate::layout::{Extras, Layout};
use crate::vocab;

/// Writes `net` as a PNML document.
pub(crate) fn write(net: &Net, layout: Option<&Layout>) -> String {
    let empty = Layout::default();
    let layout = layout.unwrap_or(&empty);
    let no_extras = Extras::default();
    let extras = |id: &str| layout.element(id).unwrap_or(&no_extras);
    // Only the inhibitorptnet grammar knows arc types, and it wants one on every arc.
    let special = net.arcs().iter().any(|a| a.kind != ArcKind::Normal);
    let net_type = if special {
        vocab::INHIBITOR_PTNET
    } else {
        vocab::PTNET
    };

    let mut w = Out::default();
    w.line(0, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>");
    w.line(0, &format!("<pnml xmlns=\"{}\">", vocab::PNML_NS));
    w.line(
        1,
        &format!("<net id=\"{}\" type=\"{net_type}\">", attr(&net.id)),
    );
    if !net.name.is_empty() || !layout.net.label("name").is_empty() {
        w.label(2, "name", &net.name, layout.net.label("name"));
    }
    let mut tool = Vec::new();
    if net.step != StepRule::default() {
        tool.push(format!("<step>{}</step>", net.step));
    }
    if net.evolve != Evolution::default() {
        tool.push(format!("<evolve>{}</evolve>", net.evolve));
    }
    // Declaring every signal, in table order, makes the table read back identical.
    for s in net.signals() {
        tool.push(format!(
            "<signal name=\"{}\" direction=\"{}\" type=\"{}\"/>",
            attr(&s.name),
            s.direction,
            s.ty
        ));
    }
    w.toolspecific(2, &tool);
    w.raw(2, &layout.net.children);

    w.line(2, &format!("<page id=\"{}\">", attr(&page_id(net, layout))));
    w.raw(3, &layout.page.children);
    for p in net.places() {
        let x = extras(&p.id);
        let mut b = Out::default();
        // A label that only carries graphics is still written, to keep them.
        if !p.name.is_empty() || !x.label("name").is_empty() {
            b.label(4, "name", &p.name, x.label("name"));
        }
        if p.initial != 0 || !x.label("initialMarking").is_empty() {
            b.label(
                4,
                "initialMarking",
                &p.initial.to_string(),
                x.label("initialMarking"),
            );
        }
        b.raw(4, &x.children);
        let mut tool = Vec::new();
        if let Some(s) = p.output {
            tool.push(format!("<output>{}</output>", text(&net.signal(s).name)));
        }
        if let Some(s) = p.input {
            tool.push(format!("<input>{}</input>", text(&net.signal(s).name)));
        }
        if let Some(c) = p.capacity {
            tool.push(format!("<capacity>{c}</capacity>"));
        }
        b.toolspecific(4, &tool);
        w.element(3, &format!("<place id=\"{}\"", attr(&p.id)), "place", b);
    }
    for (i, t) in net.transitions().iter().enumerate() {
        let x = extras(&t.id);
        let mut b = Out::default();
        if !t.name.is_empty() || !x.label("name").is_empty() {
            b.label(4, "name", &t.name, x.label("name"));
        }
        b.raw(4, &x.children);
        let mut tool = Vec::new();
        if !t.guard.is_true() {
            tool.push(format!(
                "<guard>{}</guard>",
                text(&net.guard_text(i.into()))
            ));
        }
        if let Some(d) = t.deadline {
            tool.push(format!("<deadline>{}</deadline>", format_iec(d)));
        }
        b.toolspecific(4, &tool);
        w.element(
            3,
            &format!("<transition id=\"{}\"", attr(&t.id)),
            "transition",
            b,
        );
    }
    for a in net.arcs() {
        let x = extras(&a.id);
        let place = &net.place(a.place).id;
        let transition = &net.transition(a.transition).id;
        let (source, target) = match a.direction {
            ArcDirection::PlaceToTransition => (place, transition),
            ArcDirection::TransitionToPlace => (transition, place),
        };
        let mut b = Out::default();
        if a.weight != 1 || !x.label("inscription").is_empty() {
            b.label(
                4,
                "inscription",
                &a.weight.to_string(),
                x.label("inscription"),
            );
        }
        if special {
            b.line(4, &format!("<arctype>{}</arctype>", a.kind));
        }
        b.raw(4, &x.children);
        let mut tool = Vec::new();
        if a.kind != ArcKind::Normal {
            // The issue's own spelling, valid inside toolspecific whatever the grammar.
            tool.push(format!("<type value=\"{}\"/>", a.kind));
        }
        if let Some(d) = a.delay {
            tool.push(format!("<delay>{}</delay>", format_iec(d)));
        }
        b.toolspecific(4, &tool);
        let open = format!(
            "<arc id=\"{}\" source=\"{}\" target=\"{}\"",
            attr(&a.id),
            attr(source),
            attr(target)
        );
        w.element(3, &open, "arc", b);
    }
    w.line(2, "</page>");
    w.line(1, "</net>");
    w.line(0, "</pnml>");
    w.0
}

/// The layout's page id, unless an element of the (possibly edited) net now has it.
fn page_id(net: &Net, layout: &Layout) -> String {
    let mut taken: HashSet<&str> = HashSet::new();
    taken.insert(&net.id);
    taken.extend(net.places().iter().map(|p| p.id.as_str()));
    taken.extend(net.transitions().iter().map(|t| t.id.as_str()));
    taken.extend(net.arcs().iter().map(|a| a.id.as_str()));
    if let Some(id) = layout.page_id.as_deref().filter(|id| !taken.contains(id)) {
        return id.to_string();
    }
    (0..)
        .map(|i| format!("page{i}"))
        .find(|id| !taken.contains(id.as_str()))
        .unwrap_or_default()
}

#[derive(Default)]
struct Out(String);

impl Out {
    fn line(&mut self, indent: usize, s: &str) {
        for _ in 0..indent {
            self.0.push_str("  ");
        }
        self.0.push_str(s);
        self.0.push('\n');
    }

    fn label(&mut self, indent: usize, tag: &str, value: &str, extras: &[String]) {
        let line = format!(
            "<{tag}><text>{}</text>{}</{tag}>",
            text(value),
            extras.concat()
        );
        self.line(indent, &line);
    }

    /// Writes `open` (a start tag without its `>`) with `body`, or as an empty element.
    fn element(&mut self, indent: usize, open: &str, tag: &str, body: Out) {
        if body.0.is_empty() {
            self.line(indent, &format!("{open}/>"));
        } else {
            self.line(indent, &format!("{open}>"));
            self.0.push_str(&body.0);
            self.line(indent, &format!("</{tag}>"));
        }
    }

    fn raw(&mut self, indent: usize, fragments: &[String]) {
        for f in fragments {
            self.line(indent, f);
        }
    }

    fn toolspecific(&mut self, indent: usize, items: &[String]) {
        if items.is_empty() {
            return;
        }
        self.line(
            indent,
            &format!(
                "<toolspecific tool=\"{}\" version=\"{}\">",
                vocab::TOOL,
                vocab::VERSION
            ),
        );
        for item in items {
            self.line(indent + 1, item);
        }
        self.line(indent, "</toolspecific>");
    }
}

/// XML 1.0 cannot carry most control characters at all, escaped or not.
fn representable(c: char) -> char {
    if crate::xml::allowed(c) {
        c
    } else {
        char::REPLACEMENT_CHARACTER
    }
}

/// Escapes character data; `\r` as a reference because parsers turn a raw one into `\n`.
fn text(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars().map(representable) {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '\r' => out.push_str("&#13;"),
            c => out.push(c),
        }
    }
    out
}

/// Escapes an attribute value; white space as references, which attribute normalisation
/// would otherwise turn into spaces.
fn attr(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars().map(representable) {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\t' => out.push_str("&#9;"),
            '\n' => out.push_str("&#10;"),
            '\r' => out.push_str("&#13;"),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use petriplc_net::guard::parse;
    use petriplc_net::{
        ArcSpec, NetBuilder, PlaceSpec, SignalDirection, SignalType, TransitionSpec,
    };

    use super::*;

    /// Builds a net with `build` and compares what is written with `expect`.
    fn check(build: impl FnOnce(&mut NetBuilder), expect: &str) {
        let mut b = NetBuilder::new("n", "");
        build(&mut b);
        let net = b.build().expect("the test net is valid");
        let got = write(&net, None);
        assert_eq!(got.trim(), expect.trim(), "\n--- got ---\n{got}");
    }

    fn place(id: &str, initial: u32) -> PlaceSpec {
        PlaceSpec {
            id: id.into(),
            name: id.to_uppercase(),
            initial,
            ..Default::default()
        }
    }

    fn transition(id: &str, guard: &str) -> TransitionSpec {
        TransitionSpec {
            id: id.into(),
            name: String::new(),
            guard: parse(guard).unwrap(),
        }
    }

    fn arc(id: &str, source: &str, target: &str, kind: ArcKind, weight: u32) -> ArcSpec {
        ArcSpec {
            id: id.into(),
            source: source.into(),
            target: target.into(),
            kind,
            weight,
            delay: None,
        }
    }

    #[test]
    fn writes_a_plain_net_without_defaults() {
        check(
            |b| {
                b.place(place("p1", 2));
                b.place(place("page0", 0));
                b.transition(transition("t1", ""));
                b.arc(arc("a1", "p1", "t1", ArcKind::Normal, 1));
                b.arc(arc("a2", "t1", "page0", ArcKind::Normal, 3));
            },
            r#"
<?xml version="1.0" encoding="UTF-8"?>
<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml">
  <net id="n" type="http://www.pnml.org/version-2009/grammar/ptnet">
    <page id="page1">
      <place id="p1">
        <name><text>P1</text></name>
        <initialMarking><text>2</text></initialMarking>
      </place>
      <place id="page0">
        <name><text>PAGE0</text></name>
      </place>
      <transition id="t1"/>
      <arc id="a1" source="p1" target="t1"/>
      <arc id="a2" source="t1" target="page0">
        <inscription><text>3</text></inscription>
      </arc>
    </page>
  </net>
</pnml>"#,
        );
    }

    #[test]
    fn writes_arc_types_on_every_arc_of_a_special_net() {
        check(
            |b| {
                b.place(place("p", 1));
                b.place(place("q", 0));
                b.transition(transition("t", ""));
                b.arc(arc("a1", "p", "t", ArcKind::Normal, 1));
                b.arc(arc("a2", "q", "t", ArcKind::Inhibitor, 2));
                b.arc(arc("a3", "p", "t", ArcKind::Read, 1));
            },
            r#"
<?xml version="1.0" encoding="UTF-8"?>
<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml">
  <net id="n" type="http://www.pnml.org/version-2009/extensions/inhibitorptnet">
    <page id="page0">
      <place id="p">
        <name><text>P</text></name>
        <initialMarking><text>1</text></initialMarking>
      </place>
      <place id="q">
        <name><text>Q</text></name>
      </place>
      <transition id="t"/>
      <arc id="a1" source="p" target="t">
        <arctype>normal</arctype>
      </arc>
      <arc id="a2" source="q" target="t">
        <inscription><text>2</text></inscription>
        <arctype>inhibitor</arctype>
        <toolspecific tool="petriplc" version="1">
          <type value="inhibitor"/>
        </toolspecific>
      </arc>
      <arc id="a3" source="p" target="t">
        <arctype>read</arctype>
        <toolspecific tool="petriplc" version="1">
          <type value="read"/>
        </toolspecific>
      </arc>
    </page>
  </net>
</pnml>"#,
        );
    }

    #[test]
    fn writes_petriplc_data_where_it_is_not_the_default() {
        check(
            |b| {
                b.step(StepRule::Sequential).evolve(Evolution::UntilStable);
                b.signal("Level", SignalDirection::Input, SignalType::Int);
                b.place(PlaceSpec {
                    output: Some("L1".into()),
                    capacity: Some(1),
                    ..place("p", 1)
                });
                b.place(PlaceSpec {
                    input: Some("B1".into()),
                    ..place("i", 0)
                });
                let t = b.transition(TransitionSpec {
                    name: "fill & <go>".into(),
                    ..transition("t", "B1 & !(Level >= 3)")
                });
                b.deadline(t, Duration::from_secs(2));
                b.arc(ArcSpec {
                    delay: Some(Duration::from_millis(1500)),
                    ..arc("a", "p", "t", ArcKind::Normal, 1)
                });
                b.arc(arc("b", "i", "t", ArcKind::Read, 1));
            },
            r#"
<?xml version="1.0" encoding="UTF-8"?>
<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml">
  <net id="n" type="http://www.pnml.org/version-2009/extensions/inhibitorptnet">
    <toolspecific tool="petriplc" version="1">
      <step>sequential</step>
      <evolve>until-stable</evolve>
      <signal name="Level" direction="input" type="int"/>
      <signal name="L1" direction="output" type="bool"/>
      <signal name="B1" direction="input" type="bool"/>
    </toolspecific>
    <page id="page0">
      <place id="p">
        <name><text>P</text></name>
        <initialMarking><text>1</text></initialMarking>
        <toolspecific tool="petriplc" version="1">
          <output>L1</output>
          <capacity>1</capacity>
        </toolspecific>
      </place>
      <place id="i">
        <name><text>I</text></name>
        <toolspecific tool="petriplc" version="1">
          <input>B1</input>
        </toolspecific>
      </place>
      <transition id="t">
        <name><text>fill &amp; &lt;go&gt;</text></name>
        <toolspecific tool="petriplc" version="1">
          <guard>B1 AND NOT (Level &gt;= 3)</guard>
          <deadline>T#2s</deadline>
        </toolspecific>
      </transition>
      <arc id="a" source="p" target="t">
        <arctype>normal</arctype>
        <toolspecific tool="petriplc" version="1">
          <delay>T#1s500ms</delay>
        </toolspecific>
      </arc>
      <arc id="b" source="i" target="t">
        <arctype>read</arctype>
        <toolspecific tool="petriplc" version="1">
          <type value="read"/>
        </toolspecific>
      </arc>
    </page>
  </net>
</pnml>"#,
        );
    }
}

#[cfg(test)]
mod escaping {
    use super::*;

    fn check(input: &str, expect: &str) {
        assert_eq!(
            format!("{} | {}", text(input), attr(input)),
            expect,
            "{input:?}"
        );
    }

    #[test]
    fn escapes_text_and_attributes() {
        check("a<b>&\"c'", "a&lt;b&gt;&amp;\"c' | a&lt;b&gt;&amp;&quot;c'");
        check("x\ty\nz\r", "x\ty\nz&#13; | x&#9;y&#10;z&#13;");
        check(
            "nul\u{0}\u{fffe}é",
            "nul\u{fffd}\u{fffd}é | nul\u{fffd}\u{fffd}é",
        );
    }
}
