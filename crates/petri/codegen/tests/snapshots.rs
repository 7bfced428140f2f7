//! Snapshots of the generated ST, IL and C for the mixer (seed 002, Figure 5) and blink
//! (seed 003, Example 4) examples; docs/codegen.md compares them with the seeds.

mod common;

use petriplc_codegen::{generate, Form, Language, Markings, Options, Request};

fn code(example: &str, language: Language, form: Form) -> String {
    code_with(example, language, form, Markings::Auto)
}

fn code_with(example: &str, language: Language, form: Form, markings: Markings) -> String {
    let net = common::example(example);
    let mut options = Options::of(&net);
    options.markings = markings;
    let request = Request {
        language,
        form,
        options,
        created: common::CREATED.into(),
    };
    generate(&net, &request).expect("code is generated").text
}

#[test]
fn mixer_st() {
    insta::assert_snapshot!(code("mixer", Language::St, Form::Plain));
}

#[test]
fn blink_st() {
    insta::assert_snapshot!(code("blink", Language::St, Form::Plain));
}

/// Seed 003 keeps integer markings (`%MW201`…): the same net with `--markings int`.
#[test]
fn blink_st_int() {
    insta::assert_snapshot!(code_with("blink", Language::St, Form::Plain, Markings::Int));
}

#[test]
fn mixer_il() {
    insta::assert_snapshot!(code("mixer", Language::Il, Form::Plain));
}

#[test]
fn blink_il() {
    insta::assert_snapshot!(code("blink", Language::Il, Form::Plain));
}

#[test]
fn mixer_c() {
    insta::assert_snapshot!(code("mixer", Language::C, Form::Project));
}

#[test]
fn blink_c() {
    insta::assert_snapshot!(code("blink", Language::C, Form::Project));
}
