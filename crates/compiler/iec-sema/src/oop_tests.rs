//! The checker's rules of object orientation (docs/iec.md, "Object orientation"): each misuse
//! with its code and message, and what is accepted.

use crate::tests::check_src;

const BASE: &str = "FUNCTION_BLOCK b
VAR x : INT; END_VAR
METHOD PUBLIC get_x : INT
get_x := x;
END_METHOD
METHOD PRIVATE secret : INT
secret := 1;
END_METHOD
METHOD PROTECTED inner : INT
inner := secret();
END_METHOD
METHOD FINAL fixed
END_METHOD
END_FUNCTION_BLOCK
";

#[test]
fn members_are_used_where_they_are_visible() {
    check_src(
        &format!(
            "{BASE}FUNCTION_BLOCK d EXTENDS b
METHOD m : INT
m := inner() + get_x() + x;
END_METHOD
END_FUNCTION_BLOCK
PROGRAM p
VAR i : d; n : INT; END_VAR
n := i.get_x() + i.m();
i.fixed();
END_PROGRAM"
        ),
        "ok",
    );
}

#[test]
fn private_and_protected_members_are_refused_outside() {
    check_src(
        &format!(
            "{BASE}FUNCTION_BLOCK d EXTENDS b
METHOD m : INT
m := secret();
END_METHOD
END_FUNCTION_BLOCK
PROGRAM p
VAR i : b; n : INT; END_VAR
n := i.secret();
n := i.inner();
END_PROGRAM"
        ),
        "t.st:17:6: error[E213]: secret is PRIVATE in b: only the code of b can use it; declare it PUBLIC to call it from here
t.st:22:8: error[E213]: secret is PRIVATE in b: only the code of b can use it; declare it PUBLIC to call it from here
t.st:23:8: error[E213]: inner is PROTECTED in b: only b and the blocks that extend it can use it; declare it PUBLIC to call it from here",
    );
}

#[test]
fn a_final_method_is_not_overridden_and_a_final_block_not_extended() {
    check_src(
        &format!(
            "{BASE}FUNCTION_BLOCK d EXTENDS b
METHOD fixed
END_METHOD
END_FUNCTION_BLOCK
FUNCTION_BLOCK FINAL f
END_FUNCTION_BLOCK
FUNCTION_BLOCK g EXTENDS f
END_FUNCTION_BLOCK"
        ),
        "t.st:16:8: error[E212]: fixed is FINAL in b and cannot be overridden; rename this method or remove FINAL there
t.st:21:26: error[E212]: f is FINAL and cannot be extended; remove FINAL from it or extend another block",
    );
}

#[test]
fn an_abstract_block_is_not_instantiated_and_its_methods_are_implemented() {
    check_src(
        "FUNCTION_BLOCK ABSTRACT shape
METHOD ABSTRACT area : REAL
END_METHOD
END_FUNCTION_BLOCK
FUNCTION_BLOCK square EXTENDS shape
END_FUNCTION_BLOCK
FUNCTION_BLOCK circle EXTENDS shape
METHOD area : REAL
area := 3.14;
END_METHOD
END_FUNCTION_BLOCK
PROGRAM p
VAR s : shape; c : circle; a : REAL; END_VAR
a := c.area();
END_PROGRAM",
        "t.st:5:16: error[E212]: square is not ABSTRACT but has the ABSTRACT method area without an implementation; implement area or declare FUNCTION_BLOCK ABSTRACT square
t.st:13:5: error[E212]: shape is ABSTRACT and cannot be instantiated; declare an instance of a block that extends it",
    );
}

#[test]
fn an_override_keeps_the_signature() {
    check_src(
        "FUNCTION_BLOCK a
METHOD m : INT
VAR_INPUT k : INT; END_VAR
m := k;
END_METHOD
END_FUNCTION_BLOCK
FUNCTION_BLOCK b EXTENDS a
METHOD m : INT
VAR_INPUT k : REAL; END_VAR
m := 1;
END_METHOD
END_FUNCTION_BLOCK",
        "t.st:8:8: error[E214]: m overrides a's m with other parameters: (result INT, K : REAL) instead of (result INT, K : INT); give it the same inputs, outputs, in-outs and result type",
    );
}

#[test]
fn extends_names_a_function_block_and_ends() {
    check_src(
        "FUNCTION_BLOCK a EXTENDS missing
END_FUNCTION_BLOCK
FUNCTION_BLOCK c EXTENDS Lib.base
END_FUNCTION_BLOCK
FUNCTION_BLOCK x EXTENDS y
END_FUNCTION_BLOCK
FUNCTION_BLOCK y EXTENDS x
END_FUNCTION_BLOCK
FUNCTION f : INT
f := 1;
END_FUNCTION
FUNCTION_BLOCK z EXTENDS f
END_FUNCTION_BLOCK",
        "t.st:1:26: error[E210]: a extends `missing`, which is not declared among these sources; declare FUNCTION_BLOCK missing or correct the name
t.st:3:26: error[E210]: c extends `Lib.base`, which is not declared among these sources; it comes from the library Lib: check the library's sources together with this one
t.st:5:26: error[E210]: y extends itself through y; a chain of EXTENDS must end
t.st:7:26: error[E210]: x extends itself through x; a chain of EXTENDS must end
t.st:12:26: error[E210]: only a FUNCTION_BLOCK extends another FUNCTION_BLOCK; z is a FUNCTION_BLOCK and f a FUNCTION",
    );
}

#[test]
fn super_and_properties_are_used_as_they_can_be() {
    check_src(
        "FUNCTION_BLOCK a
VAR v : INT; END_VAR
PROPERTY RO : INT
GET
RO := v;
END_GET
END_PROPERTY
PROPERTY WO : INT
SET
v := WO;
END_SET
END_PROPERTY
METHOD m
SUPER^();
END_METHOD
END_FUNCTION_BLOCK
FUNCTION_BLOCK b EXTENDS a
METHOD n
SUPER^.nothing();
END_METHOD
END_FUNCTION_BLOCK
PROGRAM p
VAR i : a; k : INT; END_VAR
i.RO := 1;
k := i.WO;
SUPER^();
END_PROGRAM",
        "t.st:14:1: error[E211]: a extends no function block, so it has no SUPER^; add EXTENDS base to its declaration
t.st:19:8: error[E211]: a (SUPER^) has no method `nothing`
t.st:24:1: error[E211]: property RO has no SET: it can only be read
t.st:25:6: error[E211]: property WO has no GET: it can only be assigned
t.st:26:1: error[E211]: p extends no function block, so it has no SUPER^; add EXTENDS base to its declaration",
    );
}

#[test]
fn var_inst_belongs_in_a_method_and_functions_have_no_members() {
    check_src(
        "FUNCTION_BLOCK a
VAR_INST k : INT; END_VAR
END_FUNCTION_BLOCK
FUNCTION f : INT
METHOD m
END_METHOD
f := 1;
END_FUNCTION",
        "t.st:2:1: error[E109]: VAR_INST is not allowed in a FUNCTION_BLOCK; VAR_INST belongs in a METHOD of a FUNCTION_BLOCK (its variables kept in the instance); use VAR here
t.st:4:10: error[E210]: FUNCTION f cannot have methods, properties, actions, EXTENDS or IMPLEMENTS; make it a FUNCTION_BLOCK",
    );
}
