//! PLCopen XML projects: a CODESYS-style export runs (one with an interface too), projects
//! the engine cannot run say why, malformed files give positioned errors. (Beremiz's projects
//! and libraries, which are not in the repository: conformance_beremiz.rs.)

use std::path::Path;

use petriplc_iec::{build_file, check, Natives, Select, Sources};
use petriplc_iec_sema::value::Value;
use petriplc_iec_vm::Machine;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");

fn checked(path: &str) -> Result<Vec<String>, String> {
    let mut s = Sources::new();
    s.add_file(Path::new(path)).map_err(|e| e.to_string())?;
    check(&s, &Natives::default())
        .map(|c| c.warnings)
        .map_err(|e| e.to_string())
}

#[test]
fn a_codesys_style_export_runs() {
    let b = build_file(
        Path::new(&format!("{DATA}/codesys_style.xml")),
        &Select::Auto,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let e = b.engine.clone();
    let mut m = Machine::new(e.clone());
    let go = e.lookup("PLC_PRG.go").unwrap();
    let parts = e.lookup("PLC_PRG.counts.parts").unwrap();
    let busy = e.lookup("PLC_PRG.busy").unwrap();
    let limit = e.lookup("PLC_PRG.limits[2]").unwrap();
    assert_eq!(m.get(limit), Some(Value::Int(20)));
    m.set(go, &Value::Int(1)).unwrap();
    let mut busy_seen = Vec::new();
    for k in 0..8 {
        m.scan(k * 10_000_000, &mut || true).unwrap();
        busy_seen.push(m.get(busy) == Some(Value::Int(1)));
    }
    // Running from the first scan until the 30 ms timer fires at t = 40 ms.
    assert_eq!(
        busy_seen,
        [true, true, true, true, false, false, false, false]
    );
    assert_eq!(m.get(parts), Some(Value::Int(1)));
}

#[test]
fn malformed_files_get_positioned_errors() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p.display().to_string()
    };
    let p = write("a.xml", "<project xmlns=\"http://www.plcopen.org/xml/tc6_0201\"><types><pous><pou name=\"x\"></pous></types></project>");
    let e = checked(&p).unwrap_err();
    assert!(
        e.contains("a.xml:1:") && e.contains("error[E050]: malformed XML"),
        "{e}"
    );
    let p = write(
        "b.xml",
        "<pnml xmlns=\"http://www.plcopen.org/xml/tc6_0201\"/>",
    );
    let e = checked(&p).unwrap_err();
    assert!(
        e.contains("b.xml:1:1: error[E051]: the root element is <pnml>"),
        "{e}"
    );
    let p = write(
        "c.xml",
        "<project xmlns=\"http://www.plcopen.org/xml/tc6_0201\"><types><pous>\n<pou name=\"p\" pouType=\"program\"><body><ST><xhtml:p xmlns:xhtml=\"http://www.w3.org/1999/xhtml\"><![CDATA[x := 1;\ny := ;]]></xhtml:p></ST></body></pou>\n</pous></types></project>",
    );
    let e = checked(&p).unwrap_err();
    // The ST body's errors point into the XML file, at the body's own lines.
    assert!(
        e.contains("c.xml:3:6: error[E010]: expected an expression, found `;`"),
        "{e}"
    );
    let p = write(
        "d.xml",
        "<project xmlns=\"http://www.plcopen.org/xml/tc6_0201\"><types><pous>\n<pou name=\"p\" pouType=\"program\"><body><ST><xhtml:p xmlns:xhtml=\"http://www.w3.org/1999/xhtml\"><![CDATA[\n  x := 1;]]></xhtml:p></ST></body></pou>\n</pous></types></project>",
    );
    let e = checked(&p).unwrap_err();
    assert!(
        e.contains("d.xml:3:3: error[E100]: `x` is not declared"),
        "{e}"
    );
}

/// A CODESYS export with an interface (`<Interface>` in the project's `<addData>`, with
/// `<Methods>`), two blocks implementing it (`<Implements>` in their inheritance data) and a
/// program calling through an interface variable.
const CODESYS_ITF: &str = r#"<?xml version="1.0" encoding="utf-8"?>
<project xmlns="http://www.plcopen.org/xml/tc6_0200">
  <types><dataTypes/><pous>
    <pou name="FB_Two" pouType="functionBlock">
      <interface/>
      <body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">;</xhtml></ST></body>
      <addData>
        <data name="http://www.3s-software.com/plcopenxml/method" handleUnknown="implementation">
          <Method name="Scale" ObjectId="1"><interface><returnType><INT/></returnType><inputVars><variable name="x"><type><INT/></type></variable></inputVars></interface><body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">Scale := 2 * x;</xhtml></ST></body></Method>
        </data>
        <data name="http://www.3s-software.com/plcopenxml/pouinheritance" handleUnknown="implementation">
          <Inheritance><Implements>I_Scale</Implements></Inheritance>
        </data>
      </addData>
    </pou>
    <pou name="FB_Ten" pouType="functionBlock">
      <interface/>
      <body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">;</xhtml></ST></body>
      <addData>
        <data name="http://www.3s-software.com/plcopenxml/method" handleUnknown="implementation">
          <Method name="Scale" ObjectId="2"><interface><returnType><INT/></returnType><inputVars><variable name="x"><type><INT/></type></variable></inputVars></interface><body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">Scale := 10 * x;</xhtml></ST></body></Method>
        </data>
        <data name="http://www.3s-software.com/plcopenxml/pouinheritance" handleUnknown="implementation">
          <Inheritance><Implements>I_Scale</Implements></Inheritance>
        </data>
      </addData>
    </pou>
    <pou name="PLC_PRG" pouType="program">
      <interface><localVars>
        <variable name="two"><type><derived name="FB_Two"/></type></variable>
        <variable name="ten"><type><derived name="FB_Ten"/></type></variable>
        <variable name="s"><type><derived name="I_Scale"/></type></variable>
        <variable name="a"><type><INT/></type></variable>
        <variable name="b"><type><INT/></type></variable>
      </localVars></interface>
      <body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">s := two;
a := s.Scale(x := 3);
s := ten;
b := s.Scale(x := 3);</xhtml></ST></body>
    </pou>
  </pous></types>
  <instances><configurations/></instances>
  <addData>
    <data name="http://www.3s-software.com/plcopenxml/interface" handleUnknown="implementation">
      <Interface name="I_Scale" ObjectId="3">
        <Methods>
          <Method name="Scale" ObjectId="4"><interface><returnType><INT/></returnType><inputVars><variable name="x"><type><INT/></type></variable></inputVars></interface><addData/></Method>
        </Methods>
      </Interface>
    </data>
  </addData>
</project>"#;

#[test]
fn a_codesys_interface_dispatches_to_its_implementations() {
    let mut s = Sources::new();
    s.add_text("itf.xml", CODESYS_ITF);
    let b = petriplc_iec::build(&s, &Select::Auto, Natives::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let e = b.engine.clone();
    let mut m = Machine::new(e.clone());
    m.scan(0, &mut || true).unwrap();
    let a = e.lookup("PLC_PRG.a").unwrap();
    let bb = e.lookup("PLC_PRG.b").unwrap();
    assert_eq!(
        (m.get(a), m.get(bb)),
        (Some(Value::Int(6)), Some(Value::Int(30)))
    );
}

#[test]
fn wide_strings_in_a_tc6_project() {
    // <wstring length="…"/> and CODESYS's <WSTRING/>, a "…" initial value and a "…" literal
    // in an ST body (what Beremiz and the OpenPLC editor write for WSTRING).
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("w.xml");
    std::fs::write(
        &p,
        r#"<project xmlns="http://www.plcopen.org/xml/tc6_0201"><types><pous>
<pou name="main" pouType="program"><interface><localVars>
<variable name="w"><type><wstring length="8"/></type><initialValue><simpleValue value="&quot;Grüße&quot;"/></initialValue></variable>
<variable name="v"><type><WSTRING/></type></variable>
<variable name="n"><type><INT/></type></variable>
</localVars></interface>
<body><ST><xhtml:p xmlns:xhtml="http://www.w3.org/1999/xhtml"><![CDATA[v := CONCAT(w, " $20AC");
n := LEN(v);]]></xhtml:p></ST></body></pou>
</pous></types></project>"#,
    )
    .unwrap();
    let b = build_file(&p, &Select::Auto).unwrap_or_else(|e| panic!("{e}"));
    let e = b.engine.clone();
    let mut m = Machine::new(e.clone());
    m.scan(0, &mut || true).unwrap();
    let v = e.lookup("main.v").unwrap();
    let n = e.lookup("main.n").unwrap();
    assert_eq!(
        m.get(v),
        Some(Value::WStr("Grüße €".encode_utf16().collect()))
    );
    assert_eq!(m.get(n), Some(Value::Int(7)));
}
