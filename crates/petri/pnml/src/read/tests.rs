//! Reader tests: each module has one `check(input, expect)` that renders either the
//! diagnostics exactly as a user sees them or a one-line-per-element summary of the net.

use std::fmt::Write as _;

use petriplc_net::Net;

use crate::{read_str, Document, Naming, PnmlError, ReadOptions};

/// Line 1 of every test document; the body starts on line 2 at column 1.
const HEAD: &str = r#"<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml"><net id="n" type="http://www.pnml.org/version-2009/grammar/ptnet"><page id="pg">"#;

/// A document whose page holds `body` (from line 2).
fn page(body: &str) -> String {
    format!("{HEAD}\n{}\n</page></net></pnml>", body.trim())
}

/// A document whose net holds `body` (from line 2) before an empty page.
fn net(body: &str) -> String {
    let head = HEAD.trim_end_matches(r#"<page id="pg">"#);
    format!("{head}\n{}\n<page id=\"pg\"/></net></pnml>", body.trim())
}

fn summary(net: &Net) -> String {
    let mut s = format!(
        "net {} {:?} {} {}\n",
        net.id, net.name, net.step, net.evolve
    );
    for sig in net.signals() {
        let _ = writeln!(s, "signal {} {} {}", sig.direction, sig.ty, sig.name);
    }
    for p in net.places() {
        let _ = write!(s, "place {} {:?}", p.id, p.name);
        if p.initial != 0 {
            let _ = write!(s, " initial={}", p.initial);
        }
        if let Some(c) = p.capacity {
            let _ = write!(s, " capacity={c}");
        }
        if let Some(o) = p.output {
            let _ = write!(s, " output={}", net.signal(o).name);
        }
        if let Some(i) = p.input {
            let _ = write!(s, " input={}", net.signal(i).name);
        }
        s.push('\n');
    }
    for (i, t) in net.transitions().iter().enumerate() {
        let _ = write!(s, "transition {} {:?}", t.id, t.name);
        if !t.guard.is_true() {
            let _ = write!(s, " guard=`{}`", net.guard_text(i.into()));
        }
        s.push('\n');
    }
    for a in net.arcs() {
        let (p, t) = (&net.place(a.place).id, &net.transition(a.transition).id);
        let ends = match a.direction {
            petriplc_net::ArcDirection::PlaceToTransition => format!("{p}->{t}"),
            petriplc_net::ArcDirection::TransitionToPlace => format!("{t}->{p}"),
        };
        let _ = write!(s, "arc {} {ends} {}", a.id, a.kind);
        if a.weight != 1 {
            let _ = write!(s, " weight={}", a.weight);
        }
        if let Some(d) = a.delay {
            let _ = write!(s, " delay={}", petriplc_net::time::format_iec(d));
        }
        s.push('\n');
    }
    s
}

/// The net's summary, or each diagnostic as displayed followed by its element id.
fn render(result: Result<Document, PnmlError>) -> String {
    match result {
        Ok(doc) => summary(&doc.net),
        Err(e) => {
            let lines: Vec<String> = e
                .diagnostics()
                .iter()
                .map(|d| {
                    // The element after the diagnostic's own line, before its notes.
                    let shown = d.to_string();
                    let (line, notes) = shown.split_once('\n').unwrap_or((&shown, ""));
                    let el = d.element.as_deref().unwrap_or("-");
                    if notes.is_empty() {
                        format!("{line} [{el}]")
                    } else {
                        format!("{line} [{el}]\n{notes}")
                    }
                })
                .collect();
            lines.join("\n")
        }
    }
}

fn read(input: &str, naming: Naming) -> String {
    render(read_str(input, "t.pnml", &ReadOptions { naming }))
}

fn assert_same(got: &str, expect: &str) {
    assert_eq!(got.trim(), expect.trim(), "\n--- got ---\n{got}\n");
}

mod documents {
    use super::*;

    fn check(input: &str, expect: &str) {
        assert_same(&read(input, Naming::Plain), expect);
    }

    #[test]
    fn reads_a_plain_net() {
        check(
            &page(
                r#"
<place id="p1"><name><text>P1</text></name><initialMarking><text> 2 </text></initialMarking></place>
<place id="p2"/>
<transition id="t1"><name><text>T1</text></name></transition>
<arc id="a1" source="p1" target="t1"><inscription><text>+02</text></inscription></arc>
<arc id="a2" source="t1" target="p2"/>"#,
            ),
            r#"
net n "" maximal-step one-pass
place p1 "P1" initial=2
place p2 ""
transition t1 "T1"
arc a1 p1->t1 normal weight=2
arc a2 t1->p2 normal"#,
        );
    }

    #[test]
    fn rejects_what_is_not_a_pnml_net() {
        check(
            "hello",
            "t.pnml:1:1: error[P001]: text outside the root element [-]",
        );
        check(
            "<pnml>\n  <net id=\"n\">\n</pnml>",
            "t.pnml:3:1: error[P001]: malformed XML: ill-formed document: expected `</net>`, but `</pnml>` was found [-]",
        );
        check(
            "<pnml><net>",
            "t.pnml:1:7: error[P001]: `<net>` is never closed [-]",
        );
        check(
            "<html/>",
            "t.pnml:1:1: error[P002]: the root element is `<html>`, not `<pnml>`; this is not a PNML file [-]",
        );
        check(
            "<pnml/>",
            "t.pnml:1:1: error[P002]: `<pnml>` holds no `<net>`; a PNML file describes at least one net [-]",
        );
        check(
            "<pnml>\n<net id=\"a\" type=\"ptnet\"><page id=\"pa\"/></net>\n<net id=\"b\" type=\"ptnet\"/>\n<net/>\n</pnml>",
            "t.pnml:3:1: error[P003]: a second `<net>` (`b`); petriplc reads one net per file, so split the file [b]\n\
             t.pnml:4:1: error[P003]: a second `<net>`; petriplc reads one net per file, so split the file [-]",
        );
    }

    #[test]
    fn rejects_other_net_types() {
        check(
            r#"<pnml><net id="s" type="http://www.pnml.org/version-2009/grammar/symmetricnet"><place/></net></pnml>"#,
            "t.pnml:1:7: error[P004]: net `s` has type `http://www.pnml.org/version-2009/grammar/symmetricnet`; \
             petriplc reads place/transition nets (type http://www.pnml.org/version-2009/grammar/ptnet or an \
             extension such as http://www.pnml.org/version-2009/extensions/inhibitorptnet) [s]",
        );
        check(
            r#"<pnml><net><page id="x"/></net></pnml>"#,
            "t.pnml:1:7: error[P005]: this `<net>` has no `id` attribute; every net needs an id of its own [-]\n\
             t.pnml:1:7: error[P005]: net `` has no `type` attribute; a P/T net has type=\"http://www.pnml.org/version-2009/grammar/ptnet\" []",
        );
    }

    #[test]
    fn reports_missing_and_duplicate_ids() {
        check(
            &page(
                r#"
<place id="p1"/>
<place/>
<transition id="p1"/>
<arc id="a1" target="p1"/>
<arc id="a2" source="p1"/>
<page id="pg"/>"#,
            ),
            "t.pnml:3:1: error[P005]: this `<place>` has no `id` attribute; every place needs an id of its own [-]\n\
             t.pnml:4:1: error[P006]: id `p1` of this transition is already the id of the place at line 2, column 1; every element needs its own id [p1]\n\
             t.pnml:2:1: note: the element that has this id first\n\
             t.pnml:5:1: error[P005]: arc `a1` has no `source` attribute; give the id of the place or transition it starts from or goes to [a1]\n\
             t.pnml:6:1: error[P005]: arc `a2` has no `target` attribute; give the id of the place or transition it starts from or goes to [a2]\n\
             t.pnml:7:1: error[P006]: id `pg` of this page is already the id of the page at line 1, column 127; every element needs its own id [pg]\n\
             t.pnml:1:127: note: the element that has this id first",
        );
    }

    #[test]
    fn reports_bad_arc_ends_at_the_arc() {
        check(
            &page(
                r#"
<place id="p1"/>
<place id="p2"/>
<transition id="t1"/>
<transition id="t2"/>
<arc id="a1" source="p1" target="nowhere"/>
<arc id="a2" source="p1" target="p2"/>
<arc id="a3" source="t1" target="t2"/>
<arc id="a4" source="pg" target="t1"/>"#,
            ),
            "t.pnml:6:1: error[P012]: arc `a1`: its target `nowhere` is not a place or transition of this net [a1]\n\
             t.pnml:7:1: error[P012]: arc `a2` joins two places (`p1` → `p2`); an arc joins a place and a transition [a2]\n\
             t.pnml:3:1: note: its target, also a place\n\
             t.pnml:8:1: error[P012]: arc `a3` joins two transitions (`t1` → `t2`); an arc joins a place and a transition [a3]\n\
             t.pnml:5:1: note: its target, also a transition\n\
             t.pnml:9:1: error[P012]: arc `a4`: its source `pg` is not a place or transition of this net [a4]",
        );
    }

    #[test]
    fn reports_bad_numbers() {
        check(
            &page(
                r#"
<place id="p1"><initialMarking><text>-3</text></initialMarking></place>
<place id="p2"><initialMarking><text>lots</text></initialMarking></place>
<place id="p3"><initialMarking><text>4294967296</text></initialMarking></place>
<place id="p4"><initialMarking/></place>
<place id="p5"><initialMarking><text>-0</text></initialMarking><initialMarking><text>1</text></initialMarking></place>
<transition id="t1"/>
<arc id="a1" source="p1" target="t1"><inscription><text>0</text></inscription></arc>
<arc id="a2" source="p2" target="t1"><inscription><text>1.5</text></inscription></arc>
<arc id="a3" source="p3" target="t1"><inscription><text>99999999999999999999</text></inscription></arc>
<arc id="a4" source="p4" target="t1"><inscription><text> </text></inscription></arc>"#,
            ),
            "t.pnml:2:32: error[P008]: place `p1`: initial marking `-3` is negative; a marking is a whole number of tokens, 0 or more [p1]\n\
             t.pnml:3:32: error[P008]: place `p2`: initial marking `lots` is not a whole number; a marking is a whole number of tokens, 0 or more [p2]\n\
             t.pnml:4:32: error[P008]: place `p3`: initial marking `4294967296` is larger than 4294967295; a marking is a whole number of tokens, 0 or more [p3]\n\
             t.pnml:5:16: error[P008]: place `p4`: its `<initialMarking>` has no `<text>`; write <initialMarking><text>N</text></initialMarking> [p4]\n\
             t.pnml:6:64: error[P016]: place `p5` has a second `<initialMarking>`; give it once [p5]\n\
             t.pnml:8:1: error[P018]: arc `a1` has weight 0; weights are whole numbers from 1 [a1]\n\
             t.pnml:9:51: error[P008]: arc `a2`: inscription `1.5` is not a whole number; an arc weight is a whole number from 1 [a2]\n\
             t.pnml:10:51: error[P008]: arc `a3`: inscription `99999999999999999999` is larger than 4294967295; an arc weight is a whole number from 1 [a3]\n\
             t.pnml:11:51: error[P008]: arc `a4`: inscription `` is empty; an arc weight is a whole number from 1 [a4]",
        );
    }

    #[test]
    fn reports_every_problem_in_file_order() {
        check(
            &page(
                r#"
<transition id="t1"><toolspecific tool="petriplc" version="1"><guard>B1 AND</guard></toolspecific></transition>
<place id="p1"><toolspecific tool="petriplc" version="1"><capacity>1</capacity></toolspecific><initialMarking><text>2</text></initialMarking></place>
<arc id="a1" source="p1" target="t1"><toolspecific tool="petriplc" version="1"><delay>soon</delay></toolspecific></arc>
<arc id="a2" source="t1" target="p9"/>"#,
            ),
            "t.pnml:2:63: error[P013]: transition `t1`: guard `B1 AND` is not valid: column 7: the guard ends where a signal name, TRUE, FALSE, NOT or `(` is expected [t1]\n\
             t.pnml:3:1: error[P019]: place `p1` starts with 2 tokens but its capacity is 1 [p1]\n\
             t.pnml:4:80: error[P014]: arc `a1`: delay: `soon` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`) [a1]\n\
             t.pnml:5:1: error[P012]: arc `a2`: its target `p9` is not a place or transition of this net [a2]",
        );
    }

    #[test]
    fn deadlines_are_read_and_checked() {
        check(
            &page(
                r#"
<transition id="t1"><toolspecific tool="petriplc" version="1"><deadline>later</deadline></toolspecific></transition>
<transition id="t2"><toolspecific tool="petriplc" version="1"><deadline>T#0s</deadline></toolspecific></transition>
<transition id="t3"><toolspecific tool="petriplc" version="1"><deadline>0.1</deadline><deadline>1</deadline></toolspecific></transition>
<place id="p"/>
<arc id="a" source="p" target="t3"><toolspecific tool="petriplc" version="1"><delay>T#200ms</delay></toolspecific></arc>"#,
            ),
            "t.pnml:2:63: error[P014]: transition `t1`: deadline: `later` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`) [t1]\n\
             t.pnml:3:1: error[P014]: transition `t2` has deadline 0; a deadline is a time greater than 0 (leave it out for none) [t2]\n\
             t.pnml:4:1: error[P014]: transition `t3` has a deadline of T#100ms but its arc `a` waits T#200ms; a transition cannot have to fire before its delays let it (make the deadline at least the longest delay) [t3]\n\
             t.pnml:4:87: error[P016]: transition `t3` has a second `<deadline>`; give it once [t3]",
        );
    }

    /// The deepest pages the XML reader lets through are read (the page walk is recursive)
    /// on a test thread's 2 MiB stack in a debug build, the smallest the readers run on.
    #[test]
    fn pages_as_deep_as_xml_allows_are_read() {
        let n = crate::xml::MAX_DEPTH - 6;
        let open: String = (0..n).map(|i| format!("<page id=\"q{i}\">")).collect();
        let text = page(&format!(
            "{open}<place id=\"deep\"><initialMarking><text>1</text></initialMarking></place>{}",
            "</page>".repeat(n)
        ));
        let doc = read_str(&text, "t.pnml", &ReadOptions::default()).unwrap();
        assert_eq!(doc.net.places()[0].id, "deep");
    }

    #[test]
    fn survives_hostile_nesting() {
        let deep = format!("<pnml>{}", "<page>".repeat(50_000));
        check(&deep, "t.pnml:1:1537: error[P001]: elements are nested more than 256 deep; PNML needs far fewer [-]");
        let parens = format!("{}B1{}", "(".repeat(10_000), ")".repeat(10_000));
        check(
            &page(&format!(
                r#"<transition id="t"><toolspecific tool="petriplc"><guard>{parens}</guard></toolspecific></transition>"#
            )),
            &format!(
                "t.pnml:2:50: error[P013]: transition `t`: guard `{}…` is not valid: it nests more than 64 parentheses and NOTs; simplify it [t]",
                "(".repeat(60)
            ),
        );
    }

    #[test]
    fn the_largest_allowed_guard_reads_and_writes_back() {
        let guard = format!(
            "{}B1{}{}",
            "(".repeat(30),
            ")".repeat(30),
            " AND NOT B1".repeat(482)
        );
        let input = page(&format!(
            r#"<transition id="t"><toolspecific tool="petriplc"><guard>{guard}</guard></toolspecific></transition>"#
        ));
        let doc =
            read_str(&input, "t.pnml", &ReadOptions::default()).expect("the guard is allowed");
        let written = crate::write_string(&doc.net, None);
        let back = read_str(&written, "w.pnml", &ReadOptions::default()).expect("reads back");
        assert_eq!(back.net, doc.net);
        check(&input.replace("</guard>", " AND B1</guard>"), "t.pnml:2:50: error[P013]: transition `t`: guard `((((((((((((((((((((((((((((((B1))))))))))))))))))))))))))))…` is not valid: it has more than 512 operators; simplify it [t]");
    }

    #[test]
    fn names_the_file_and_reads_files() {
        let dir = std::env::temp_dir().join(format!("petriplc-pnml-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let missing = dir.join("missing.pnml");
        let err = crate::read_file(&missing, &ReadOptions::default()).unwrap_err();
        // The cause is the error's source, printed once by `{:#}` chains (anyhow).
        assert_eq!(
            format!("{}: {}", err, std::error::Error::source(&err).unwrap()),
            format!("could not read `{}`: no such file", missing.display())
        );
        // A directory or a device is refused before anything is read (`/dev/zero` has no
        // end).
        let cause = |path: &std::path::Path| {
            let err = crate::read_file(path, &ReadOptions::default()).unwrap_err();
            std::error::Error::source(&err).unwrap().to_string()
        };
        assert_eq!(cause(&dir), "it is a directory; name a PNML file");
        assert_eq!(
            cause(std::path::Path::new("/dev/zero")),
            "it is a device, not a regular file; name a PNML file"
        );
        let latin1 = dir.join("latin1.pnml");
        std::fs::write(&latin1, b"<pnml>\n<net name=\"caf\xe9\"/></pnml>").unwrap();
        let err = crate::read_file(&latin1, &ReadOptions::default()).unwrap_err();
        assert_eq!(
            err.to_string(),
            format!(
                "{}:2:15: error[P001]: the file is not UTF-8 text; save it as UTF-8",
                latin1.display()
            )
        );
        let good = dir.join("good.pnml");
        std::fs::write(&good, format!("\u{feff}{}", page("<place id=\"p\"/>"))).unwrap();
        let doc = crate::read_file(&good, &ReadOptions::default()).unwrap();
        assert_eq!(doc.net.places().len(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

mod arcs {
    use super::*;

    /// Reads `arc` (on line 2) between place `p`, transition `t` and place `q`.
    fn check(arc: &str, expect: &str) {
        let nodes = r#"<place id="p"/><transition id="t"/><place id="q"/>"#;
        let doc = format!("{HEAD}{nodes}\n{arc}\n</page></net></pnml>");
        let got = read(&doc, Naming::Plain);
        let got = got
            .lines()
            .filter(|l| l.starts_with("arc") || l.contains("error"))
            .collect::<Vec<_>>();
        assert_same(&got.join("\n"), expect);
    }

    #[test]
    fn reads_every_spelling_of_arc_types() {
        check(
            r#"<arc id="a" source="p" target="t"/>"#,
            "arc a p->t normal",
        );
        check(
            r#"<arc id="a" source="p" target="t"><type value="inhibitor"/></arc>"#,
            "arc a p->t inhibitor",
        );
        check(
            r#"<arc id="a" source="p" target="t"><type value="read"/></arc>"#,
            "arc a p->t read",
        );
        check(
            r#"<arc id="a" source="p" target="t"><type value="test"/></arc>"#,
            "arc a p->t read",
        );
        check(
            r#"<arc id="a" source="p" target="t"><type value="normal"/></arc>"#,
            "arc a p->t normal",
        );
        check(
            r#"<arc id="a" source="p" target="t"><type>Inhibitor</type></arc>"#,
            "arc a p->t inhibitor",
        );
        check(
            r#"<arc id="a" source="p" target="t" type="inhibitor"/>"#,
            "arc a p->t inhibitor",
        );
        check(
            r#"<arc id="a" source="p" target="t" type="read"/>"#,
            "arc a p->t read",
        );
        check(
            r#"<arc id="a" source="p" target="t"><arctype>inhibitor</arctype></arc>"#,
            "arc a p->t inhibitor",
        );
        check(
            r#"<arc id="a" source="p" target="t"><arctype> read </arctype></arc>"#,
            "arc a p->t read",
        );
        check(
            r#"<arc id="a" source="p" target="t"><arctype><text>test</text></arctype></arc>"#,
            "arc a p->t read",
        );
        check(
            r#"<arc id="a" source="p" target="t"><toolspecific tool="petriplc" version="1"><type value="inhibitor"/></toolspecific></arc>"#,
            "arc a p->t inhibitor",
        );
        check(
            r#"<arc id="a" source="p" target="t" type="read"><arctype>read</arctype><toolspecific tool="petriplc" version="1"><type value="read"/></toolspecific></arc>"#,
            "arc a p->t read",
        );
        check(
            r#"<arc id="a" source="p" target="t"><inscription><text>3</text></inscription><arctype>inhibitor</arctype></arc>"#,
            "arc a p->t inhibitor weight=3",
        );
    }

    #[test]
    fn rejects_reset_unknown_and_conflicting_types() {
        check(
            r#"<arc id="a" source="p" target="t"><arctype>reset</arctype></arc>"#,
            "t.pnml:2:35: error[P010]: arc `a` is a reset arc; reset arcs are not supported (petriplc reads normal, read and inhibitor arcs) [a]",
        );
        check(
            r#"<arc id="a" source="p" target="t" type="reset"/>"#,
            "t.pnml:2:1: error[P010]: arc `a` is a reset arc; reset arcs are not supported (petriplc reads normal, read and inhibitor arcs) [a]",
        );
        check(
            r#"<arc id="a" source="p" target="t"><type value="reset"/></arc>"#,
            "t.pnml:2:35: error[P010]: arc `a` is a reset arc; reset arcs are not supported (petriplc reads normal, read and inhibitor arcs) [a]",
        );
        check(
            r#"<arc id="a" source="p" target="t"><type value="inhibit"/></arc>"#,
            "t.pnml:2:35: error[P009]: arc `a`: arc type `inhibit` (`<type>`) is unknown; use normal, read (or test) or inhibitor [a]",
        );
        check(
            r#"<arc id="a" source="p" target="t" type="read"><arctype>inhibitor</arctype></arc>"#,
            "t.pnml:2:47: error[P011]: arc `a`: its `type` attribute says `read` but `<arctype>` says `inhibitor`; give the arc one type [a]",
        );
        check(
            r#"<arc id="a" source="p" target="t"><arctype>normal</arctype><toolspecific tool="petriplc"><type value="read"/></toolspecific></arc>"#,
            "t.pnml:2:90: error[P011]: arc `a`: `<arctype>` says `normal` but petriplc's `<type>` says `read`; give the arc one type [a]",
        );
        check(
            r#"<arc id="a" source="p" target="t"><arctype>read</arctype><arctype>read</arctype></arc>"#,
            "t.pnml:2:58: error[P016]: arc `a` has a second `<arctype>`; give it once [a]",
        );
    }

    #[test]
    fn checks_special_arcs_with_the_model_rules() {
        check(
            r#"<arc id="a" source="t" target="q"><arctype>inhibitor</arctype></arc>"#,
            "t.pnml:2:1: error[P018]: arc `a` goes from a transition to a place but is marked inhibitor; read and inhibitor arcs go from a place to a transition [a]",
        );
        check(
            r#"<arc id="a" source="p" target="t" type="inhibitor"><toolspecific tool="petriplc"><delay>1</delay></toolspecific></arc>"#,
            "t.pnml:2:1: error[P018]: arc `a` has a delay but is an inhibitor arc; delays go on normal or read arcs from a place [a]",
        );
    }
}

mod toolspecific {
    use super::*;

    fn check(input: &str, expect: &str) {
        assert_same(&read(input, Naming::Plain), expect);
    }

    #[test]
    fn reads_petriplc_data_on_every_element() {
        let doc = format!(
            "{HEAD}\n{}\n</page>{}</net></pnml>",
            r#"
<place id="p1"><name><text>Busy</text></name><initialMarking><text>1</text></initialMarking>
  <toolspecific tool="petriplc" version="1"><output>L1</output><capacity>2</capacity></toolspecific></place>
<place id="i1"><toolspecific tool="PetriPLC" version="1"><input>Level</input></toolspecific></place>
<place id="p2"><toolspecific tool="petriplc" version="1"><output>Count</output></toolspecific></place>
<transition id="t1"><toolspecific tool="petriplc" version="1"><guard>B1 &amp; !N2 OR Level &gt;= 3</guard></toolspecific></transition>
<arc id="a1" source="p1" target="t1"><toolspecific tool="petriplc" version="1"><delay>T#1s500ms</delay></toolspecific></arc>
<arc id="a2" source="i1" target="t1"><toolspecific tool="petriplc" version="1"><type value="read"/><delay>0.25</delay></toolspecific></arc>
<arc id="a3" source="t1" target="p2"/>"#
                .trim(),
            r#"<toolspecific tool="petriplc" version="1">
  <step>sequential</step><evolve> until-stable </evolve>
  <signal name="Level" direction="input" type="int"/>
  <signal name="Count" direction="output" type="int"/>
  <signal name="Spare" direction="output"/>
</toolspecific>"#
        );
        check(
            &doc,
            r#"
net n "" sequential until-stable
signal input int Level
signal output int Count
signal output bool Spare
signal output bool L1
signal input bool B1
signal input bool N2
place p1 "Busy" initial=1 capacity=2 output=L1
place i1 "" input=Level
place p2 "" output=Count
transition t1 "" guard=`B1 AND NOT N2 OR Level >= 3`
arc a1 p1->t1 normal delay=T#1s500ms
arc a2 i1->t1 read delay=T#250ms
arc a3 t1->p2 normal"#,
        );
    }

    #[test]
    fn rejects_unknown_or_misspelt_petriplc_data() {
        check(
            &net(r#"
<toolspecific tool="petriplc" version="1"><step>fast</step><evolve>forever</evolve><steps/></toolspecific>
<toolspecific tool="petriplc" version="1"><signal name="X" dir="input"/><signal direction="in" type="real"/><step>sequential</step></toolspecific>
<toolspecific tool="petriplc" version="2"><nonsense/></toolspecific>
<toolspecific tool="other" version="9"><nonsense/></toolspecific>"#),
            "t.pnml:2:43: error[P017]: net `n`: `<step>` is `fast`; use one of: maximal-step, sequential [n]\n\
             t.pnml:2:60: error[P017]: net `n`: `<evolve>` is `forever`; use one of: one-pass, until-stable [n]\n\
             t.pnml:2:84: error[P015]: net `n`: `<steps>` is not a petriplc element of a net; known here: <step>, <evolve>, <signal> [n]\n\
             t.pnml:3:43: error[P015]: net `n`: `<signal>` has an unknown attribute `dir`; known: name, direction, type [n]\n\
             t.pnml:3:43: error[P017]: net `n`: signal `X` needs direction=\"input\" or direction=\"output\" [n]\n\
             t.pnml:3:73: error[P017]: net `n`: signal `` needs direction=\"input\" or direction=\"output\", not `in` [n]\n\
             t.pnml:3:73: error[P017]: net `n`: signal `` has type `real`; use type=\"bool\" or type=\"int\" [n]\n\
             t.pnml:3:73: error[P017]: net `n`: a `<signal>` has no name=\"…\" [n]\n\
             t.pnml:3:109: error[P016]: net `n` has a second `<step>`; give it once [n]\n\
             t.pnml:4:1: error[P017]: net `n`: petriplc toolspecific data of version `2` is not understood; this petriplc reads version 1 [n]",
        );
        check(
            &page(r#"
<place id="p"><toolspecific tool="petriplc" version="1"><ouput>L1</ouput><output> </output><guard>x</guard></toolspecific></place>
<transition id="t"><toolspecific tool="petriplc" version="1"><delay>1</delay><guard>a</guard></toolspecific><toolspecific tool="petriplc" version="1"><guard>b</guard></toolspecific></transition>
<arc id="a" source="p" target="t"><toolspecific tool="petriplc" version="1"><capacity>1</capacity></toolspecific></arc>"#),
            "t.pnml:2:57: error[P015]: place `p`: `<ouput>` is not a petriplc element of a place; known here: <output>, <input>, <capacity> [p]\n\
             t.pnml:2:74: error[P017]: place `p`: `<output>` is empty; write the signal's name [p]\n\
             t.pnml:2:92: error[P015]: place `p`: `<guard>` is not a petriplc element of a place; known here: <output>, <input>, <capacity> [p]\n\
             t.pnml:3:62: error[P015]: transition `t`: `<delay>` is not a petriplc element of a transition; known here: <guard>, <deadline> [t]\n\
             t.pnml:3:151: error[P016]: transition `t` has a second `<guard>`; give it once [t]\n\
             t.pnml:4:77: error[P015]: arc `a`: `<capacity>` is not a petriplc element of an arc; known here: <delay>, <type> [a]",
        );
    }

    #[test]
    fn points_signal_errors_at_the_use() {
        check(
            &format!(
                "{HEAD}\n{}\n</page>{}</net></pnml>",
                r#"
<place id="p1"><toolspecific tool="petriplc"><output>X</output></toolspecific></place>
<place id="p2"><toolspecific tool="petriplc"><output>L</output></toolspecific></place>
<place id="p3"><toolspecific tool="petriplc"><input>bad name</input></toolspecific></place>
<transition id="t1"><toolspecific tool="petriplc"><guard>L OR Y</guard></toolspecific></transition>"#
                    .trim(),
                r#"<toolspecific tool="petriplc"><signal name="X" direction="input"/><signal name="Y" direction="input" type="int"/><signal name="Y" direction="input" type="bool"/></toolspecific>"#
            ),
            "t.pnml:2:46: error[P020]: signal `X` is used as an input and as an output; rename one of them [p1]\n\
             t.pnml:4:46: error[P020]: `bad name` is not a valid signal name; use letters, digits and `_`, starting with a letter or `_` [p3]\n\
             t.pnml:5:1: error[P020]: transition `t1`: its guard reads output `L`; guards read input signals only [t1]\n\
             t.pnml:6:121: error[P020]: signal `Y` is declared twice with different types (int and bool) [n]",
        );
    }
}

mod sipn {
    use super::*;

    fn check(input: &str, expect: &str) {
        assert_same(&read(input, Naming::Sipn), expect);
    }

    #[test]
    fn names_are_signals_and_conditions() {
        check(
            &page(
                r#"
<place id="p1"><name><text>L1</text></name><initialMarking><text>1</text></initialMarking></place>
<place id="p2"><name><text>defaultPlace2</text></name></place>
<place id="p3"><name><text> V1 </text></name><toolspecific tool="petriplc"><capacity>3</capacity></toolspecific></place>
<place id="p4"><name><text>L1</text></name></place>
<place id="p5"><name><text>ignored</text></name><toolspecific tool="petriplc"><output>M</output></toolspecific></place>
<place id="p6"/>
<transition id="t1"><name><text>!B1</text></name></transition>
<transition id="t2"><name><text>DefaultTransition2</text></name></transition>
<transition id="t3"><name><text>T3 AND !S1</text></name></transition>
<transition id="t4"><name><text>nonsense!</text></name><toolspecific tool="petriplc"><guard>G</guard></toolspecific></transition>
<transition id="t5"/>
<arc id="a1" source="p1" target="t1"/>"#,
            ),
            r#"
net n "" maximal-step one-pass
signal output bool L1
signal output bool V1
signal output bool M
signal input bool B1
signal input bool T3
signal input bool S1
signal input bool G
place p1 "L1" initial=1 capacity=1 output=L1
place p2 "defaultPlace2" capacity=1
place p3 " V1 " capacity=3 output=V1
place p4 "L1" capacity=1 output=L1
place p5 "ignored" capacity=1 output=M
place p6 "" capacity=1
transition t1 "!B1" guard=`NOT B1`
transition t2 "DefaultTransition2"
transition t3 "T3 AND !S1" guard=`T3 AND NOT S1`
transition t4 "nonsense!" guard=`G`
transition t5 ""
arc a1 p1->t1 normal"#,
        );
    }

    #[test]
    fn reports_names_that_are_not_signals_or_conditions() {
        check(
            &page(
                r#"
<place id="p1"><name><text>Tank level</text></name></place>
<place id="p2"><name><text>Full</text></name><initialMarking><text>2</text></initialMarking></place>
<transition id="t1">
  <name><text>B1 &amp;&amp;</text></name>
</transition>"#,
            ),
            "t.pnml:2:1: error[P020]: place `p1`: its name `Tank level` is not a signal name, and SIPN naming makes a place's name its output; use letters, digits and `_`, or start the name with `default` for an internal place [p1]\n\
             t.pnml:3:1: error[P019]: place `p2` starts with 2 tokens but its capacity is 1 [p2]\n\
             t.pnml:5:3: error[P013]: transition `t1`: its name `B1 &&` is not valid as a guard (SIPN naming reads a transition's name as its input condition): column 6: the guard ends where a signal name, TRUE, FALSE, NOT or `(` is expected [t1]",
        );
    }
}

mod references {
    use super::*;

    fn check(input: &str, expect: &str) {
        assert_same(&read(input, Naming::Plain), expect);
    }

    #[test]
    fn flattens_pages_and_resolves_reference_chains() {
        check(
            &page(
                r#"
<place id="p1"/>
<page id="sub"><name><text>Sub</text></name>
  <referencePlace id="r1" ref="p1"/>
  <referencePlace id="r2" ref="r1"/>
  <page id="subsub"><transition id="t1"/><referenceTransition id="rt" ref="t1"/></page>
  <arc id="a1" source="r2" target="rt"/>
</page>
<arc id="a2" source="rt" target="r1"><inscription><text>2</text></inscription></arc>"#,
            ),
            r#"
net n "" maximal-step one-pass
place p1 ""
transition t1 ""
arc a1 p1->t1 normal
arc a2 t1->p1 normal weight=2"#,
        );
    }

    #[test]
    fn reports_broken_references() {
        check(
            &page(
                r#"
<place id="p1"/>
<transition id="t1"/>
<referencePlace id="r1" ref="r2"/>
<referencePlace id="r2" ref="r1"/>
<referencePlace id="r3" ref="t1"/>
<referenceTransition id="r4" ref="ghost"/>
<referenceTransition id="r5" ref="r6"/>
<referencePlace id="r6" ref="p1"/>
<referencePlace id="r7" ref="r1"/>
<referencePlace id="r8"/>
<arc id="a1" source="r1" target="t1"/>
<arc id="a2" source="r3" target="t1"/>"#,
            ),
            "t.pnml:4:1: error[P007]: reference place `r1` is part of a cycle of references (r1 → r2 → r1); a chain of references must end at a place [r1]\n\
             t.pnml:6:1: error[P007]: reference place `r3` refers to `t1`, which is a transition; it must refer to a place or another reference place [r3]\n\
             t.pnml:7:1: error[P007]: reference transition `r4` refers to `ghost`, which is not an element of this net [r4]\n\
             t.pnml:8:1: error[P007]: reference transition `r5` refers to `r6`, which is a reference place; it must refer to a transition or another reference transition [r5]\n\
             t.pnml:11:1: error[P005]: reference place `r8` has no `ref` attribute; give the id of the node it stands for [r8]",
        );
    }
}

mod layout {
    use super::*;
    use crate::write_string;

    /// Reads `input`, writes it back, and checks that every fragment in `expect` survives
    /// and that reading the output gives the same document.
    fn check(input: &str, expect: &[&str]) {
        let doc = read_str(input, "t.pnml", &ReadOptions::default()).expect("the input reads");
        let written = write_string(&doc.net, Some(&doc.layout));
        for fragment in expect {
            assert!(
                written.contains(fragment),
                "{fragment:?} is missing from:\n{written}"
            );
        }
        let back = read_str(&written, "w.pnml", &ReadOptions::default()).expect("the output reads");
        assert_eq!(back, doc, "written:\n{written}");
    }

    #[test]
    fn keeps_graphics_and_other_tools_data() {
        check(
            &format!(
                "{}<name><text>Tank</text><graphics><offset x=\"0\" y=\"-10\"/></graphics></name>{}</page><toolspecific tool=\"netlab\" version=\"2\"><grid on=\"yes\"/></toolspecific></net></pnml>",
                HEAD.trim_end_matches(r#"<page id="pg">"#),
                r#"<page id="main"><graphics><position x="0" y="0"/></graphics>
<place id="p1"><name><text>P1</text><graphics><offset x="5" y="5"/></graphics></name>
  <graphics><position x="10" y="20"/></graphics>
  <initialMarking><text>0</text><graphics><offset x="1" y="1"/></graphics></initialMarking>
  <toolspecific tool="pipe" version="4"><tokens colour="red"/></toolspecific>
  <capacity><text>5</text></capacity>
</place>
<transition id="t1"><graphics><position x="50" y="20"/></graphics></transition>
<arc id="a1" source="p1" target="t1"><name><text>feed</text></name><graphics><position x="30" y="40"/></graphics>
  <inscription><text>1</text><graphics><offset x="2" y="2"/></graphics></inscription></arc>"#
            ),
            &[
                r#"<name><text>Tank</text><graphics><offset x="0" y="-10"/></graphics></name>"#,
                r#"<toolspecific tool="netlab" version="2"><grid on="yes"/></toolspecific>"#,
                r#"<page id="main">"#,
                r#"<graphics><position x="0" y="0"/></graphics>"#,
                r#"<name><text>P1</text><graphics><offset x="5" y="5"/></graphics></name>"#,
                r#"<graphics><position x="10" y="20"/></graphics>"#,
                r#"<initialMarking><text>0</text><graphics><offset x="1" y="1"/></graphics></initialMarking>"#,
                r#"<toolspecific tool="pipe" version="4"><tokens colour="red"/></toolspecific>"#,
                r#"<capacity><text>5</text></capacity>"#,
                r#"<graphics><position x="50" y="20"/></graphics>"#,
                r#"<name><text>feed</text></name>"#,
                r#"<graphics><position x="30" y="40"/></graphics>"#,
                r#"<inscription><text>1</text><graphics><offset x="2" y="2"/></graphics></inscription>"#,
            ],
        );
    }

    #[test]
    fn keeps_pnml_written_by_petriplc() {
        check(
            &page(
                r#"
<place id="p1"><name><text>a &lt;&amp;&gt; "b"</text></name></place>
<transition id="t1"><toolspecific tool="petriplc" version="1"><guard>NOT x</guard></toolspecific></transition>
<arc id="a1" source="p1" target="t1" type="test"/>"#,
            ),
            &[
                "<text>a &lt;&amp;&gt; \"b\"</text>",
                "<guard>NOT x</guard>",
                "<arctype>read</arctype>",
                "<type value=\"read\"/>",
            ],
        );
    }
}
