//! Vendor libraries run (`--lib codesys`, `--lib pcworx`): CODESYS's `TIME()` and `SIZEOF`,
//! PCWorx's `GET_CHAR`, `X_TO_STRING(value, format)` and `MUL_T_AI`/`DIV_T_AI`, each program
//! on machine code and on the VM in step (the same memory after every scan), with the
//! values the vendors' documentation gives. These programs need a library, so they are
//! here rather than in the standard corpus (which blark, a strict grammar, also reads).

use petriplc_iec::{build, vendor_libs_for, IecError, Natives, Select, Sources};
use petriplc_iec_vm::{display, Backend, Machine};

/// Runs `src` with `libs` for `scans` scans `period_ns` apart (the first at 0) on machine code
/// and the VM; returns `name = value` of `names` after the last scan.
fn run(libs: &[&str], src: &str, scans: i64, period_ns: i64, names: &[&str]) -> Vec<String> {
    run_file("t.st", libs, src, scans, period_ns, names)
}

/// [`run`] for a file named `file` (`.il`: Instruction List).
fn run_file(
    file: &str,
    libs: &[&str],
    src: &str,
    scans: i64,
    period_ns: i64,
    names: &[&str],
) -> Vec<String> {
    let mut s = Sources::new();
    s.add_text(file, src);
    s.libs = libs.iter().map(|l| l.to_string()).collect();
    let b = build(&s, &Select::Auto, Natives::default()).unwrap_or_else(|e| panic!("{e}"));
    let engine = b.engine;
    assert!(engine.is_compiled(), "no machine code was made");
    let mut m = Machine::new(engine.clone());
    let mut vm = Machine::new(engine.clone());
    vm.set_backend(Backend::Vm);
    let slots = engine.code.init.len() as u32;
    for k in 0..scans {
        let now = k * period_ns;
        let (a, b) = (m.scan(now, &mut || true), vm.scan(now, &mut || true));
        assert_eq!(
            a.map_err(|f| f.to_string()),
            b.map_err(|f| f.to_string()),
            "scan {k}"
        );
        for a in 0..slots {
            assert_eq!(m.slot(a), vm.slot(a), "scan {k}: slot {a} differs");
        }
    }
    let inst = engine.instances()[0].name.clone();
    names
        .iter()
        .map(|n| {
            let v = engine
                .lookup(&format!("{inst}.{n}"))
                .unwrap_or_else(|| panic!("no variable {n}"));
            let x = m.get(v).unwrap();
            format!("{n} = {}", display(&engine.project, v.ty, &x))
        })
        .collect()
}

const MS: i64 = 1_000_000;

#[test]
fn time_is_the_scan_clock_in_milliseconds() {
    let src = "FUNCTION t_ms : DWORD\nt_ms := TIME_TO_DWORD(TIME());\nEND_FUNCTION\n\
               PROGRAM p\nVAR t : TIME; ms : DWORD; first : TIME; n : INT; END_VAR\n\
               t := TIME(); ms := t_ms();\n\
               IF n = 0 THEN first := t; END_IF; n := n + 1;\nEND_PROGRAM\n";
    assert_eq!(
        run(&["codesys"], src, 3, 10 * MS, &["t", "ms", "first"]),
        ["t = T#20ms", "ms = 20", "first = T#0s"]
    );
    // A clock between two milliseconds reads the one before, as CODESYS's millisecond
    // counter does: the fourth scan is at 4.5 ms.
    assert_eq!(
        run(&["twincat"], src, 4, 1_500_000, &["t", "ms"]),
        ["t = T#4ms", "ms = 4"]
    );
}

#[test]
fn get_char_reads_a_code_and_0_outside_the_string() {
    let src =
        "PROGRAM p\nVAR s : STRING[10] := 'AbC'; a, b, c, d, e : INT; i : USINT := 2; END_VAR\n\
               a := GET_CHAR(s, 1); b := GET_CHAR(s, i); c := GET_CHAR(s, 3);\n\
               d := GET_CHAR(s, 4); e := GET_CHAR(s, -7);\nEND_PROGRAM\n";
    assert_eq!(
        run(&["pcworx"], src, 1, 10 * MS, &["a", "b", "c", "d", "e"]),
        ["a = 65", "b = 98", "c = 67", "d = 0", "e = 0"]
    );
}

#[test]
fn instruction_list_calls_them_too() {
    let src = "PROGRAM p\nVAR c : INT; s : STRING := 'abc'; t : TIME; END_VAR\n\
               LD s\nGET_CHAR 2\nST c\nLD T#2s\nMUL_T_AI 3\nST t\nEND_PROGRAM\n";
    assert_eq!(
        run_file("p.il", &["pcworx"], src, 1, 10 * MS, &["c", "t"]),
        ["c = 98", "t = T#6s"]
    );
}

#[test]
fn to_string_with_a_format_is_c_printf() {
    let src = "PROGRAM p\nVAR a, b, c, d, e, f, g : STRING; s3 : STRING[3]; \
               fmt : STRING := '%02dm'; h : INT := 7; r : REAL := 2.5; u : UDINT := 9; END_VAR\n\
               a := BYTE_TO_STRING(BYTE#10, '%02X'); b := INT_TO_STRING(-5, '%04d');\n\
               c := REAL_TO_STRING(r, '%.2f'); d := INT_TO_STRING(h, fmt);\n\
               e := UDINT_TO_STRING(u, '%02us'); f := BYTE_TO_STRING(BYTE#65, '%c');\n\
               g := DWORD_TO_STRING(DWORD#16#FFFFFFFF, '%u');\n\
               s3 := DWORD_TO_STRING(DWORD#123456, '%u');\nEND_PROGRAM\n";
    assert_eq!(
        run(
            &["pcworx"],
            src,
            1,
            10 * MS,
            &["a", "b", "c", "d", "e", "f", "g", "s3"]
        ),
        [
            "a = '0A'",
            "b = '-005'",
            "c = '2.50'",
            "d = '07m'",
            "e = '09s'",
            "f = 'A'",
            "g = '4294967295'",
            "s3 = '123'"
        ]
    );
}

#[test]
fn time_times_an_integer_and_sizeof() {
    let src = "PROGRAM p\nVAR t, u : TIME; k : INT := 3; n : UDINT; a : ARRAY[0..4] OF INT; END_VAR\n\
               t := MUL_T_AI(T#1s, k); u := DIV_T_AI(t, 2); n := SIZEOF(a) + SIZEOF(LREAL);\nEND_PROGRAM\n";
    assert_eq!(
        run(&["pcworx", "codesys"], src, 1, 10 * MS, &["t", "u", "n"]),
        ["t = T#3s", "u = T#1s500ms", "n = 18"]
    );
}

#[test]
fn twincat_character_functions() {
    let src = "PROGRAM p\nVAR a, z : BYTE; s, e : STRING[4]; t : STRING[4] := 'xyz'; END_VAR\n\
               a := F_ToASC(t); z := F_ToASC(''); s := F_ToCHR(16#31); e := F_ToCHR(0);\n\
               s := CONCAT(s, F_ToCHR(a));\nEND_PROGRAM\n";
    assert_eq!(
        run(&["twincat"], src, 1, 10 * MS, &["a", "z", "s", "e"]),
        ["a = 120", "z = 0", "s = '1x'", "e = ''"]
    );
}

#[test]
fn codesys_util_analog_monitors() {
    // IN goes 70, 40, 70, 101, 70, 49 (one value a scan) against HIGH 100, LOW 50.
    let src = "PROGRAM p\nVAR h : HYSTERESIS; a : LIMITALARM; k : INT; x : INT; \
               xs : ARRAY[0..5] OF INT := [70, 40, 70, 101, 70, 49]; trace, alarms : STRING; END_VAR\n\
               x := xs[k]; k := k + 1;\n\
               h(IN := x, HIGH := 100, LOW := 50); a(IN := x, HIGH := 100, LOW := 50);\n\
               trace := CONCAT(trace, BOOL_TO_STRING(h.OUT));\n\
               IF a.O THEN alarms := CONCAT(alarms, 'O'); ELSIF a.U THEN alarms := CONCAT(alarms, 'U');\n\
               ELSIF a.IL THEN alarms := CONCAT(alarms, '-'); END_IF;\nEND_PROGRAM\n";
    assert_eq!(
        run(&["codesys"], src, 6, 10 * MS, &["trace", "alarms"]),
        ["trace = 'FALSETRUETRUEFALSEFALSETRUE'", "alarms = '-U-O-U'"]
    );
    // Without the library, HYSTERESIS is petriplc's DSP block (X, XON, XOFF → Q).
    let dsp = "PROGRAM p\nVAR h : HYSTERESIS; q : BOOL; END_VAR\nh(X := 5.0, XON := 4.0, XOFF := 1.0); q := h.Q;\nEND_PROGRAM\n";
    assert_eq!(run(&[], dsp, 1, 10 * MS, &["q"]), ["q = 1"]);
    // A user's function block of that name is used instead, library or not.
    let own = "FUNCTION_BLOCK HYSTERESIS\nVAR_INPUT IN : INT; END_VAR\nVAR_OUTPUT OUT : INT; END_VAR\nOUT := IN * 2;\nEND_FUNCTION_BLOCK\n\
               PROGRAM p\nVAR h : HYSTERESIS; y : INT; END_VAR\nh(IN := 4); y := h.OUT;\nEND_PROGRAM\n";
    assert_eq!(run(&["codesys"], own, 1, 10 * MS, &["y"]), ["y = 8"]);
    assert_eq!(run(&[], own, 1, 10 * MS, &["y"]), ["y = 8"]);
}

#[test]
fn libraries_are_named_and_dialects_map_to_them() {
    let mut s = Sources::new();
    s.add_text("t.st", "PROGRAM p\nEND_PROGRAM\n");
    s.libs = vec!["siemens".into()];
    match build(&s, &Select::Auto, Natives::default()) {
        Err(IecError::UnknownLibrary(m)) => assert_eq!(
            m,
            "unknown vendor library `siemens`; the libraries are codesys, twincat, pcworx, beremiz"
        ),
        Err(e) => panic!("{e}"),
        Ok(_) => panic!("accepted an unknown library"),
    }
    assert_eq!(vendor_libs_for("pcworx"), ["pcworx"]);
    // Without the library the call is refused, naming the library.
    s.libs = Vec::new();
    s.add_text(
        "u.st",
        "FUNCTION f : INT\nf := GET_CHAR('a', 1);\nEND_FUNCTION\n",
    );
    let e = build(&s, &Select::Auto, Natives::default())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("u.st:2:6: error[E180]: GET_CHAR is a PCWorx function: add --lib pcworx"),
        "{e}"
    );
}

/// Beremiz's library (`--lib beremiz`): SVGHMI's types are their base types, LOGGER takes
/// its message, and the Python blocks never answer (ACK stays FALSE, RESULT empty: petriplc
/// runs no Python); python_gear triggers its python_eval every N-th cycle.
#[test]
fn beremiz_library_runs_without_python() {
    let src = "PROGRAM main
VAR
  n : HMI_INT := 40; r : HMI_REAL := 1.5; s : HMI_STRING := 'x'; b : HMI_BOOL;
  log : LOGGER; py : python_eval; poll : python_poll; gear : python_gear;
  acks : INT; level : LOGLEVEL;
END_VAR
n := n + 1;
log(TRIG := NOT log.TRIG, MSG := s, LEVEL := LOGLEVEL#WARNING);
py(TRIG := TRUE, CODE := '1+1');
poll(TRIG := TRUE, CODE := 'x()');
gear(N := 2, TRIG := TRUE, CODE := 'y()');
IF py.ACK OR poll.ACK OR gear.ACK OR py.RESULT <> '' THEN acks := acks + 1; END_IF;
b := gear.COUNTER = 1;
level := log.LEVEL;
END_PROGRAM";
    assert_eq!(
        run(&["beremiz"], src, 3, 10 * MS, &["n", "acks", "b", "level"]),
        ["n = 43", "acks = 0", "b = 1", "level = WARNING"]
    );
}

/// A PLCopen project Beremiz wrote loads the library without being asked; a project that
/// declares one of its names keeps its own.
#[test]
fn a_beremiz_project_loads_the_beremiz_library() {
    let xml = |extra: &str| {
        format!(
            r#"<?xml version="1.0" encoding="utf-8"?>
<project xmlns="http://www.plcopen.org/xml/tc6_0201">
  <fileHeader companyName="Unknown" productName="Unnamed" productVersion="1" creationDateTime="2024-01-01T00:00:00"/>
  <contentHeader name="Unnamed"><coordinateInfo><fbd><scaling x="0" y="0"/></fbd><ld><scaling x="0" y="0"/></ld><sfc><scaling x="0" y="0"/></sfc></coordinateInfo></contentHeader>
  <types><dataTypes>{extra}</dataTypes><pous>
    <pou name="main" pouType="program">
      <interface><localVars>
        <variable name="v"><type><derived name="HMI_INT"/></type></variable>
        <variable name="s"><type><derived name="HMI_STRING"/></type><initialValue><simpleValue value="blup"/></initialValue></variable>
      </localVars></interface>
      <body><ST><xhtml:p xmlns:xhtml="http://www.w3.org/1999/xhtml"><![CDATA[v := v + LEN(s);]]></xhtml:p></ST></body>
    </pou>
  </pous></types>
  <instances><configurations/></instances>
</project>"#
        )
    };
    for (extra, base) in [
        ("", "INT"),
        (
            r#"<dataType name="HMI_INT"><baseType><DINT/></baseType></dataType>"#,
            "DINT",
        ),
    ] {
        let mut s = Sources::new();
        s.add_text("plc.xml", &xml(extra));
        assert_eq!(s.libs(), ["beremiz"]);
        let b = build(&s, &Select::Auto, Natives::default()).unwrap_or_else(|e| panic!("{e}"));
        let mut m = Machine::new(b.engine.clone());
        m.scan(0, &mut || true).unwrap();
        let v = b.engine.lookup("main.v").expect("v");
        assert_eq!(display(&b.engine.project, v.ty, &m.get(v).unwrap()), "4");
        assert_eq!(b.engine.project.types.name(v.ty), base);
    }
    // Not Beremiz: nothing loaded, HMI_INT unknown.
    let mut s = Sources::new();
    s.add_text(
        "plc.xml",
        &xml("").replace(
            r#"companyName="Unknown" productName="Unnamed""#,
            r#"companyName="3S" productName="CODESYS""#,
        ),
    );
    assert!(s.libs().is_empty());
    let e = build(&s, &Select::Auto, Natives::default())
        .err()
        .expect("refused")
        .to_string();
    assert!(e.contains("unknown type `HMI_INT`"), "{e}");
}

/// matiec's RTC (in `beremiz`): set to PDT on IN's rising edge, then running on with the
/// scan clock; without IN, the PLC clock (the scan clock from 1970).
#[test]
fn rtc_runs_from_the_time_it_was_set() {
    let src = "PROGRAM main
VAR c : RTC; free : RTC; k : INT; ok : BOOL; q : BOOL; off : BOOL; END_VAR
k := k + 1;
c(IN := TRUE, PDT := DT#2024-01-01-00:00:00);
free(IN := FALSE);
ok := c.CDT = DT#2024-01-01-00:00:00 + INT_TO_TIME(k - 1) * 10;
off := free.CDT = DT#1970-01-01-00:00:00 + INT_TO_TIME(k - 1) * 10;
q := c.Q AND NOT free.Q;
END_PROGRAM";
    assert_eq!(
        run(&["beremiz"], src, 3, 10 * MS, &["k", "ok", "off", "q"]),
        ["k = 3", "ok = 1", "off = 1", "q = 1"]
    );
}

/// matiec's PID, INTEGRAL and DERIVATIVE (in `beremiz`): CYCLE counts in seconds; in manual
/// the PID's output is KP * X0; they replace petriplc's DSP PID without a warning.
#[test]
fn matiec_pid_integral_and_derivative() {
    let src = "PROGRAM main
VAR
  man : PID; i : INTEGRAL; d : DERIVATIVE; k : INT;
  out : REAL; sum : REAL; rate : REAL;
END_VAR
k := k + 1;
man(AUTO := FALSE, PV := 3.0, SP := 1.0, X0 := 5.0, KP := 2.0, TR := 4.0, TD := 0.0,
    CYCLE := T#100ms);
out := man.XOUT;
i(RUN := TRUE, R1 := k = 1, XIN := 2.0, X0 := 1.0, CYCLE := T#100ms);
sum := i.XOUT;
d(RUN := k > 1, XIN := INT_TO_REAL(k), CYCLE := T#100ms);
rate := d.XOUT;
END_PROGRAM";
    // INTEGRAL: 1.0 at reset, then + 2.0 * 0.1 s per call. DERIVATIVE of XIN = k (10 per
    // second): (3 * (5 - 2) + 4 - 3) / (10 * 0.1) = 10 at k = 5.
    assert_eq!(
        run(&["beremiz"], src, 5, 100 * MS, &["out", "sum", "rate"]),
        ["out = 10.0", "sum = 1.8000002", "rate = 10.0"]
    );
    let mut s = Sources::new();
    s.libs = vec!["beremiz".into()];
    s.add_text("t.st", src);
    let checked = petriplc_iec::check(&s, &Natives::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(checked.warnings.is_empty(), "{:?}", checked.warnings);
}

/// An ANY input kept whole (`stored := Item`, an AnyType holding the caller's address) keeps
/// the caller's pointer: a METHOD's own variable given to it is E201, while one given to an
/// input that only reads it (`F_Size(Item)`, a T_Generic input) is accepted.
#[test]
fn an_any_input_kept_whole_keeps_the_callers_address() {
    let src = "{attribute 'TcTypeSystem'}
TYPE T_Generic : __SYSTEM.AnyType; END_TYPE
FUNCTION F_Size : DINT
VAR_INPUT A : T_Generic; END_VAR
F_Size := A.diSize;
END_FUNCTION
FUNCTION_BLOCK FB_Store
VAR stored : T_Generic; END_VAR
METHOD Keep
VAR_INPUT Item : ANY; END_VAR
stored := Item;
END_METHOD
METHOD Size : DINT
VAR_INPUT Item : ANY; END_VAR
Size := F_Size(Item);
END_METHOD
END_FUNCTION_BLOCK
FUNCTION_BLOCK FB_User
VAR s : FB_Store; n : DINT; END_VAR
METHOD Use
VAR x : INT; END_VAR
n := s.Size(x);
s.Keep(x);
END_METHOD
END_FUNCTION_BLOCK
PROGRAM main
VAR u : FB_User; END_VAR
u.Use();
END_PROGRAM";
    let mut s = Sources::new();
    s.add_text("t.st", src);
    let errors = match build(&s, &Select::Auto, Natives::default()) {
        Ok(_) => panic!("built"),
        Err(e) => e.to_string(),
    };
    let lines: Vec<&str> = errors.lines().filter(|l| l.contains("error[")).collect();
    assert_eq!(lines.len(), 1, "{errors}");
    assert!(lines[0].starts_with("t.st:23:8: error[E201]"), "{errors}");
}

/// A structure input holding a pointer (a T_Generic) whose field the callee stores in a
/// global keeps the caller's address: a METHOD's own variable put in it is E201.
#[test]
fn a_pointer_field_of_a_structure_input_kept_keeps_the_callers_address() {
    let src = "{attribute 'TcTypeSystem'}
TYPE T_Generic : __SYSTEM.AnyType; END_TYPE
VAR_GLOBAL g : POINTER TO BYTE; END_VAR
FUNCTION F_Keep : BOOL
VAR_INPUT A : T_Generic; END_VAR
VAR_EXTERNAL g : POINTER TO BYTE; END_VAR
g := A.pValue;
END_FUNCTION
FUNCTION F_Read : DINT
VAR_INPUT A : T_Generic; END_VAR
F_Read := A.diSize + BYTE_TO_DINT(A.pValue^);
END_FUNCTION
FUNCTION_BLOCK FB_User
VAR n : DINT; END_VAR
METHOD Use
VAR x : INT; t : T_Generic; END_VAR
t.pValue := ADR(x);
n := F_Read(t);
F_Keep(t);
END_METHOD
END_FUNCTION_BLOCK
PROGRAM main
VAR u : FB_User; END_VAR
u.Use();
END_PROGRAM";
    let mut s = Sources::new();
    s.add_text("t.st", src);
    let errors = match build(&s, &Select::Auto, Natives::default()) {
        Ok(_) => panic!("built"),
        Err(e) => e.to_string(),
    };
    let lines: Vec<&str> = errors.lines().filter(|l| l.contains("error[")).collect();
    assert_eq!(lines.len(), 1, "{errors}");
    assert!(lines[0].starts_with("t.st:19:8: error[E201]"), "{errors}");
}

/// A block declared in a METHOD's VAR ends with the call: its method may give its own
/// instance as the result (`Get := THIS^;`, TwinCAT-Dynamic-Collections' `Append`), used
/// where it was called (`q.Get(v).Pop();`), but the caller may not keep that result beyond
/// the call (a global: E201), nor the method keep its own VAR's address in the instance.
#[test]
fn a_frame_instance_may_return_itself_but_not_outlive_the_call() {
    let src = |extra: &str| {
        format!(
            "{{attribute 'TcTypeSystem'}}
INTERFACE I_Q
METHOD Pop : BOOL
END_METHOD
METHOD Get : I_Q
VAR_OUTPUT x : DINT; END_VAR
END_METHOD
END_INTERFACE
VAR_GLOBAL g : I_Q; END_VAR
FUNCTION_BLOCK FB_Q IMPLEMENTS I_Q
VAR n : DINT; p : POINTER TO DINT; END_VAR
METHOD Pop : BOOL
n := n - 1;
END_METHOD
METHOD Get : I_Q
VAR_OUTPUT x : DINT; END_VAR
x := n;
Get := THIS^;
END_METHOD
END_FUNCTION_BLOCK
FUNCTION_BLOCK FB_User
METHOD Run : DINT
VAR q : FB_Q; v : DINT; END_VAR
q.Get(v).Pop();
{extra}
Run := v;
END_METHOD
END_FUNCTION_BLOCK
PROGRAM main
VAR u : FB_User; r : DINT; END_VAR
r := u.Run();
END_PROGRAM"
        )
    };
    let errors = |extra: &str| {
        let mut s = Sources::new();
        s.add_text("t.st", &src(extra));
        match build(&s, &Select::Auto, Natives::default()) {
            Ok(_) => Vec::new(),
            Err(e) => e
                .to_string()
                .lines()
                .filter(|l| l.contains("error["))
                .map(str::to_string)
                .collect(),
        }
    };
    assert_eq!(errors(""), Vec::<String>::new());
    let kept = errors("g := q.Get(v);");
    assert_eq!(kept.len(), 1, "{kept:?}");
    assert!(kept[0].starts_with("t.st:25:6: error[E201]"), "{kept:?}");
}

/// In a method of a block that may end with a call, its own variables' addresses stay in it:
/// stored in a global by the method itself, or by a caller from a method that returns one.
#[test]
fn a_frame_instance_keeps_its_variables_addresses_in() {
    let src = "{attribute 'TcTypeSystem'}
VAR_GLOBAL g : POINTER TO DINT; END_VAR
FUNCTION_BLOCK FB_Q
VAR n : DINT; END_VAR
METHOD Leak
g := ADR(n);
END_METHOD
METHOD Keep : POINTER TO DINT
Keep := ADR(THIS^.n);
END_METHOD
END_FUNCTION_BLOCK
FUNCTION_BLOCK FB_User
METHOD Run : DINT
VAR q : FB_Q; END_VAR
q.Leak();
g := q.Keep();
END_METHOD
END_FUNCTION_BLOCK
PROGRAM main
VAR u : FB_User; r : DINT; END_VAR
r := u.Run();
END_PROGRAM";
    let mut s = Sources::new();
    s.add_text("t.st", src);
    let errors = match build(&s, &Select::Auto, Natives::default()) {
        Ok(_) => panic!("built"),
        Err(e) => e.to_string(),
    };
    let lines: Vec<&str> = errors.lines().filter(|l| l.contains("error[")).collect();
    assert_eq!(lines.len(), 2, "{errors}");
    assert!(lines[0].starts_with("t.st:6:6: error[E201]"), "{errors}");
    assert!(lines[1].starts_with("t.st:16:6: error[E201]"), "{errors}");
}
