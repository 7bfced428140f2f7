use super::*;

fn read_text(name: &str, text: &str) -> (Library, Vec<String>, SourceMap) {
    let mut map = SourceMap::new();
    let mut d = Diagnostics::new();
    let lib = read(&mut map, name, text, &mut d);
    let msgs = d.items.iter().map(|x| x.render(&map)).collect();
    (lib, msgs, map)
}

/// A function block as TwinCAT 3 saves it, with a byte order mark, a method, a property, an
/// action and a transition after its body (lines counted in the tests below).
const FB: &str = "\u{feff}<?xml version=\"1.0\" encoding=\"utf-8\"?>
<TcPlcObject Version=\"1.1.0.1\">
  <POU Name=\"Counter\" Id=\"{00000000-0000-0000-0000-000000000001}\" SpecialFunc=\"None\">
    <Declaration><![CDATA[{attribute 'hide'}
FUNCTION_BLOCK Counter
VAR_INPUT
\tstep : INT := 1;
END_VAR
VAR_OUTPUT
\tcount : INT;
END_VAR]]></Declaration>
    <Implementation>
      <ST><![CDATA[// counts
count := count + step;]]></ST>
    </Implementation>
    <Method Name=\"Reset\" Id=\"{00000000-0000-0000-0000-000000000002}\">
      <Declaration><![CDATA[METHOD Reset]]></Declaration>
      <Implementation>
        <ST><![CDATA[count := 0;]]></ST>
      </Implementation>
    </Method>
    <Property Name=\"Value\" Id=\"{00000000-0000-0000-0000-000000000003}\">
      <Declaration><![CDATA[PROPERTY Value : INT]]></Declaration>
    </Property>
    <Action Name=\"Twice\" Id=\"{00000000-0000-0000-0000-000000000004}\">
      <Implementation>
        <ST><![CDATA[count := count * 2;]]></ST>
      </Implementation>
    </Action>
    <Transition Name=\"Done\" Id=\"{00000000-0000-0000-0000-000000000005}\">
      <Implementation>
        <ST><![CDATA[count > 10]]></ST>
      </Implementation>
    </Transition>
    <LineIds Name=\"Counter\">
      <LineId Id=\"1\" Count=\"0\" />
    </LineIds>
  </POU>
</TcPlcObject>";

#[test]
fn a_pou_is_its_declaration_and_its_body() {
    let (lib, msgs, map) = read_text("Counter.TcPOU", FB);
    let [Element::Pou(p)] = lib.elements.as_slice() else {
        panic!("{:?}", lib.elements);
    };
    assert_eq!(p.kind, PouKind::FunctionBlock);
    assert!(p.name.is("Counter"));
    assert_eq!(p.var_blocks.len(), 2);
    let Body::St(body) = &p.body else {
        panic!("{:?}", p.body)
    };
    assert_eq!(body.len(), 1);
    // The statement is on line 14 of the file, column 1.
    assert_eq!(map.position(body[0].span).to_string(), "Counter.TcPOU:14:1");
    assert!(map.files().all(|(_, f)| f.from_twincat));
    // The method, property and action are read; the transition is reported at its element.
    let lines: Vec<&str> = msgs
        .iter()
        .filter(|m| m.contains(": error"))
        .map(|m| m.split(": error").next().unwrap())
        .collect();
    assert_eq!(lines, ["Counter.TcPOU:30:5"], "{msgs:?}");
    assert!(msgs[1].contains("error[E190]: TRANSITION Done of Counter is not supported yet"));
    let [m] = p.oop.methods.as_slice() else {
        panic!("{:?}", p.oop.methods)
    };
    assert!(m.pou.name.is("Reset") && m.pou.return_type.is_none());
    let Body::St(mb) = &m.pou.body else {
        panic!("{:?}", m.pou.body)
    };
    // `count := 0;` is on line 19, column 22 (after `<ST><![CDATA[`).
    assert_eq!(map.position(mb[0].span).to_string(), "Counter.TcPOU:19:22");
    let [pr] = p.oop.properties.as_slice() else {
        panic!("{:?}", p.oop.properties)
    };
    assert!(pr.name.is("Value") && pr.get.is_none() && pr.set.is_none());
    let [a] = p.oop.actions.as_slice() else {
        panic!("{:?}", p.oop.actions)
    };
    assert!(a.name.is("Twice") && matches!(&a.body, Body::St(b) if b.len() == 1));
}

/// A property's `<Get>` and `<Set>`: each its variable blocks and body; the setter reads the
/// new value as an input named as the property.
#[test]
fn a_property_has_its_get_and_set() {
    let text = "<TcPlcObject>
  <POU Name=\"F\">
    <Declaration><![CDATA[FUNCTION_BLOCK F
VAR x : INT; END_VAR]]></Declaration>
    <Implementation><ST><![CDATA[]]></ST></Implementation>
    <Property Name=\"P\">
      <Declaration><![CDATA[PROPERTY PUBLIC P : INT]]></Declaration>
      <Get Name=\"Get\">
        <Declaration><![CDATA[VAR tmp : INT; END_VAR]]></Declaration>
        <Implementation><ST><![CDATA[tmp := x; P := tmp;]]></ST></Implementation>
      </Get>
      <Set Name=\"Set\">
        <Declaration><![CDATA[]]></Declaration>
        <Implementation><ST><![CDATA[x := P;]]></ST></Implementation>
      </Set>
    </Property>
  </POU>
</TcPlcObject>";
    let (lib, msgs, _) = read_text("F.TcPOU", text);
    assert!(msgs.is_empty(), "{msgs:?}");
    let [Element::Pou(p)] = lib.elements.as_slice() else {
        panic!("{:?}", lib.elements);
    };
    let pr = &p.oop.properties[0];
    let get = pr.get.as_ref().unwrap();
    assert!(get.return_type.is_some() && get.var_blocks.len() == 1);
    assert!(matches!(&get.body, Body::St(b) if b.len() == 2));
    let set = pr.set.as_ref().unwrap();
    assert!(set.return_type.is_none());
    assert_eq!(set.var_blocks[0].kind, VarKind::Input);
    assert!(set.var_blocks[0].vars[0].names[0].is("P"));
}

#[test]
fn errors_point_into_the_declaration_and_the_body() {
    let text = "<TcPlcObject>
  <POU Name=\"f\">
    <Declaration><![CDATA[FUNCTION f : INT
VAR_INPUT
  a : INT
END_VAR]]></Declaration>
    <Implementation>
      <ST><![CDATA[f := a +;]]></ST>
    </Implementation>
  </POU>
</TcPlcObject>";
    let (_, msgs, _) = read_text("f.TcPOU", text);
    assert_eq!(msgs.len(), 2, "{msgs:?}");
    assert!(msgs[0].starts_with("f.TcPOU:5:10: error[E012]"), "{msgs:?}");
    assert!(msgs[1].starts_with("f.TcPOU:8:28: error[E010]"), "{msgs:?}");
}

#[test]
fn a_declaration_may_close_its_pou_but_holds_no_statement() {
    let closed = "<TcPlcObject><POU Name=\"p\"><Declaration><![CDATA[PROGRAM p
VAR x : INT; END_VAR
END_PROGRAM]]></Declaration><Implementation><ST><![CDATA[x := 1;]]></ST></Implementation></POU></TcPlcObject>";
    let (lib, msgs, _) = read_text("p.TcPOU", closed);
    assert!(msgs.is_empty(), "{msgs:?}");
    assert_eq!(lib.elements.len(), 1);

    let statement = "<TcPlcObject><POU Name=\"p\"><Declaration><![CDATA[PROGRAM p
VAR x : INT; END_VAR
x := 1;]]></Declaration></POU></TcPlcObject>";
    let (_, msgs, _) = read_text("p.TcPOU", statement);
    assert_eq!(msgs.len(), 1, "{msgs:?}");
    assert!(
        msgs[0].starts_with("p.TcPOU:3:1: error[E010]: a statement in the declaration of p"),
        "{msgs:?}"
    );

    let not_a_pou = "<TcPlcObject><POU Name=\"p\"><Declaration><![CDATA[VAR x : INT; END_VAR]]></Declaration></POU></TcPlcObject>";
    let (lib, msgs, _) = read_text("p.TcPOU", not_a_pou);
    assert!(lib.elements.is_empty());
    assert!(
        msgs[0].contains("error[E010]: a POU's declaration starts with PROGRAM"),
        "{msgs:?}"
    );
}

#[test]
fn types_and_global_lists_are_read_as_written() {
    let dut = "<?xml version=\"1.0\" encoding=\"utf-8\"?>
<TcPlcObject Version=\"1.1.0.1\">
  <DUT Name=\"Pair\" Id=\"{1}\">
    <Declaration><![CDATA[TYPE Pair :
STRUCT
\ta : INT;
\tb : BOOL;
END_STRUCT;
END_TYPE
]]></Declaration>
  </DUT>
</TcPlcObject>";
    let (lib, msgs, _) = read_text("Pair.TcDUT", dut);
    assert!(msgs.is_empty(), "{msgs:?}");
    assert!(matches!(lib.elements.as_slice(), [Element::Types(t)] if t[0].name.is("Pair")));

    let gvl = "<TcPlcObject Version=\"1.1.0.1\">
  <GVL Name=\"GVL\" Id=\"{2}\">
    <Declaration><![CDATA[{attribute 'qualified_only'}
VAR_GLOBAL
\tlimit : INT := 10;
\tbad : INT := ;
END_VAR]]></Declaration>
  </GVL>
</TcPlcObject>";
    let (lib, msgs, _) = read_text("GVL.TcGVL", gvl);
    assert!(matches!(lib.elements.as_slice(), [Element::Globals(_)]));
    assert!(
        msgs.iter()
            .any(|m| m.starts_with("GVL.TcGVL:6:15: error[E010]")),
        "{msgs:?}"
    );
}

#[test]
fn a_task_object_is_a_configured_task() {
    let tto = "<?xml version=\"1.0\" encoding=\"utf-8\"?>
<TcPlcObject Version=\"1.1.0.1\">
  <Task Name=\"PlcTask\" Id=\"{3}\">
    <!--CycleTime in micro seconds.-->
    <CycleTime>10000</CycleTime>
    <Priority>20</Priority>
    <PouCall>
      <Name>MAIN</Name>
    </PouCall>
    <TaskFBGuid>{4}</TaskFBGuid>
  </Task>
</TcPlcObject>";
    let (lib, msgs, _) = read_text("PlcTask.TcTTO", tto);
    assert!(msgs.is_empty(), "{msgs:?}");
    let [Element::Configuration(c)] = lib.elements.as_slice() else {
        panic!("{:?}", lib.elements)
    };
    assert!(c.name.is(TASKS_CONFIGURATION));
    let r = &c.resources[0];
    let t = &r.tasks[0];
    assert!(t.name.is("PlcTask"));
    assert!(matches!(
        t.interval.as_ref().map(|e| &e.kind),
        Some(ExprKind::Literal(Literal::Time {
            nanos: 10_000_000,
            ..
        }))
    ));
    assert!(matches!(
        t.priority.as_ref().map(|e| &e.kind),
        Some(ExprKind::Literal(Literal::Int { value: 20, .. }))
    ));
    assert!(r.programs[0].type_name.is("MAIN"));
    assert!(r.programs[0].task.as_ref().is_some_and(|t| t.is("PlcTask")));

    let bad = "<TcPlcObject>\n<Task Name=\"t\">\n<CycleTime>10 ms</CycleTime></Task></TcPlcObject>";
    let (_, msgs, _) = read_text("t.TcTTO", bad);
    assert!(
        msgs[0].starts_with("t.TcTTO:3:1: error[E055]: task t: <CycleTime> is `10 ms`"),
        "{msgs:?}"
    );
}

#[test]
fn malformed_files_are_positioned_errors() {
    let (_, msgs, _) = read_text(
        "x.TcPOU",
        "<TcPlcObject>\n  <POU Name=\"x\">\n</TcPlcObject>",
    );
    assert!(msgs[0].starts_with("x.TcPOU:3:"), "{msgs:?}");
    assert!(msgs[0].contains("error[E050]"), "{msgs:?}");
    let (_, msgs, _) = read_text("x.TcPOU", "<project/>");
    assert!(
        msgs[0].contains("error[E055]: the root element is <project>"),
        "{msgs:?}"
    );
    let (_, msgs, _) = read_text("x.TcPOU", "<TcPlcObject>\n <POU Name=\"x\"/></TcPlcObject>");
    assert!(
        msgs[0].starts_with("x.TcPOU:2:2: error[E055]: <POU Name=\"x\"> has no <Declaration>"),
        "{msgs:?}"
    );
    let (_, msgs, _) = read_text(
        "x.TcPOU",
        "<TcPlcObject>\n <Visu Name=\"v\"/></TcPlcObject>",
    );
    assert!(
        msgs[0].contains("error[E055]: <Visu> is not a TwinCAT object"),
        "{msgs:?}"
    );
}

#[test]
fn an_interface_file_is_read() {
    // A .TcIO as TwinCAT 3 saves it: the declaration, methods and a property whose <Get>
    // alone says it is read-only; the implied __SYSTEM.IQueryInterface base kept by name.
    let text = "<?xml version=\"1.0\" encoding=\"utf-8\"?>
<TcPlcObject Version=\"1.1.0.1\">
  <Itf Name=\"I_Run\" Id=\"{1}\">
    <Declaration><![CDATA[INTERFACE I_Run EXTENDS __SYSTEM.IQueryInterface
]]></Declaration>
    <Method Name=\"Run\" Id=\"{2}\">
      <Declaration><![CDATA[METHOD Run : BOOL
VAR_INPUT
  speed : INT;
END_VAR
]]></Declaration>
    </Method>
    <Property Name=\"Speed\" Id=\"{3}\">
      <Declaration><![CDATA[PROPERTY Speed : INT]]></Declaration>
      <Get Name=\"Get\" Id=\"{4}\">
        <Declaration><![CDATA[]]></Declaration>
      </Get>
    </Property>
  </Itf>
</TcPlcObject>";
    let (lib, msgs, _) = read_text("I_Run.TcIO", text);
    assert!(msgs.is_empty(), "{msgs:?}");
    let Element::Pou(i) = &lib.elements[0] else {
        panic!("{:?}", lib.elements)
    };
    assert!(i.oop.interface && i.name.is("I_Run"));
    // The library namespace `__SYSTEM.` is dropped by the lexer (lexer/namespace.rs).
    assert!(i.oop.implements[0].is("IQueryInterface"));
    let m = &i.oop.methods[0];
    assert!(m.pou.name.is("Run") && m.modifiers.is_abstract);
    assert_eq!(m.pou.var_blocks[0].vars[0].names[0].name, "speed");
    let p = &i.oop.properties[0];
    assert!(p.name.is("Speed") && p.get.is_some() && p.set.is_none());
}

#[test]
fn a_graphical_implementation_is_reported() {
    let text = "<TcPlcObject><POU Name=\"p\"><Declaration><![CDATA[PROGRAM p]]></Declaration>
<Implementation>
  <SFC>…</SFC>
</Implementation></POU></TcPlcObject>";
    let (lib, msgs, _) = read_text("p.TcPOU", text);
    assert_eq!(lib.elements.len(), 1);
    assert!(
        msgs[0].starts_with("p.TcPOU:3:3: error[E190]: POU p: TwinCAT's <SFC> body is not read"),
        "{msgs:?}"
    );
}

#[test]
fn files_are_recognised_by_extension_or_root() {
    assert!(is_twincat("a/B.TcPOU", ""));
    assert!(is_twincat("b.tcgvl", ""));
    assert!(is_twincat(
        "x.xml",
        "<?xml version=\"1.0\"?>\n<TcPlcObject>"
    ));
    assert!(!is_twincat("x.st", "PROGRAM p END_PROGRAM"));
    // The sniffed head ends inside no character.
    let mut text = "x".repeat(1023);
    text.push('é');
    assert!(!is_twincat("x", &text));
}

#[test]
fn a_project_lists_its_sources() {
    let proj = r#"<?xml version="1.0" encoding="utf-8"?>
<Project DefaultTargets="Build" xmlns="http://schemas.microsoft.com/developer/msbuild/2003">
  <ItemGroup>
    <Folder Include="POUs" />
  </ItemGroup>
  <ItemGroup>
    <Compile Include="DUTs\Pair.TcDUT">
      <SubType>Code</SubType>
    </Compile>
    <Compile Include="POUs\Time&amp;Date\MAIN.TcPOU" />
    <Compile Include="Visu.TcVIS" />
    <Compile Include="PlcTask.TcTTO" />
  </ItemGroup>
</Project>"#;
    let mut map = SourceMap::new();
    let mut d = Diagnostics::new();
    let files = project_files(&mut map, "p.plcproj", proj, &mut d);
    assert!(d.items.is_empty());
    let names: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "DUTs/Pair.TcDUT",
            "POUs/Time&Date/MAIN.TcPOU",
            "PlcTask.TcTTO"
        ]
    );
    assert_eq!(map.position(files[1].1).to_string(), "p.plcproj:10:5");

    let files = project_files(&mut map, "q.plcproj", "<Solution/>", &mut d);
    assert!(files.is_empty());
    assert!(d.items[0].render(&map).contains("error[E055]"));
}

#[test]
fn no_cut_of_a_file_panics_and_every_problem_is_coded() {
    let mut ends: Vec<usize> = (0..=FB.len()).filter(|&i| FB.is_char_boundary(i)).collect();
    ends.retain(|&i| i % 3 == 0 || FB[..i].ends_with('>'));
    for end in ends {
        let (_, msgs, _) = read_text("cut.TcPOU", &FB[..end]);
        for m in msgs {
            assert!(
                m.contains(": error[E") || m.contains(": warning[W"),
                "{end}: {m}"
            );
        }
    }
}

#[test]
fn an_accessor_may_start_with_an_access_specifier() {
    // TwinCAT writes `PROTECTED` (or another access word) at the top of a <Set>'s declaration.
    let text =
        "<TcPlcObject><POU Name=\"F\"><Declaration><![CDATA[FUNCTION_BLOCK F]]></Declaration>
<Property Name=\"P\"><Declaration><![CDATA[PROPERTY P : INT]]></Declaration>
<Set Name=\"Set\"><Declaration><![CDATA[PROTECTED
VAR
  old : INT;
END_VAR
]]></Declaration><Implementation><ST><![CDATA[old := P;]]></ST></Implementation></Set>
</Property></POU></TcPlcObject>";
    let (lib, msgs, _) = read_text("F.TcPOU", text);
    assert!(msgs.is_empty(), "{msgs:?}");
    let Element::Pou(f) = &lib.elements[0] else {
        panic!("{:?}", lib.elements)
    };
    let set = f.oop.properties[0].set.as_ref().unwrap();
    assert!(set.var_blocks.iter().any(|b| b.vars[0].names[0].is("old")));
}

#[test]
fn an_enumeration_with_a_text_list_is_its_declaration() {
    let text = "<?xml version=\"1.0\" encoding=\"utf-8\"?>
<TcPlcObject Version=\"1.1.0.1\">
  <EnumerationTextList Name=\"E_Mode\" Id=\"{00000000-0000-0000-0000-000000000009}\">
    <Declaration><![CDATA[{attribute 'to_string'}
TYPE E_Mode :
(
\tIdle := 0,
\tRun
)BYTE;
END_TYPE
]]></Declaration>
    <XmlArchive>
      <Data>
        <o xml:space=\"preserve\" t=\"TextListEnumerationTextListObject\" />
      </Data>
    </XmlArchive>
  </EnumerationTextList>
</TcPlcObject>";
    let (lib, msgs, _) = read_text("E_Mode.TcTLEO", text);
    assert!(msgs.iter().all(|m| !m.contains("error")), "{msgs:?}");
    assert!(
        matches!(lib.elements.as_slice(), [Element::Types(t)] if t[0].name.name == "E_Mode"),
        "{:?}",
        lib.elements.len()
    );
}
