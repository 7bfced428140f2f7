//! TwinCAT 3 projects using what TwinCAT's libraries and object names give: a GVL's name
//! qualifying its variables (`GVL_Main.nCount`, `{attribute 'qualified_only'}` lists),
//! library namespaces (`Tc2_System.T_MaxString`) and `E.Value`, built from `.TcGVL` and
//! `.TcPOU` files and run on machine code and the VM in step (docs/iec.md, "Vendor
//! libraries").

use petriplc_iec::{build, Natives, Select, Sources};
use petriplc_iec_vm::{display, Backend, Machine};

const GVL: &str = r#"<?xml version="1.0" encoding="utf-8"?>
<TcPlcObject Version="1.1.0.1">
  <GVL Name="GVL_Main" Id="{00000000-0000-0000-0000-000000000001}">
    <Declaration><![CDATA[{attribute 'qualified_only'}
VAR_GLOBAL
    nCount : INT;
    sName : Tc2_System.T_MaxString := 'tc';
END_VAR
]]></Declaration>
  </GVL>
</TcPlcObject>"#;

const PARAMS: &str = r#"<?xml version="1.0" encoding="utf-8"?>
<TcPlcObject Version="1.1.0.1">
  <GVL Name="GVL_Param" Id="{00000000-0000-0000-0000-000000000002}">
    <Declaration><![CDATA[{attribute 'qualified_only'}
VAR_GLOBAL CONSTANT
    nMax : UINT := 3;
END_VAR
]]></Declaration>
  </GVL>
</TcPlcObject>"#;

const MAIN: &str = r#"<?xml version="1.0" encoding="utf-8"?>
<TcPlcObject Version="1.1.0.1">
  <POU Name="MAIN" Id="{00000000-0000-0000-0000-000000000003}" SpecialFunc="None">
    <Declaration><![CDATA[PROGRAM MAIN
VAR
    aSlots : ARRAY[1..GVL_Param.nMax] OF INT;
    nLen : UDINT;
    eType : __SYSTEM.TYPE_CLASS;
    eBase : IBaseLibrary.TypeClass;
    bSame : BOOL;
END_VAR]]></Declaration>
    <Implementation>
      <ST><![CDATA[GVL_Main.nCount := GVL_Main.nCount + 1;
aSlots[GVL_Param.nMax] := GVL_Main.nCount * 10;
nLen := Tc2_Utilities.LEN2(ADR(GVL_Main.sName));
eType := __SYSTEM.TYPE_CLASS.TYPE_LREAL;
eBase := IBaseLibrary.TypeClass.TYPE_LREAL;
bSame := eType = eBase;]]></ST>
    </Implementation>
  </POU>
</TcPlcObject>"#;

fn sources(main: &str) -> Sources {
    let mut s = Sources::new();
    s.add_text("GVL_Main.TcGVL", GVL);
    s.add_text("GVL_Param.TcGVL", PARAMS);
    s.add_text("MAIN.TcPOU", main);
    s
}

#[test]
fn gvl_names_and_library_namespaces_run() {
    let b =
        build(&sources(MAIN), &Select::Auto, Natives::default()).unwrap_or_else(|e| panic!("{e}"));
    let mut m = Machine::new(b.engine.clone());
    let mut vm = Machine::new(b.engine.clone());
    vm.set_backend(Backend::Vm);
    let names = [
        "nCount",
        "MAIN.aSlots[3]",
        "MAIN.nLen",
        "MAIN.eType",
        "MAIN.bSame",
    ];
    let mut seen = Vec::new();
    for k in 0..2 {
        m.scan(k * 10_000_000, &mut || true).unwrap();
        vm.scan(k * 10_000_000, &mut || true).unwrap();
        let get = |m: &Machine, v: &str| {
            let r = b.engine.lookup(v).unwrap_or_else(|| panic!("no {v}"));
            display(&b.engine.project, r.ty, &m.get(r).unwrap())
        };
        let here: Vec<String> = names.iter().map(|v| get(&m, v)).collect();
        let there: Vec<String> = names.iter().map(|v| get(&vm, v)).collect();
        assert_eq!(here, there, "machine code and VM disagree");
        seen.push(here.join(" "));
    }
    assert_eq!(seen, ["1 10 2 TYPE_LREAL 1", "2 20 2 TYPE_LREAL 1"]);
}

#[test]
fn a_name_the_gvl_does_not_hold_is_refused() {
    let main = MAIN.replace("GVL_Main.nCount * 10", "GVL_Main.nMax * 10");
    let e = build(&sources(&main), &Select::Auto, Natives::default())
        .err()
        .expect("accepted");
    let e = e.to_string();
    assert!(
        e.contains("error[E100]: the global variable list GVL_Main has no variable `nMax`"),
        "{e}"
    );
}

/// The file blocks of Tc2_System report ADS's "service not supported" on a rising edge of
/// bExecute and hold it; SysFile's functions report ERR_NOT_IMPLEMENTED.
#[test]
fn file_services_report_that_they_are_unavailable() {
    let main = r#"<?xml version="1.0" encoding="utf-8"?>
<TcPlcObject Version="1.1.0.1">
  <POU Name="MAIN" Id="{00000000-0000-0000-0000-000000000004}" SpecialFunc="None">
    <Declaration><![CDATA[PROGRAM MAIN
VAR
    fbOpen : Tc2_System.FB_FileOpen;
    nScan : INT;
    nRead : SysFile.SysTypes.RTS_IEC_SIZE;
    nResult : SysFile.SysTypes.RTS_IEC_RESULT;
    buf : ARRAY[0..9] OF BYTE;
END_VAR]]></Declaration>
    <Implementation>
      <ST><![CDATA[nScan := nScan + 1;
fbOpen(sPathName := 'C:\log.txt', nMode := FOPEN_MODEWRITE, bExecute := nScan = 2);
nRead := SysFile.SysFileRead(0, ADR(buf), 10, ADR(nResult));]]></ST>
    </Implementation>
  </POU>
</TcPlcObject>"#;
    let mut s = Sources::new();
    s.add_text("MAIN.TcPOU", main);
    let b = build(&s, &Select::Auto, Natives::default()).unwrap_or_else(|e| panic!("{e}"));
    let mut m = Machine::new(b.engine.clone());
    let mut seen = Vec::new();
    for k in 0..3 {
        m.scan(k * 10_000_000, &mut || true).unwrap();
        let get = |v: &str| {
            let r = b.engine.lookup(v).unwrap_or_else(|| panic!("no {v}"));
            display(&b.engine.project, r.ty, &m.get(r).unwrap())
        };
        let names = [
            "MAIN.fbOpen.bError",
            "MAIN.fbOpen.nErrId",
            "MAIN.nRead",
            "MAIN.nResult",
        ];
        seen.push(names.map(get).join(" "));
    }
    assert_eq!(seen, ["0 0 0 10", "1 1793 0 10", "1 1793 0 10"]);
}

/// GETCPUCOUNTER gives the scan's clock in 100 ns, as two DWORD halves (TcUnit joins them
/// into an LWORD to time its tests), on machine code and the VM alike.
#[test]
fn cpu_counter_follows_the_scan_clock() {
    let src = "{attribute 'TcTypeSystem'}\n\
               PROGRAM main\nVAR\n  counter : GETCPUCOUNTER;\n  ticks : LWORD;\nEND_VAR\n\
               counter();\n\
               ticks := SHL(DWORD_TO_LWORD(counter.cpuCntHiDW), 32) + DWORD_TO_LWORD(counter.cpuCntLoDW);\n\
               END_PROGRAM\n";
    let mut s = Sources::new();
    s.add_text("main.st", src);
    let b = build(&s, &Select::Auto, Natives::default()).unwrap_or_else(|e| panic!("{e}"));
    let mut m = Machine::new(b.engine.clone());
    let mut vm = Machine::new(b.engine.clone());
    vm.set_backend(Backend::Vm);
    let r = b.engine.lookup("main.ticks").expect("main.ticks");
    let mut seen = Vec::new();
    for now in [0, 10_000_000, 500_000_000_000] {
        m.scan(now, &mut || true).unwrap();
        vm.scan(now, &mut || true).unwrap();
        let (a, v) = (m.get(r).unwrap(), vm.get(r).unwrap());
        assert_eq!(a, v, "machine code and VM disagree");
        seen.push(display(&b.engine.project, r.ty, &a));
    }
    assert_eq!(seen, ["0", "100000", "5000000000"]);
}

/// A structure (a `.TcDUT`, read before the GVLs) whose bounds are a GVL's constants, as
/// TcUnit's `ST_TestSuiteResult` has them.
#[test]
fn a_type_takes_its_bounds_from_a_gvl_constant() {
    const DUT: &str = r#"<?xml version="1.0" encoding="utf-8"?>
<TcPlcObject Version="1.1.0.1">
  <DUT Name="ST_Slots" Id="{00000000-0000-0000-0000-000000000004}">
    <Declaration><![CDATA[TYPE ST_Slots :
STRUCT
    aSlots : ARRAY[1..GVL_Param.nMax] OF INT;
    nId : UINT(0..GVL_Param.nMax);
END_STRUCT
END_TYPE
]]></Declaration>
  </DUT>
</TcPlcObject>"#;
    let main = MAIN
        .replace(
            "aSlots : ARRAY[1..GVL_Param.nMax] OF INT;",
            "aSlots : ARRAY[1..GVL_Param.nMax] OF INT;\n    st : ST_Slots;",
        )
        .replace(
            "bSame := eType = eBase;",
            "bSame := eType = eBase;\nst.aSlots[GVL_Param.nMax] := 7;\nst.nId := GVL_Param.nMax;",
        );
    let mut s = Sources::new();
    s.add_text("ST_Slots.TcDUT", DUT);
    s.add_text("GVL_Main.TcGVL", GVL);
    s.add_text("GVL_Param.TcGVL", PARAMS);
    s.add_text("MAIN.TcPOU", &main);
    let b = build(&s, &Select::Auto, Natives::default()).unwrap_or_else(|e| panic!("{e}"));
    let mut m = Machine::new(b.engine.clone());
    m.scan(0, &mut || true).unwrap();
    let get = |v: &str| {
        let r = b.engine.lookup(v).unwrap_or_else(|| panic!("no {v}"));
        display(&b.engine.project, r.ty, &m.get(r).unwrap())
    };
    assert_eq!(
        (get("MAIN.st.aSlots[3]"), get("MAIN.st.nId")),
        ("7".into(), "3".into())
    );
}
