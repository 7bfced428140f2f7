//! Object orientation in text: both layouts of methods, properties, actions, modifiers,
//! EXTENDS/IMPLEMENTS, and the words staying usable as names.

use super::*;
use crate::source::SourceMap;

fn parse_src(src: &str) -> (Library, String) {
    let mut map = SourceMap::new();
    let f = map.add("t.st", src);
    let mut d = Diagnostics::new();
    let lib = parse(f, src, &mut d);
    (lib, d.render(&map))
}

fn check(src: &str, expect: &str) {
    let (lib, d) = parse_src(src);
    let mut out = String::new();
    for e in &lib.elements {
        if let Element::Pou(p) = e {
            let o = &p.oop;
            out.push_str(&format!("{} {}", p.kind.keyword(), p.name.name));
            if let Some(x) = &o.extends {
                out.push_str(&format!(" extends {}", x.name));
            }
            for i in &o.implements {
                out.push_str(&format!(" implements {}", i.name));
            }
            if o.modifiers.is_abstract {
                out.push_str(" abstract");
            }
            for m in &o.methods {
                let blocks: Vec<&str> = m.pou.var_blocks.iter().map(|b| b.kind.keyword()).collect();
                let n = match &m.pou.body {
                    Body::St(b) => b.len(),
                    _ => 99,
                };
                out.push_str(&format!(
                    "; method {} {}{} [{}] {n} stmts",
                    m.modifiers.access.keyword(),
                    m.pou.name.name,
                    if m.pou.return_type.is_some() {
                        " : T"
                    } else {
                        ""
                    },
                    blocks.join(" ")
                ));
            }
            for pr in &o.properties {
                out.push_str(&format!(
                    "; property {}{}{}",
                    pr.name.name,
                    if pr.get.is_some() { " get" } else { "" },
                    if pr.set.is_some() { " set" } else { "" }
                ));
            }
            for a in &o.actions {
                out.push_str(&format!("; action {}", a.name.name));
            }
            if let Body::St(b) = &p.body {
                out.push_str(&format!("; body {}", b.len()));
            }
            out.push('\n');
        }
    }
    out.push_str(&d);
    assert_eq!(out.trim_end(), expect.trim_end(), "{src}");
}

#[test]
fn methods_between_the_variables_and_the_body() {
    check(
        "FUNCTION_BLOCK FB_A EXTENDS FB_Base IMPLEMENTS I_One, I_Two
VAR x : INT; END_VAR
METHOD PUBLIC Inc : INT
VAR_INPUT step : INT; END_VAR
VAR_INST calls : INT; END_VAR
x := x + step; Inc := x;
END_METHOD
METHOD PRIVATE Reset
x := 0;
END_METHOD
x := x + 1;
END_FUNCTION_BLOCK",
        "FUNCTION_BLOCK FB_A extends FB_Base implements I_One implements I_Two; method PUBLIC Inc : T [VAR_INPUT VAR_INST] 2 stmts; method PRIVATE Reset [] 1 stmts; body 1",
    );
}

#[test]
fn members_after_the_body_and_after_end_function_block() {
    check(
        "FUNCTION_BLOCK ABSTRACT FB_A
VAR x : INT; END_VAR
x := 1;
METHOD M1 : BOOL
M1 := TRUE;
END_METHOD
END_FUNCTION_BLOCK
METHOD PROTECTED M2
x := 2;
END_METHOD
PROPERTY P : INT
GET
P := x;
END_GET
SET
x := P;
END_SET
END_PROPERTY
ACTION Act:
x := 3;
END_ACTION
PROGRAM main
VAR method : INT; action : INT; get : INT; END_VAR
method := 1; action := method; get := 2;
END_PROGRAM",
        "FUNCTION_BLOCK FB_A abstract; method PUBLIC M1 : T [] 1 stmts; method PROTECTED M2 [] 1 stmts; property P get set; action Act; body 1
PROGRAM main; body 3",
    );
}

#[test]
fn an_interface_is_read_in_both_layouts() {
    // Members inside INTERFACE … END_INTERFACE (the standard's, CODESYS's), a property's
    // GET/SET sections optional; or after END_INTERFACE (blark's, TwinCAT's exports).
    check(
        "INTERFACE I_Run EXTENDS I_Base, I_Other
METHOD Run : BOOL
VAR_INPUT x : INT; END_VAR
END_METHOD
PROPERTY Speed : INT
GET
END_GET
END_PROPERTY
PROPERTY Both : INT
END_PROPERTY
END_INTERFACE
INTERFACE I_Two
END_INTERFACE
METHOD Stop
END_METHOD
PROPERTY Level : REAL
END_PROPERTY
FUNCTION_BLOCK F
END_FUNCTION_BLOCK",
        "FUNCTION_BLOCK I_Run implements I_Base implements I_Other; method PUBLIC Run : T [VAR_INPUT] 0 stmts; property Speed get; property Both get set; body 0
FUNCTION_BLOCK I_Two; method PUBLIC Stop [] 0 stmts; property Level get set; body 0
FUNCTION_BLOCK F; body 0",
    );
}

#[test]
fn an_interface_method_with_a_body_is_refused() {
    check(
        "INTERFACE I_Run
METHOD Run : BOOL
Run := TRUE;
END_METHOD
END_INTERFACE",
        "FUNCTION_BLOCK I_Run; method PUBLIC Run : T [] 0 stmts; body 0
t.st:3:1: error[E010]: METHOD Run of an INTERFACE is a declaration without a body; found `Run`: write the code in the FUNCTION_BLOCKs that implement it",
    );
}

#[test]
fn a_member_outside_a_function_block_is_refused() {
    check(
        "METHOD M
END_METHOD",
        "t.st:1:1: error[E010]: a METHOD, PROPERTY or ACTION belongs to a FUNCTION_BLOCK (an ACTION also to a PROGRAM): write it inside the POU, or right after its END_FUNCTION_BLOCK",
    );
}

#[test]
fn a_method_without_its_end() {
    check(
        "FUNCTION_BLOCK F
METHOD M
x := 1;
END_FUNCTION_BLOCK",
        "FUNCTION_BLOCK F; body 0\nt.st:4:1: error[E011]: M has no END_METHOD; found `END_FUNCTION_BLOCK`",
    );
}
