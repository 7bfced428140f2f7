//! CODESYS's and TwinCAT's `UNION`: what is accepted, and the errors (E221–E223) around
//! declaring, reading and initialising its members.

use crate::memory;
use crate::tests::{check_diags, run};

const U: &str =
    "TYPE U :\nUNION\n  a : INT;\n  s : STRING;\n  w : ARRAY[0..1] OF WORD;\nEND_UNION\nEND_TYPE\n";

#[test]
fn a_union_is_as_large_as_its_largest_member_rounded_to_its_alignment() {
    let (p, text) = run(
        "TYPE U :\nUNION\n  b : BYTE;\n  s : STRING[4];\n  d : DINT;\nEND_UNION\nEND_TYPE\n\
         TYPE S :\nSTRUCT\n  c : BYTE;\n  u : U;\nEND_STRUCT\nEND_TYPE\n\
         PROGRAM p\nVAR s : S; x : DINT; END_VAR\nx := s.u.d;\nEND_PROGRAM\n",
    );
    let p = p.unwrap_or_else(|| panic!("{text}"));
    let s = (0..p.types.len() as u32)
        .find(|&t| p.types.name(t) == "S")
        .expect("S");
    let u = (0..p.types.len() as u32)
        .find(|&t| p.types.name(t) == "U")
        .expect("U");
    // STRING[4] is 5 bytes, rounded up to DINT's 4: 8; in S, the union is aligned to 4.
    assert_eq!(memory::size_align(&p.types, u), Some((8, 4)));
    assert_eq!(memory::size_align(&p.types, s), Some((12, 4)));
    assert_eq!(memory::field_offsets(&p.types, s), vec![0, 4]);
}

#[test]
fn members_that_share_no_bytes_are_refused_at_the_declaration() {
    check_diags(
        "TYPE U :\nUNION\n  a : INT := 5;\n  p : POINTER TO INT;\n  a : DINT;\nEND_UNION\nEND_TYPE\n\
         TYPE E : UNION END_UNION END_TYPE\n",
        &[
            "t.st:3:3: error[E221]: a member of UNION U cannot be given an initial value",
            "t.st:4:3: error[E221]: member `p` of UNION U is POINTER TO INT, a reference or pointer",
            "t.st:5:3: error[E103]: member `a` is declared twice in UNION U",
            "t.st:8:10: error[E221]: UNION E has no members; declare at least one",
        ],
    );
}

#[test]
fn only_elementary_and_string_members_and_array_elements_are_read_and_written() {
    check_diags(
        &format!(
            "{U}FUNCTION_BLOCK F\nVAR_IN_OUT io : STRING; END_VAR\nVAR_OUTPUT q : WORD; END_VAR\nEND_FUNCTION_BLOCK\n\
             PROGRAM p\nVAR u, v : U; x : STRING; f : F; pw : POINTER TO WORD; n : WORD; END_VAR\n\
             n := u.w[1]; u.a := 3; u := v;\n\
             x := u.s;\nu.w := v.w;\nf(io := u.s, q => u.w[0]);\npw := ADR(u.w[1]);\nu.zz := 1;\nEND_PROGRAM\n"
        ),
        &[
            "t.st:16:1: error[E222]: member `w` of UNION U is ARRAY[0..1] OF WORD: only its elementary values and strings are read and written",
            "t.st:17:9: error[E222]: member `s` of UNION U is read and assigned through the union's bytes and has no address of its own",
            "t.st:17:19: error[E222]: member `w` of UNION U is read and assigned through the union's bytes and has no address of its own",
            "t.st:18:11: error[E222]: member `w` of UNION U is read and assigned",
            "t.st:19:3: error[E105]: UNION U has no member `zz`; its members are a, s, w",
        ],
    );
}

#[test]
fn a_union_starts_with_one_members_value() {
    check_diags(
        &format!(
            "{U}PROGRAM p\nVAR a : U := 5; b : U := (s := 'ab'); c : U := (a := 1, s := 'x');\n\
             d : U := (zz := 1); e : U := (w := [1, 2]); END_VAR\nEND_PROGRAM\n"
        ),
        &[
            "t.st:9:48: error[E223]: a UNION holds one member's value at a time",
            "t.st:10:11: error[E105]: UNION U has no member `zz`",
            "t.st:10:36: error[E223]: member `w` of UNION U is ARRAY[0..1] OF WORD: only an elementary or STRING member takes an initial value yet",
        ],
    );
}

#[test]
fn a_union_extends_nothing() {
    use petriplc_iec_syntax::{parser, source::SourceMap, Diagnostics};
    let src = "TYPE B :\nUNION\n  a : INT;\nEND_UNION\nEND_TYPE\nTYPE U EXTENDS B :\nUNION\n  d : DINT;\nEND_UNION\nEND_TYPE\n";
    let mut map = SourceMap::new();
    let f = map.add("t.st", src);
    let mut d = Diagnostics::new();
    parser::parse(f, src, &mut d);
    assert_eq!(
        d.render(&map).trim(),
        "t.st:7:1: error[E190]: a UNION that EXTENDS another is not supported yet; list all its members"
    );
}

#[test]
fn a_union_inside_a_union_is_not_read_through_yet() {
    check_diags(
        "TYPE I :\nUNION\n  b : BYTE;\nEND_UNION\nEND_TYPE\nTYPE S :\nSTRUCT\n  w : WORD;\n  i : I;\nEND_STRUCT\nEND_TYPE\n\
         TYPE U :\nUNION\n  i : I;\n  s : S;\nEND_UNION\nEND_TYPE\n\
         PROGRAM p\nVAR u : U; b : BYTE; w : WORD; pb : POINTER TO BYTE; END_VAR\n\
         w := u.s.w; pb := ADR(u.i);\nb := u.i.b;\npb := ADR(u.s.i.b);\nEND_PROGRAM\n",
        &[
            "t.st:21:6: error[E222]: member `b` of UNION I lies inside another union",
            "t.st:22:11: error[E222]: member `b` of UNION I lies inside another union",
        ],
    );
}
