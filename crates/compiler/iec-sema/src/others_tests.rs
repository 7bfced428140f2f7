//! What other compilers (matiec, CODESYS, TwinCAT, PCWorx) accept and the standard does not:
//! accepted with a warning, and where it stays refused.

use crate::tests::check_diags;

const FB: &str = "FUNCTION_BLOCK fb\nVAR n : INT; END_VAR\nVAR CONSTANT k : INT := 3; END_VAR\nVAR_TEMP t : INT; END_VAR\nn := n + 1;\nEND_FUNCTION_BLOCK\n";

#[test]
fn an_instance_internal_variable_is_read_and_set_with_a_warning() {
    check_diags(
        &format!("{FB}PROGRAM p\nVAR f : fb; x : INT; END_VAR\nf.n := 5;\nf();\nx := f.n + f.k;\nEND_PROGRAM\n"),
        &[
            "t.st:9:3: warning[W030]: `n` is internal to fb (its VAR)",
            "t.st:11:8: warning[W030]: `n` is internal to fb",
            "t.st:11:14: warning[W030]: `k` is internal to fb",
        ],
    );
}

#[test]
fn an_instance_constant_or_temporary_stays_out_of_reach() {
    check_diags(
        &format!(
            "{FB}PROGRAM p\nVAR f : fb; x : INT; END_VAR\nf.k := 5;\nx := f.t;\nEND_PROGRAM\n"
        ),
        &[
            "t.st:9:1: error[E121]: `k` is a CONSTANT of fb and cannot be assigned",
            "t.st:10:8: error[E105]: `t` is internal to fb; only its inputs and outputs",
        ],
    );
}

#[test]
fn a_for_variable_assigned_in_the_body_is_a_warning() {
    check_diags(
        "PROGRAM p\nVAR i : INT; n : INT; END_VAR\nFOR i := 1 TO 10 DO\n  i := i + 1;\n  n := n + 1;\nEND_FOR;\nEND_PROGRAM\n",
        &["t.st:4:3: warning[W031]: `i` controls the FOR loop around this statement"],
    );
}

#[test]
fn an_in_out_initial_value_is_ignored_with_a_warning_and_an_external_one_refused() {
    check_diags(
        "FUNCTION_BLOCK fb\nVAR_IN_OUT x : INT := 5; END_VAR\nx := x + 1;\nEND_FUNCTION_BLOCK\nPROGRAM p\nEND_PROGRAM\n",
        &["t.st:2:23: warning[W032]: a VAR_IN_OUT takes no initial value"],
    );
    check_diags(
        "PROGRAM p\nVAR_EXTERNAL g : INT := 5; END_VAR\nEND_PROGRAM\n",
        &[
            "t.st:2:14: error[E106]: VAR_EXTERNAL g has no VAR_GLOBAL",
            "t.st:2:25: error[E109]: VAR_EXTERNAL variables take no initial value",
        ],
    );
}

#[test]
fn time_by_time_negated_unsigned_and_wide_literals_type_as_codesys_does() {
    check_diags(
        "PROGRAM p\nVAR t : TIME; b : BYTE; w : WORD; i : INT; d : DINT; r : INT; END_VAR\n\
         t := t / t * t;\nd := -w;\nr := -b;\nd := i * 60000;\nEND_PROGRAM\n",
        &[],
    );
    // The wider type is the result's: an INT result of `i * 60000` is a DINT to narrow.
    check_diags(
        "PROGRAM p\nVAR i : INT; r : INT; t : TIME; l : LTIME; END_VAR\nr := i * 60000;\nt := t / l;\nEND_PROGRAM\n",
        &[
            "t.st:3:6: error[E110]: the value assigned to `r` is DINT but INT is needed",
            "t.st:4:6: error[E111]: `/` cannot combine TIME and LTIME",
        ],
    );
}
