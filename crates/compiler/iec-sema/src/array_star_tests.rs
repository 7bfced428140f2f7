//! The checker's rules for ARRAY[*] in-outs and LOWER_BOUND/UPPER_BOUND, and for the FOR loops
//! over array elements TcUnit walks such arrays with.

use crate::tests::{check_diags, check_src};

const SUM: &str = "FUNCTION Sum : DINT
VAR_IN_OUT xs : ARRAY[*] OF INT; END_VAR
VAR i : DINT; END_VAR
FOR i := LOWER_BOUND(xs, 1) TO UPPER_BOUND(xs, 1) DO Sum := Sum + xs[i]; END_FOR
END_FUNCTION
";

fn with_sum(main: &str) -> String {
    format!("{SUM}{main}")
}

#[test]
fn any_bounds_of_the_same_element_type_and_dimensions_bind() {
    check_src(
        &with_sum(
            "PROGRAM p
VAR a : ARRAY[1..3] OF INT; b : ARRAY[-5..5] OF INT; s : DINT; END_VAR
s := Sum(a) + Sum(xs := b);
END_PROGRAM",
        ),
        "ok",
    );
}

#[test]
fn another_element_type_or_dimension_count_is_a_type_error_naming_both() {
    check_src(
        &with_sum(
            "PROGRAM p
VAR a : ARRAY[1..3] OF DINT; m : ARRAY[1..2, 1..2] OF INT; x : INT; s : DINT; END_VAR
s := Sum(a);
s := Sum(m);
s := Sum(x);
END_PROGRAM",
        ),
        "t.st:8:10: error[E110]: in-out `xs` is ARRAY[*] OF INT; this variable is ARRAY[1..3] OF DINT (an in-out is passed by reference, so the types must be the same)
t.st:9:10: error[E110]: in-out `xs` is ARRAY[*] OF INT; this variable is ARRAY[1..2, 1..2] OF INT (an in-out is passed by reference, so the types must be the same)
t.st:10:10: error[E110]: in-out `xs` is ARRAY[*] OF INT; this variable is INT (an in-out is passed by reference, so the types must be the same)",
    );
}

#[test]
fn array_star_is_only_an_in_out_type() {
    check_diags(
        "TYPE T : ARRAY[*] OF INT; END_TYPE
FUNCTION_BLOCK b
VAR_INPUT i : ARRAY[*] OF INT; END_VAR
VAR l : ARRAY[*] OF INT; END_VAR
VAR_OUTPUT o : ARRAY[1..2] OF ARRAY[*] OF INT; END_VAR
VAR_IN_OUT ok : ARRAY[*, *, *] OF BOOL; END_VAR
END_FUNCTION_BLOCK
PROGRAM p
VAR_IN_OUT io : ARRAY[*] OF INT; END_VAR
END_PROGRAM",
        &[
            "t.st:1:10: error[E228]: ARRAY[*] takes the bounds",
            "t.st:3:15: error[E228]",
            "t.st:4:9: error[E228]",
            "t.st:5:31: error[E228]",
            "t.st:9:17: error[E228]",
        ],
    );
}

#[test]
fn bounds_need_an_array_and_a_constant_dimension_it_has() {
    check_diags(
        "FUNCTION f : DINT
VAR_IN_OUT a : ARRAY[*, *] OF INT; END_VAR
VAR x : INT; d : DINT := 1; END_VAR
f := UPPER_BOUND(a, 3);
f := LOWER_BOUND(x, 1);
f := LOWER_BOUND(a, d);
f := LOWER_BOUND(a);
f := UPPER_BOUND(a, 2) - LOWER_BOUND(a, 1);
END_FUNCTION",
        &[
            "t.st:4:21: error[E229]: UPPER_BOUND: ARRAY[*, *] OF INT has dimensions 1 to 2, not 3",
            "t.st:5:18: error[E229]: LOWER_BOUND gives an array's bound; this is INT",
            "t.st:6:21: error[",
            "t.st:7:6: error[E229]: LOWER_BOUND takes an array variable and a constant dimension",
        ],
    );
}

#[test]
fn bounds_of_a_fixed_array_are_constants() {
    check_src(
        "PROGRAM p
VAR a : ARRAY[1..3, -4..7] OF INT; END_VAR
VAR CONSTANT n : DINT := UPPER_BOUND(a, 2); END_VAR
VAR c : ARRAY[0..UPPER_BOUND(a, 1)] OF INT; END_VAR
END_PROGRAM",
        "ok",
    );
}

#[test]
fn an_array_star_is_not_used_as_a_whole() {
    check_diags(
        "FUNCTION f : BOOL
VAR_IN_OUT a, b : ARRAY[*] OF INT; END_VAR
VAR p : POINTER TO INT; n : DINT; END_VAR
a := b;
p := ADR(a);
f := a = b;
n := SIZEOF(a);
END_FUNCTION",
        &[
            "t.st:4:6: error[E230]: an ARRAY[*] in-out is used element by element",
            "t.st:5:10: error[E230]",
            "t.st:6:6: error[E230]",
            "t.st:6:10: error[E230]",
            "t.st:7:13: error[E230]",
        ],
    );
}

/// TcUnit's loops over an array's elements as control variables: an element with constant
/// subscripts or a field of the POU's own variable; a variable subscript or an in-out's
/// element is refused (its place would move during the loop, or lives in the caller).
#[test]
fn a_for_loop_runs_on_an_element_with_constant_subscripts() {
    check_diags(
        "TYPE S : STRUCT k : INT; END_STRUCT END_TYPE
FUNCTION f : BOOL
VAR_IN_OUT io : ARRAY[1..2] OF INT; END_VAR
VAR o : ARRAY[1..2] OF DINT; s : S; i : INT := 1; r : ARRAY[1..2] OF REAL; END_VAR
FOR o[1] := 0 TO 3 DO FOR o[2] := 0 TO 1 DO f := TRUE; END_FOR; END_FOR;
FOR s.k := 1 TO 2 DO f := FALSE; END_FOR;
FOR o[i] := 0 TO 3 DO f := TRUE; END_FOR;
FOR io[1] := 0 TO 3 DO f := TRUE; END_FOR;
FOR r[1] := 0 TO 3 DO f := TRUE; END_FOR;
END_FUNCTION",
        &[
            "t.st:7:5: error[E143]: the control variable of FOR is a variable of the POU, or an element",
            "t.st:8:5: error[E143]",
            "t.st:9:5: error[E143]: the control variable of FOR is SINT, INT, DINT, LINT or an unsigned integer; `this element` is REAL",
        ],
    );
}
