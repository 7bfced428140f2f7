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

/// What CODESYS V3.5 writes in `<addData>`: lines are counted in the test below.
const CODESYS: &str = r#"<?xml version="1.0" encoding="utf-8"?>
<project xmlns="http://www.plcopen.org/xml/tc6_0200">
  <types><dataTypes/><pous>
    <pou name="Lamp" pouType="functionBlock">
      <interface>
        <inputVars><variable name="on"><type><BOOL/></type><documentation><xhtml xmlns="http://www.w3.org/1999/xhtml">switch</xhtml></documentation></variable></inputVars>
      </interface>
      <body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">;</xhtml></ST></body>
      <actions>
        <action name="Reset"><body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">on := FALSE;</xhtml></ST></body></action>
      </actions>
      <addData>
        <data name="http://www.3s-software.com/plcopenxml/method" handleUnknown="implementation">
          <Method name="Toggle" ObjectId="1"><interface/><body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">;</xhtml></ST></body></Method>
        </data>
        <data name="http://www.3s-software.com/plcopenxml/property" handleUnknown="implementation">
          <Property name="Level" ObjectId="2"><interface><returnType><INT/></returnType></interface><GetAccessor><interface/><body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">Level := 1;</xhtml></ST></body></GetAccessor></Property>
        </data>
        <data name="http://www.3s-software.com/plcopenxml/pouinheritance" handleUnknown="implementation">
          <Inheritance><Extends>Base</Extends></Inheritance>
        </data>
        <data name="http://www.3s-software.com/plcopenxml/objectid" handleUnknown="discard"><ObjectId>3</ObjectId></data>
      </addData>
    </pou>
  </pous></types>
  <instances><configurations>
    <configuration name="Device">
      <resource name="Application">
        <task name="Main" interval="PT0.01S" priority="1">
          <pouInstance name="PLC_PRG" typeName=""/>
        </task>
        <globalVars name="GVL_IO">
          <variable name="a"><type><INT/></type></variable>
          <variable name="k"><type><INT/></type></variable>
          <addData>
            <data name="http://www.3s-software.com/plcopenxml/mixedattrsvarlist" handleUnknown="implementation">
              <MixedAttrsVarList>
                <globalVars name="GVL_IO"><variable name="a"><type><INT/></type></variable></globalVars>
                <globalVars name="GVL_IO" constant="true"><variable name="k"><type><INT/></type></variable></globalVars>
              </MixedAttrsVarList>
            </data>
          </addData>
        </globalVars>
        <addData>
          <data name="http://www.3s-software.com/plcopenxml/pou" handleUnknown="implementation">
            <pou name="PLC_PRG" pouType="program">
              <interface><localVars><variable name="x"><type><INT/></type></variable></localVars></interface>
              <body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">x := x + 1;</xhtml></ST></body>
            </pou>
          </data>
        </addData>
      </resource>
    </configuration>
  </configurations></instances>
  <addData>
    <data name="http://www.3s-software.com/plcopenxml/globalvars" handleUnknown="implementation">
      <globalVars name="GVL"><variable name="limit"><type><INT/></type></variable></globalVars>
    </data>
    <data name="http://www.3s-software.com/plcopenxml/interface" handleUnknown="implementation">
      <Interface name="I_Switch" ObjectId="4">
        <Methods>
          <Method name="Flip" ObjectId="5"><interface><returnType><BOOL/></returnType><inputVars><variable name="hard"><type><BOOL/></type></variable></inputVars></interface><addData/></Method>
        </Methods>
        <Inheritance><Extends>I_Base</Extends></Inheritance>
      </Interface>
    </data>
  </addData>
</project>"#;

#[test]
fn codesys_add_data_is_read_or_reported_where_it_is() {
    let (lib, msgs) = read_text(CODESYS);
    // Methods, properties, EXTENDS, actions and interfaces are read.
    assert!(msgs.is_empty(), "{msgs:?}");
    let itf = lib
        .elements
        .iter()
        .find_map(|e| match e {
            Element::Pou(p) if p.oop.interface => Some(p),
            _ => None,
        })
        .unwrap();
    assert!(itf.name.is("I_Switch") && itf.oop.implements[0].is("I_Base"));
    let flip = &itf.oop.methods[0];
    assert!(flip.pou.name.is("Flip") && flip.modifiers.is_abstract);
    assert!(flip.pou.return_type.is_some() && flip.pou.var_blocks[0].vars[0].names[0].is("hard"));
    let Element::Pou(lamp) = &lib.elements[0] else {
        panic!("{:?}", lib.elements[0])
    };
    let o = &lamp.oop;
    assert!(o.methods[0].pou.name.is("Toggle") && o.methods[0].pou.return_type.is_none());
    assert!(o.properties[0].name.is("Level") && o.properties[0].get.is_some());
    assert!(o.properties[0].set.is_none());
    assert!(o.extends.as_ref().is_some_and(|b| b.is("Base")));
    assert!(o.actions[0].name.is("Reset"));
    assert!(matches!(&o.actions[0].body, Body::St(b) if b.len() == 1));
    // The resource's program, the project's global list; the typeless instance is PLC_PRG.
    let pous: Vec<&str> = lib
        .elements
        .iter()
        .filter_map(|e| match e {
            Element::Pou(p) => Some(p.name.name.as_str()),
            _ => None,
        })
        .collect();
    assert_eq!(pous, ["Lamp", "PLC_PRG", "I_Switch"]);
    assert!(lib
        .elements
        .iter()
        .any(|e| matches!(e, Element::Globals(b) if b.vars[0].names[0].is("limit"))));
    let c = lib
        .elements
        .iter()
        .find_map(|e| match e {
            Element::Configuration(c) => Some(c),
            _ => None,
        })
        .unwrap();
    let r = &c.resources[0];
    assert!(r.programs[0].type_name.is("PLC_PRG"));
    // The interval is an XML duration, 10 ms.
    assert!(matches!(
        r.tasks[0].interval.as_ref().map(|e| &e.kind),
        Some(ExprKind::Literal(Literal::Time {
            nanos: 10_000_000,
            ..
        }))
    ));
    // The mixed list's two blocks, not the flat one.
    let blocks: Vec<(bool, usize)> = r
        .globals
        .iter()
        .map(|b| (b.constant, b.vars.len()))
        .collect();
    assert_eq!(blocks, [(false, 1), (true, 1)]);
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

#[test]
fn a_tc6_1_0_pou_instance_names_its_type_with_type() {
    let text = r#"<?xml version="1.0" encoding="utf-8"?>
<project xmlns="http://www.plcopen.org/xml/tc6.xsd">
  <types><dataTypes/><pous>
    <pou name="main" pouType="program">
      <interface><localVars><variable name="x"><type><INT/></type></variable></localVars></interface>
      <body><ST><xhtml:p xmlns:xhtml="http://www.w3.org/1999/xhtml"><![CDATA[x := x + 1;]]></xhtml:p></ST></body>
    </pou>
  </pous></types>
  <instances><configurations><configuration name="c"><resource name="r">
    <task name="t" interval="T#10ms" priority="1"><pouInstance type="main" name="inst"/></task>
  </resource></configuration></configurations></instances>
</project>"#;
    let (lib, msgs) = read_text(text);
    assert!(msgs.is_empty(), "{msgs:?}");
    let conf = lib
        .elements
        .iter()
        .find_map(|e| match e {
            Element::Configuration(c) => Some(c),
            _ => None,
        })
        .expect("a configuration");
    let p = &conf.resources[0].programs[0];
    assert_eq!(
        (p.name.name.as_str(), p.type_name.name.as_str()),
        ("inst", "main")
    );
    // Neither attribute: still the positioned E052.
    let (_, msgs) = read_text(&text.replace(r#"type="main" "#, ""));
    assert!(msgs[0].contains("error[E052]"), "{msgs:?}");
}

/// Beremiz writes a string's initial value as typed and quotes it in the Structured Text it
/// generates: `blup` is `'blup'`, for STRING, an alias of it and SVGHMI's HMI_STRING.
#[test]
fn an_unquoted_string_initial_value_is_quoted_as_beremiz_does() {
    let text = r#"<project xmlns="http://www.plcopen.org/xml/tc6_0201">
  <fileHeader companyName="Unknown" productName="Unnamed" productVersion="1" creationDateTime="2024-01-01T00:00:00"/>
  <types><dataTypes>
    <dataType name="Name"><baseType><string/></baseType></dataType>
  </dataTypes><pous>
    <pou name="main" pouType="program">
      <interface><localVars>
        <variable name="a"><type><string/></type><initialValue><simpleValue value="blup"/></initialValue></variable>
        <variable name="b"><type><derived name="name"/></type><initialValue><simpleValue value="x y"/></initialValue></variable>
        <variable name="c"><type><derived name="HMI_STRING"/></type><initialValue><simpleValue value="'q'"/></initialValue></variable>
        <variable name="d"><type><INT/></type><initialValue><simpleValue value="7"/></initialValue></variable>
      </localVars></interface>
      <body><ST><xhtml:p xmlns:xhtml="http://www.w3.org/1999/xhtml"><![CDATA[a := a;]]></xhtml:p></ST></body>
    </pou>
  </pous></types>
</project>"#;
    let (lib, msgs) = read_text(text);
    assert!(msgs.is_empty(), "{msgs:?}");
    let pou = lib
        .elements
        .iter()
        .find_map(|e| match e {
            Element::Pou(p) => Some(p),
            _ => None,
        })
        .expect("a POU");
    let inits: Vec<String> = pou.var_blocks[0]
        .vars
        .iter()
        .map(|v| match &v.init {
            Some(Init::Expr(Expr {
                kind: ExprKind::Literal(Literal::String { bytes, .. }),
                ..
            })) => String::from_utf8_lossy(bytes).into_owned(),
            Some(Init::Expr(Expr {
                kind: ExprKind::Literal(Literal::Int { value, .. }),
                ..
            })) => value.to_string(),
            other => format!("{other:?}"),
        })
        .collect();
    assert_eq!(inits, ["blup", "x y", "q", "7"]);
}

/// TC6 1.0's task interval is an xsd:time (matiec's test projects: `00:00:00.100000`).
#[test]
fn a_clock_time_interval_is_a_duration() {
    assert_eq!(clock_duration("00:00:00.100000"), Some(100_000_000));
    assert_eq!(clock_duration("01:02:03"), Some(3_723_000_000_000));
    assert_eq!(clock_duration("T#10ms"), None);
    assert_eq!(clock_duration("1:2"), None);
    assert_eq!(clock_duration("00:00:0x"), None);
}

#[test]
fn a_string_initial_value_of_another_writer_is_read_as_written() {
    // CODESYS keeps an expression there; only Beremiz's projects get their values quoted.
    let text = r#"<project xmlns="http://www.plcopen.org/xml/tc6_0200">
  <fileHeader companyName="" productName="CODESYS" productVersion="3.5" creationDateTime="2024-01-01T00:00:00"/>
  <types><dataTypes/><pous>
    <pou name="main" pouType="program">
      <interface><localVars>
        <variable name="a"><type><string/></type><initialValue><simpleValue value="CONCAT('ab', '#')"/></initialValue></variable>
      </localVars></interface>
      <body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">a := a;</xhtml></ST></body>
    </pou>
  </pous></types>
</project>"#;
    let (_, msgs) = read_text(text);
    assert!(msgs.is_empty(), "{msgs:?}");
}
