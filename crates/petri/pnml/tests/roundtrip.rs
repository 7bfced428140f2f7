//! Property tests: random valid nets read back equal after writing, and no input, however
//! broken, makes the reader panic.

mod common;

use petriplc_pnml::{read_str, write_string, Naming, ReadOptions};
use proptest::prelude::*;

use common::nets;

const SNIPPETS: &[&str] = &[
    "<",
    ">",
    "/>",
    "\"",
    "&amp;",
    "&",
    "&#0;",
    "<![CDATA[x]]>",
    "</place>",
    "<page id=\"x\">",
    "<place id=\"p0\"/>",
    "<transition/>",
    "<arc id=\"z\" source=\"p0\" target=\"t0\"/>",
    "<referencePlace id=\"r\" ref=\"r\"/>",
    "<toolspecific tool=\"petriplc\" version=\"1\">",
    "</toolspecific>",
    "<guard>((((</guard>",
    "<delay>T#</delay>",
    "<arctype>reset</arctype>",
    "<type value=\"read\"/>",
    "<inscription><text>-1</text></inscription>",
    "99999999999",
    "<signal name=\"B1\" direction=\"output\" type=\"int\"/>",
    "<capacity>0</capacity>",
    "<net id=\"n2\" type=\"ptnet\">",
    "</net>",
    "é",
    "\u{0}",
];

fn mutate(doc: &str, edits: &[(usize, u8, usize, usize)]) -> String {
    let mut s = doc.to_string();
    for &(at, op, len, snippet) in edits {
        let at = floor_char(&s, at % (s.len() + 1));
        let end = floor_char(&s, (at + len % 40).min(s.len()));
        match op % 4 {
            0 => s.replace_range(at..end, ""),
            1 => s.insert_str(at, SNIPPETS[snippet % SNIPPETS.len()]),
            2 => {
                let copy = s[at..end].to_string();
                s.insert_str(at, &copy);
            }
            _ => s.replace_range(at..end, SNIPPETS[snippet % SNIPPETS.len()]),
        }
    }
    s
}

fn floor_char(s: &str, mut i: usize) -> usize {
    while !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn written_nets_read_back_equal(plan in nets::plan()) {
        let net = nets::build(&plan);
        let text = write_string(&net, None);
        let back = read_str(&text, "w.pnml", &ReadOptions::default());
        match back {
            Ok(doc) => {
                prop_assert_eq!(&doc.net, &net, "written:\n{}", text);
                // A second round changes nothing, layout included.
                prop_assert_eq!(write_string(&doc.net, Some(&doc.layout)), text);
            }
            Err(e) => prop_assert!(false, "does not read back:\n{}\n{}", e, text),
        }
    }

    #[test]
    fn mutated_documents_never_panic(
        plan in nets::plan(),
        edits in prop::collection::vec((any::<usize>(), any::<u8>(), any::<usize>(), any::<usize>()), 1..6),
        sipn in any::<bool>(),
    ) {
        let text = mutate(&write_string(&nets::build(&plan), None), &edits);
        let naming = if sipn { Naming::Sipn } else { Naming::Plain };
        if let Err(e) = read_str(&text, "m.pnml", &ReadOptions { naming }) {
            // Every diagnostic has a position inside the file.
            for d in e.diagnostics() {
                prop_assert!(d.span.line >= 1 && d.span.column >= 1 && d.span.line as usize <= text.lines().count() + 1);
            }
        }
    }

    /// Sizes and depths far past any real file: elements nested 20 000 deep, ids, numbers
    /// and guards thousands of characters long, guards nested or chained past their limits,
    /// durations a float cannot hold. Refused with coded, positioned, short diagnostics (the
    /// work bounded by the document's size).
    #[test]
    fn hostile_sizes_are_refused_with_codes(
        shape in 0u8..8,
        n in prop_oneof![1usize..300, 1_000usize..20_000],
        sipn in any::<bool>(),
    ) {
        let head = r#"<pnml><net id="n" type="http://www.pnml.org/version-2009/grammar/ptnet"><page id="g">"#;
        let tool = |inner: String| format!(r#"<toolspecific tool="petriplc" version="1">{inner}</toolspecific>"#);
        let body = match shape {
            0 => "<page>".repeat(n),
            1 => format!(r#"<place id="{}"/>"#, "p".repeat(n)),
            2 => format!(r#"<place id="p"><initialMarking><text>{}</text></initialMarking></place>"#, "9".repeat(n)),
            3 => format!(r#"<transition id="t">{}</transition>"#, tool(format!("<guard>{}B1{}</guard>", "(".repeat(n), ")".repeat(n)))),
            4 => format!(r#"<transition id="t">{}</transition>"#, tool(format!("<guard>{}</guard>", vec!["B1"; n].join(" AND ")))),
            5 => format!(r#"<transition id="t">{}</transition>"#, tool(format!("<guard>{}B1</guard>", "NOT ".repeat(n)))),
            6 => {
                let delay = ["NaN s", "inf", "1e400", "-1s", "T#99999999999999999999d", "1e-400"][n % 6];
                format!(r#"<place id="p"/><transition id="t"/><arc id="a" source="p" target="t">{}</arc>"#, tool(format!("<delay>{delay}</delay>")))
            }
            _ => format!(r#"<place id="p"><name><text>{}</text></name></place>"#, "é".repeat(n)),
        };
        let text = format!("{head}{body}</page></net></pnml>");
        let naming = if sipn { Naming::Sipn } else { Naming::Plain };
        if let Err(e) = read_str(&text, "h.pnml", &ReadOptions { naming }) {
            let lines = text.lines().count();
            for d in e.diagnostics() {
                prop_assert!(d.code.0.len() == 4 && d.code.0.starts_with('P'), "{d}");
                prop_assert!(d.span.line >= 1 && d.span.column >= 1 && d.span.line as usize <= lines + 1, "{d}");
                prop_assert!(d.to_string().len() < 1000, "{} bytes", d.to_string().len());
            }
            prop_assert!(e.diagnostics().len() <= 4, "{}", e.diagnostics().len());
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = read_str(&text, "b.pnml", &ReadOptions::default());
        let _ = read_str(&format!("<pnml><net id=\"n\" type=\"ptnet\"><page id=\"g\">{text}"), "b.pnml", &ReadOptions { naming: Naming::Sipn });
    }
}
