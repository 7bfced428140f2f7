//! The checker's rules of interfaces (docs/iec.md, "Interfaces"): IMPLEMENTS checked, the
//! values an interface takes, and its misuses, each with its code and message.

use crate::tests::check_src;

const ITF: &str = "INTERFACE I_Base
METHOD Id : INT
END_METHOD
END_INTERFACE
INTERFACE I_Run EXTENDS I_Base
METHOD Run : BOOL
VAR_INPUT speed : INT; END_VAR
END_METHOD
PROPERTY Level : INT
GET
END_GET
END_PROPERTY
END_INTERFACE
";

#[test]
fn a_block_implements_every_member_of_its_interfaces_and_their_bases() {
    check_src(
        &format!(
            "{ITF}FUNCTION_BLOCK Motor IMPLEMENTS I_Run
METHOD Run : BOOL
VAR_INPUT speed : INT; END_VAR
Run := speed > 0;
END_METHOD
END_FUNCTION_BLOCK
FUNCTION_BLOCK ABSTRACT Half IMPLEMENTS I_Run
END_FUNCTION_BLOCK
FUNCTION_BLOCK Full EXTENDS Half
METHOD Run : BOOL
VAR_INPUT speed : INT; END_VAR
END_METHOD
METHOD Id : INT
END_METHOD
PROPERTY Level : INT
GET
END_GET
END_PROPERTY
END_FUNCTION_BLOCK"
        ),
        "t.st:14:16: error[E215]: Motor implements I_Base but has no method Id; add METHOD Id with the interface's parameters to Motor, or declare it FUNCTION_BLOCK ABSTRACT
t.st:14:16: error[E215]: Motor implements I_Run but has no GET for property Level; add PROPERTY Level with a GET accessor to Motor, or declare it FUNCTION_BLOCK ABSTRACT",
    );
}

#[test]
fn an_implementation_keeps_the_signature() {
    check_src(
        &format!(
            "{ITF}FUNCTION_BLOCK Motor IMPLEMENTS I_Run
METHOD Run : BOOL
VAR_INPUT speed : REAL; END_VAR
END_METHOD
METHOD Id : DINT
END_METHOD
PROPERTY Level : BOOL
GET
END_GET
END_PROPERTY
END_FUNCTION_BLOCK"
        ),
        "t.st:15:8: error[E216]: Motor's Run implements I_Run's with other parameters: (result BOOL, SPEED : REAL) instead of (result BOOL, SPEED : INT); give it the interface's inputs, outputs, in-outs and result type
t.st:18:8: error[E216]: Motor's Id implements I_Base's with other parameters: (result DINT) instead of (result INT); give it the interface's inputs, outputs, in-outs and result type
t.st:20:10: error[E216]: Motor's Level implements I_Run's with other parameters: (result BOOL) instead of (result INT); give it the interface's inputs, outputs, in-outs and result type",
    );
}

#[test]
fn an_interface_extending_itself_is_refused() {
    check_src(
        "INTERFACE I_A EXTENDS I_B
END_INTERFACE
INTERFACE I_B EXTENDS I_A
END_INTERFACE
INTERFACE I_C EXTENDS I_C
END_INTERFACE",
        "t.st:1:23: error[E210]: I_A extends itself through I_B; a chain of EXTENDS must end
t.st:3:23: error[E210]: I_B extends itself through I_A; a chain of EXTENDS must end
t.st:5:23: error[E210]: I_C extends itself through I_C; a chain of EXTENDS must end",
    );
}

#[test]
fn implements_and_an_interfaces_extends_name_interfaces() {
    check_src(
        "FUNCTION_BLOCK Base
END_FUNCTION_BLOCK
INTERFACE I_X EXTENDS Base, __SYSTEM.IQueryInterface
END_INTERFACE
FUNCTION_BLOCK Motor IMPLEMENTS Base, I_Nowhere, I_X
END_FUNCTION_BLOCK
FUNCTION_BLOCK Other IMPLEMENTS __SYSTEM.IQueryInterface
END_FUNCTION_BLOCK",
        "t.st:3:23: error[E217]: `Base` is a FUNCTION_BLOCK, not an INTERFACE; an INTERFACE extends INTERFACEs only
t.st:5:33: error[E217]: `Base` is a FUNCTION_BLOCK, not an INTERFACE; a FUNCTION_BLOCK's base goes after EXTENDS
t.st:5:39: error[E217]: `I_Nowhere` is not an INTERFACE declared among these sources; declare it, check the source that declares it together with these, or correct the name",
    );
}

#[test]
fn an_interface_takes_an_implementing_instance_an_extending_interface_or_0() {
    check_src(
        &format!(
            "{ITF}FUNCTION_BLOCK Motor IMPLEMENTS I_Run
METHOD Run : BOOL
VAR_INPUT speed : INT; END_VAR
END_METHOD
METHOD Id : INT
END_METHOD
PROPERTY Level : INT
GET
END_GET
END_PROPERTY
END_FUNCTION_BLOCK
FUNCTION_BLOCK Lamp
END_FUNCTION_BLOCK
PROGRAM p
VAR m : Motor; l : Lamp; t : TON; r : I_Run; b : I_Base; ok : BOOL; n : INT; END_VAR
r := m;
b := r;
b := m;
r := 0;
ok := r = b;
r := l;
r := t;
r := b;
n := r;
m := r;
END_PROGRAM"
        ),
        "t.st:34:6: error[E219]: the value assigned to `r` is an instance of Lamp, which does not implement I_Run; add IMPLEMENTS I_Run to Lamp or give an instance of a block that implements it
t.st:35:6: error[E219]: the value assigned to `r` is an instance of a standard function block, which implements no interface; I_Run needs an instance of a block that IMPLEMENTS it
t.st:36:6: error[E219]: the value assigned to `r` is I_Base, which does not extend I_Run; cast with __QUERYINTERFACE(I_Base_value, I_Run_variable), which tells whether the instance implements I_Run
t.st:37:6: error[E110]: the value assigned to `n` is I_Run but INT is needed
t.st:38:1: error[E120]: a function block instance cannot be assigned; call it or set its inputs",
    );
}

#[test]
fn an_interface_is_not_dereferenced_and_has_only_its_members() {
    check_src(
        &format!(
            "{ITF}PROGRAM p
VAR r : I_Run; ok : BOOL; n : INT; END_VAR
ok := r^.Run(speed := 1);
ok := r.Stop();
n := r.Level;
n := r.Id();
ok := r.Run(speed := 1);
r.Level := 3;
END_PROGRAM"
        ),
        "t.st:16:7: error[E218]: an interface (I_Run) is not dereferenced with `^`; call its methods and use its properties directly (x.M())
t.st:17:9: error[E218]: the interface I_Run has no method `Stop`; use what I_Run declares, or __QUERYINTERFACE to reach another interface of the instance
t.st:21:1: error[E211]: property Level has no SET: it can only be read",
    );
}

#[test]
fn recursion_through_an_interface_is_a_warning_and_a_direct_one_an_error() {
    // Function frames are static: a method reached again through an interface would share
    // its frame, so the cycle is guarded at run time (W050; corpus-lenient 649 runs it); a
    // cycle of direct calls always re-enters (E107). (An interface's initial value
    // `i : I_Node := a` is set when the program starts: iec-syntax's fb_init.rs.)
    check_src(
        "INTERFACE I_Node
METHOD Visit : INT
END_METHOD
END_INTERFACE
FUNCTION_BLOCK Node IMPLEMENTS I_Node
VAR next : I_Node; END_VAR
METHOD Visit : INT
IF next <> 0 THEN
  Visit := next.Visit() + 1;
END_IF;
END_METHOD
END_FUNCTION_BLOCK
PROGRAM p
VAR a : Node; i : I_Node := a; END_VAR
END_PROGRAM",
        "t.st:9:12: warning[W050]: this call through I_Node.Visit may come back to Node.Visit while it is running: petriplc's frames are static, so if the instances make it re-enter, the scan stops with the fault `recursion` (CODESYS and TwinCAT would recurse); make sure the chain of instances ends, or walk it in a loop",
    );
    check_src(
        "FUNCTION_BLOCK Node
METHOD Visit : INT
Visit := THIS^.Visit() + 1;
END_METHOD
END_FUNCTION_BLOCK
PROGRAM p
VAR a : Node; END_VAR
END_PROGRAM",
        "t.st:3:10: error[E107]: Node.Visit calls itself; IEC 61131-3 does not allow recursion",
    );
}
