//! LD and SFC bodies of PLCopen XML: the diagnostics of a graphical body name the element
//! (POU, language, element kind, localId and its variable or name) with stable codes, and
//! the Beremiz SFC sample (traffic light: FBD transitions, LD actions, blocks in the chart)
//! is checked.

use petriplc_iec::{check, Natives, Sources};

/// Checks a project made of one POU `main` with this interface and body; returns the
/// rendered diagnostics (errors and warnings).
fn diagnostics(iface: &str, lang: &str, body: &str) -> String {
    let xml = format!(
        r#"<?xml version="1.0" encoding="utf-8"?>
<project xmlns="http://www.plcopen.org/xml/tc6_0201">
<types><dataTypes/><pous>
<pou name="main" pouType="program">
<interface>{iface}</interface>
<body><{lang}>
{body}
</{lang}></body>
</pou></pous></types>
<instances><configurations/></instances>
</project>"#
    );
    let mut s = Sources::new();
    s.add_text("g.xml", &xml);
    match check(&s, &Natives::default()) {
        Ok(c) => c.warnings.join("\n"),
        Err(e) => e.to_string(),
    }
}

fn check_diag(iface: &str, lang: &str, body: &str, expect: &[&str]) {
    let got = diagnostics(iface, lang, body);
    for e in expect {
        assert!(got.contains(e), "expected `{e}` in:\n{got}");
    }
}

const BOOLS: &str = r#"<inputVars><variable name="a"><type><BOOL/></type></variable></inputVars>
<outputVars><variable name="q"><type><BOOL/></type></variable><variable name="n"><type><INT/></type></variable></outputVars>"#;

#[test]
fn a_connection_to_a_missing_element_names_the_element() {
    check_diag(
        BOOLS,
        "LD",
        r#"<leftPowerRail localId="1"><position x="0" y="0"/></leftPowerRail>
<contact localId="2"><position x="0" y="0"/><connectionPointIn><connection refLocalId="9"/></connectionPointIn><variable>a</variable></contact>
<coil localId="3"><position x="0" y="0"/><connectionPointIn><connection refLocalId="2"/></connectionPointIn><variable>q</variable></coil>"#,
        &["g.xml: POU main, LD contact localId 2 (a): error[E054]: a connection refers to localId 9, which no element of the body has"],
    );
}

#[test]
fn type_and_name_errors_point_at_the_element() {
    check_diag(
        BOOLS,
        "LD",
        r#"<leftPowerRail localId="1"><position x="0" y="0"/></leftPowerRail>
<contact localId="2"><position x="0" y="0"/><connectionPointIn><connection refLocalId="1"/></connectionPointIn><variable>nope</variable></contact>
<coil localId="3"><position x="0" y="0"/><connectionPointIn><connection refLocalId="2"/></connectionPointIn><variable>q</variable></coil>
<contact localId="4"><position x="0" y="0"/><connectionPointIn><connection refLocalId="1"/></connectionPointIn><variable>a</variable></contact>
<coil localId="5"><position x="0" y="0"/><connectionPointIn><connection refLocalId="4"/></connectionPointIn><variable>n</variable></coil>"#,
        &[
            "g.xml: POU main, LD contact localId 2 (nope): error[E100]",
            "g.xml: POU main, LD coil localId 5 (n): error[E110]",
        ],
    );
}

#[test]
fn an_unconnected_coil_and_a_duplicate_local_id_are_reported() {
    check_diag(
        BOOLS,
        "LD",
        r#"<leftPowerRail localId="1"><position x="0" y="0"/></leftPowerRail>
<coil localId="1"><position x="0" y="0"/><connectionPointIn/><variable>q</variable></coil>"#,
        &[
            "error[E054]: localId 1 is used by two elements",
            "LD coil localId 1 (q): error[E054]: <coil> is connected to nothing on its input",
        ],
    );
}

#[test]
fn sfc_structure_errors_name_the_element() {
    check_diag(
        BOOLS,
        "SFC",
        r#"<step localId="1" name="S0"><position x="0" y="0"/></step>
<transition localId="2"><position x="0" y="0"/><connectionPointIn><connection refLocalId="1"/></connectionPointIn><condition><inline name=""><ST><xhtml:p xmlns:xhtml="http://www.w3.org/1999/xhtml">a</xhtml:p></ST></inline></condition></transition>
<jumpStep localId="3" targetName="S9"><position x="0" y="0"/><connectionPointIn><connection refLocalId="2"/></connectionPointIn></jumpStep>
<actionBlock localId="4"><position x="0" y="0"/><connectionPointIn><connection refLocalId="1"/></connectionPointIn><action localId="5" qualifier="X"><reference name="q"/></action></actionBlock>"#,
        &[
            "g.xml: POU main, SFC step localId 1 (S0): error[E054]: the chart has no initial step",
            "SFC jumpStep localId 3 (to S9): error[E054]: the jump goes to step S9, which the chart does not have",
            "SFC actionBlock localId 4: error[E054]: action qualifier X is not one of N, R, S, L, D, P, P0, P1, SD, DS or SL",
        ],
    );
}

#[test]
fn a_very_long_rung_is_refused_not_a_stack_overflow() {
    let mut body =
        String::from(r#"<leftPowerRail localId="1"><position x="0" y="0"/></leftPowerRail>"#);
    for k in 2..5000 {
        body.push_str(&format!(
            r#"<contact localId="{k}"><position x="0" y="0"/><connectionPointIn><connection refLocalId="{}"/></connectionPointIn><variable>a</variable></contact>"#,
            k - 1
        ));
    }
    body.push_str(r#"<coil localId="5000"><position x="0" y="0"/><connectionPointIn><connection refLocalId="4999"/></connectionPointIn><variable>q</variable></coil>"#);
    check_diag(
        BOOLS,
        "LD",
        &body,
        &["error[E054]: this element is more than 256 elements away from a rail"],
    );
}

#[test]
fn a_long_rung_within_the_limit_checks() {
    let mut body =
        String::from(r#"<leftPowerRail localId="1"><position x="0" y="0"/></leftPowerRail>"#);
    for k in 2..250 {
        body.push_str(&format!(
            r#"<contact localId="{k}"><position x="0" y="0"/><connectionPointIn><connection refLocalId="{}"/></connectionPointIn><variable>a</variable></contact>"#,
            k - 1
        ));
    }
    body.push_str(r#"<coil localId="250"><position x="0" y="0"/><connectionPointIn><connection refLocalId="249"/></connectionPointIn><variable>q</variable></coil>"#);
    assert_eq!(diagnostics(BOOLS, "LD", &body), "");
}

#[test]
fn a_function_with_en_feeding_another_block_checks() {
    // ADD's result guarded by EN goes into another function's input (Beremiz's wxGlade
    // test project has STRING_TO_INT so): computed before the statement that uses it.
    let got = diagnostics(
        BOOLS,
        "LD",
        r#"<leftPowerRail localId="1"><position x="0" y="0"/></leftPowerRail>
<contact localId="2"><position x="0" y="0"/><connectionPointIn><connection refLocalId="1"/></connectionPointIn><variable>a</variable></contact>
<inVariable localId="3"><position x="0" y="0"/><connectionPointOut/><expression>n</expression></inVariable>
<block localId="4" typeName="ADD"><position x="0" y="0"/><inputVariables>
<variable formalParameter="EN"><connectionPointIn><connection refLocalId="2"/></connectionPointIn></variable>
<variable formalParameter="IN1"><connectionPointIn><connection refLocalId="3"/></connectionPointIn></variable>
<variable formalParameter="IN2"><connectionPointIn><connection refLocalId="3"/></connectionPointIn></variable>
</inputVariables><inOutVariables/><outputVariables><variable formalParameter="OUT"><connectionPointOut/></variable></outputVariables></block>
<block localId="5" typeName="MUL"><position x="0" y="0"/><inputVariables>
<variable formalParameter="IN1"><connectionPointIn><connection refLocalId="4" formalParameter="OUT"/></connectionPointIn></variable>
<variable formalParameter="IN2"><connectionPointIn><connection refLocalId="3"/></connectionPointIn></variable>
</inputVariables><inOutVariables/><outputVariables><variable formalParameter="OUT"><connectionPointOut/></variable></outputVariables></block>
<outVariable localId="6"><position x="0" y="0"/><connectionPointIn><connection refLocalId="5" formalParameter="OUT"/></connectionPointIn><expression>n</expression></outVariable>"#,
    );
    assert!(!got.contains("error"), "{got}");
}

#[test]
fn edges_and_negations_on_block_pins_check() {
    // A rising input and a negated output of a function block instance are accepted.
    let iface = BOOLS.to_string()
        + r#"<localVars><variable name="p1"><type><derived name="TP"/></type></variable></localVars>"#;
    let got = diagnostics(
        &iface,
        "FBD",
        r#"<inVariable localId="1"><position x="0" y="0"/><connectionPointOut/><expression>a</expression></inVariable>
<block localId="2" typeName="TP" instanceName="p1"><position x="0" y="0"/><inputVariables>
<variable formalParameter="IN" edge="rising"><connectionPointIn><connection refLocalId="1"/></connectionPointIn></variable>
<variable formalParameter="PT"><connectionPointIn><connection refLocalId="3"/></connectionPointIn></variable>
</inputVariables><inOutVariables/><outputVariables><variable formalParameter="Q" negated="true"><connectionPointOut/></variable></outputVariables></block>
<inVariable localId="3"><position x="0" y="0"/><connectionPointOut/><expression>T#1s</expression></inVariable>
<outVariable localId="4"><position x="0" y="0"/><connectionPointIn><connection refLocalId="2" formalParameter="Q"/></connectionPointIn><expression>q</expression></outVariable>"#,
    );
    assert!(!got.contains("error"), "{got}");
}
