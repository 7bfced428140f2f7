use super::*;

fn read_text(text: &str) -> (Library, Vec<String>) {
    let mut map = SourceMap::new();
    let mut d = Diagnostics::new();
    let lib = read(&mut map, "p.xml", text, &mut d);
    let msgs = d.items.iter().map(|x| x.render(&map)).collect();
    (lib, msgs)
}

#[test]
fn sniffing_stops_inside_no_character() {
    // Found by fuzzing: the 4096-byte head of the text ended inside a UTF-8 character.
    let mut text = "x".repeat(4095);
    text.push('é');
    text.push_str("<project xmlns=\"http://www.plcopen.org/xml/tc6_0201\">");
    assert!(!is_plcopen(&text));
    assert!(is_plcopen(
        "<?xml version=\"1.0\"?><project xmlns=\"http://www.plcopen.org/xml/tc6_0201\"></project>"
    ));
    assert!(!is_plcopen("PROGRAM p END_PROGRAM"));
}

#[test]
fn an_st_body_is_placed_at_its_line_in_the_xml() {
    let text = r#"<?xml version="1.0" encoding="utf-8"?>
<project xmlns="http://www.plcopen.org/xml/tc6_0201" xmlns:xhtml="http://www.w3.org/1999/xhtml">
  <fileHeader companyName="x" productName="x" productVersion="1" creationDateTime="2026-01-01T00:00:00"/>
  <contentHeader name="p"><coordinateInfo><fbd><scaling x="1" y="1"/></fbd><ld><scaling x="1" y="1"/></ld><sfc><scaling x="1" y="1"/></sfc></coordinateInfo></contentHeader>
  <types><dataTypes/><pous>
    <pou name="main" pouType="program">
      <interface><localVars><variable name="x"><type><INT/></type></variable></localVars></interface>
      <body><ST><xhtml:p><![CDATA[
x := x + 1;
x := ;
]]></xhtml:p></ST></body>
    </pou>
  </pous></types>
  <instances><configurations/></instances>
</project>"#;
    let (lib, msgs) = read_text(text);
    assert_eq!(lib.elements.len(), 1);
    assert_eq!(msgs.len(), 1, "{msgs:?}");
    assert!(msgs[0].starts_with("p.xml:10:6: error[E010]"), "{msgs:?}");
}

#[test]
fn malformed_xml_and_other_roots_are_positioned_errors() {
    let (_, msgs) = read_text("<project>\n  <types>\n</project>");
    assert!(msgs[0].starts_with("p.xml:3:"), "{msgs:?}");
    let (_, msgs) = read_text("<pnml/>");
    assert!(msgs[0].contains("error[E051]"), "{msgs:?}");
}

#[test]
fn a_pointer_type_is_a_pointer_to_its_base_type() {
    let text = r#"<?xml version="1.0" encoding="utf-8"?>
<project xmlns="http://www.plcopen.org/xml/tc6_0201">
  <types><dataTypes/><pous>
    <pou name="main" pouType="program">
      <interface><localVars><variable name="p"><type><pointer><baseType><INT/></baseType></pointer></type></variable></localVars></interface>
      <body><ST><xhtml:p xmlns:xhtml="http://www.w3.org/1999/xhtml"><![CDATA[p := p;]]></xhtml:p></ST></body>
    </pou>
  </pous></types>
</project>"#;
    let (lib, msgs) = read_text(text);
    assert!(msgs.is_empty(), "{msgs:?}");
    let Element::Pou(p) = &lib.elements[0] else {
        panic!("not a POU")
    };
    match &p.var_blocks[0].vars[0].ty {
        TypeSpec::Ref { kind, target, .. } => {
            assert_eq!(*kind, RefKind::PointerTo);
            assert!(
                matches!(&**target, TypeSpec::Named(i) if i.name == "INT"),
                "{target:?}"
            );
        }
        other => panic!("{other:?}"),
    }
    let (_, msgs) = read_text(&text.replace("<baseType><INT/></baseType>", ""));
    assert!(msgs[0].contains("error[E052]"), "{msgs:?}");
}
