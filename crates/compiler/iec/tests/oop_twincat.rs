//! Object orientation in TwinCAT 3 files: a `.TcPOU` function block with a `<Method>`, a
//! `<Property>` (`<Get>`, `<Set>`) and an `<Action>`, and one extending it, built and run with
//! a program that uses them (docs/iec.md, "Object orientation").

use petriplc_iec::{build, Natives, Select, Sources};
use petriplc_iec_vm::Machine;

const COUNTER: &str = r#"<?xml version="1.0" encoding="utf-8"?>
<TcPlcObject Version="1.1.0.1">
  <POU Name="FB_Counter" SpecialFunc="None">
    <Declaration><![CDATA[FUNCTION_BLOCK FB_Counter
VAR_OUTPUT
	nCount : INT;
END_VAR]]></Declaration>
    <Implementation>
      <ST><![CDATA[nCount := nCount + 1;]]></ST>
    </Implementation>
    <Method Name="Add">
      <Declaration><![CDATA[METHOD PUBLIC Add : INT
VAR_INPUT
	nBy : INT;
END_VAR]]></Declaration>
      <Implementation>
        <ST><![CDATA[nCount := nCount + nBy;
Add := nCount;]]></ST>
      </Implementation>
    </Method>
    <Property Name="Count">
      <Declaration><![CDATA[PROPERTY Count : INT]]></Declaration>
      <Get Name="Get">
        <Declaration><![CDATA[VAR
END_VAR]]></Declaration>
        <Implementation>
          <ST><![CDATA[Count := nCount;]]></ST>
        </Implementation>
      </Get>
      <Set Name="Set">
        <Declaration><![CDATA[VAR
END_VAR]]></Declaration>
        <Implementation>
          <ST><![CDATA[nCount := Count;]]></ST>
        </Implementation>
      </Set>
    </Property>
    <Action Name="Clear">
      <Implementation>
        <ST><![CDATA[nCount := 0;]]></ST>
      </Implementation>
    </Action>
  </POU>
</TcPlcObject>"#;

const FAST: &str = r#"<?xml version="1.0" encoding="utf-8"?>
<TcPlcObject Version="1.1.0.1">
  <POU Name="FB_Fast" SpecialFunc="None">
    <Declaration><![CDATA[FUNCTION_BLOCK FB_Fast EXTENDS FB_Counter
VAR
END_VAR]]></Declaration>
    <Implementation>
      <ST><![CDATA[SUPER^();
SUPER^();]]></ST>
    </Implementation>
    <Method Name="Add">
      <Declaration><![CDATA[METHOD PUBLIC Add : INT
VAR_INPUT
	nBy : INT;
END_VAR]]></Declaration>
      <Implementation>
        <ST><![CDATA[Add := SUPER^.Add(nBy := 10 * nBy);]]></ST>
      </Implementation>
    </Method>
  </POU>
</TcPlcObject>"#;

const MAIN: &str = "PROGRAM MAIN
VAR
  c : FB_Counter;
  f : FB_Fast;
  a : INT;
  b : INT;
  n : INT;
END_VAR
c();
f();
a := c.Add(nBy := 5);
b := f.Add(nBy := 1);
n := c.Count;
IF n > 20 THEN
  c.Clear();
END_IF;
f.Count := 100;
END_PROGRAM
";

#[test]
fn twincat_methods_properties_actions_and_extends_run() {
    let mut s = Sources::new();
    s.add_text("FB_Counter.TcPOU", COUNTER);
    s.add_text("FB_Fast.TcPOU", FAST);
    s.add_text("MAIN.st", MAIN);
    let b = match build(&s, &Select::Auto, Natives::default()) {
        Ok(b) => b,
        Err(e) => panic!("{e}"),
    };
    let mut m = Machine::new(b.engine.clone());
    let mut seen = Vec::new();
    for k in 0..5 {
        m.scan(k * 10_000_000, &mut || true).unwrap();
        let get = |v: &str| {
            let r = b.engine.lookup(v).unwrap_or_else(|| panic!("no {v}"));
            petriplc_iec_vm::display(&b.engine.project, r.ty, &m.get(r).unwrap())
        };
        seen.push(format!(
            "a={} b={} n={} f={}",
            get("MAIN.a"),
            get("MAIN.b"),
            get("MAIN.n"),
            get("MAIN.f.nCount")
        ));
    }
    // c: +1 by its body, +5 by Add; cleared once it passes 20. f: +2 by its body (the base's,
    // twice), +10 by its Add (the base's, with ten times the input), then set to 100.
    assert_eq!(
        seen,
        [
            "a=6 b=12 n=6 f=100",
            "a=12 b=112 n=12 f=100",
            "a=18 b=112 n=18 f=100",
            "a=24 b=112 n=24 f=100",
            "a=6 b=112 n=6 f=100"
        ]
    );
}

/// An interface as TwinCAT 3 saves it (`.TcIO`): a method and a read-only property, on the
/// implied `__SYSTEM.IQueryInterface`.
const I_COUNTER: &str = r#"<?xml version="1.0" encoding="utf-8"?>
<TcPlcObject Version="1.1.0.1">
  <Itf Name="I_Counter" Id="{6f1d3c1e-0000-0000-0000-000000000001}">
    <Declaration><![CDATA[INTERFACE I_Counter EXTENDS __SYSTEM.IQueryInterface
]]></Declaration>
    <Method Name="Add" Id="{6f1d3c1e-0000-0000-0000-000000000002}">
      <Declaration><![CDATA[METHOD Add : INT
VAR_INPUT
	nBy : INT;
END_VAR
]]></Declaration>
    </Method>
    <Property Name="Count" Id="{6f1d3c1e-0000-0000-0000-000000000003}">
      <Declaration><![CDATA[PROPERTY Count : INT]]></Declaration>
      <Get Name="Get" Id="{6f1d3c1e-0000-0000-0000-000000000004}">
        <Declaration><![CDATA[]]></Declaration>
      </Get>
    </Property>
  </Itf>
</TcPlcObject>"#;

const ITF_MAIN: &str = "PROGRAM MAIN
VAR
  c : FB_Counter;
  f : FB_Fast;
  all : ARRAY[0..1] OF I_Counter;
  i : INT;
  sum : INT;
  n : INT;
END_VAR
all[0] := c;
all[1] := f;
sum := 0;
FOR i := 0 TO 1 DO
  sum := sum + all[i].Add(nBy := 1);
END_FOR;
n := all[1].Count;
END_PROGRAM
";

#[test]
fn a_twincat_interface_dispatches_to_its_implementations() {
    let mut s = Sources::new();
    // The blocks of COUNTER and FAST, FB_Counter now implementing I_Counter (FB_Fast
    // through its base).
    s.add_text(
        "FB_Counter.TcPOU",
        &COUNTER.replace(
            "FUNCTION_BLOCK FB_Counter\n",
            "FUNCTION_BLOCK FB_Counter IMPLEMENTS I_Counter\n",
        ),
    );
    s.add_text("FB_Fast.TcPOU", FAST);
    s.add_text("I_Counter.TcIO", I_COUNTER);
    s.add_text("MAIN.st", ITF_MAIN);
    let b = match build(&s, &Select::Auto, Natives::default()) {
        Ok(b) => b,
        Err(e) => panic!("{e}"),
    };
    let mut m = Machine::new(b.engine.clone());
    let mut seen = Vec::new();
    for k in 0..2 {
        m.scan(k * 10_000_000, &mut || true).unwrap();
        let get = |v: &str| {
            let r = b.engine.lookup(v).unwrap_or_else(|| panic!("no {v}"));
            petriplc_iec_vm::display(&b.engine.project, r.ty, &m.get(r).unwrap())
        };
        seen.push(format!("sum={} n={}", get("MAIN.sum"), get("MAIN.n")));
    }
    // c.Add adds 1, f's Add (dispatched to FB_Fast's override) 10: the blocks' bodies are not
    // called here.
    assert_eq!(seen, ["sum=11 n=10", "sum=22 n=20"]);
}
