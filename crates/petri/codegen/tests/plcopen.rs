//! Every PLCopen XML file petriplc writes validates against tc6_xml_v201.xsd: ST and IL for
//! every example under every step rule, evolution and marking representation, LD and SFC for
//! every example they accept, and all four languages for random nets.

mod common;

use petriplc_codegen::{generate, CodegenError, Form, Language, Markings, Options, Request};
use petriplc_net::{Evolution, Net, StepRule};
use proptest::prelude::*;

const RULES: [(StepRule, Evolution); 4] = [
    (StepRule::MaximalStep, Evolution::OnePass),
    (StepRule::MaximalStep, Evolution::UntilStable),
    (StepRule::Sequential, Evolution::OnePass),
    (StepRule::Sequential, Evolution::UntilStable),
];

fn project(
    net: &Net,
    language: Language,
    rule: (StepRule, Evolution),
    markings: Markings,
) -> Result<String, CodegenError> {
    let mut options = Options::of(net);
    (options.step, options.evolve) = rule;
    options.markings = markings;
    let request = Request {
        language,
        form: Form::Project,
        options,
        created: common::CREATED.into(),
    };
    generate(net, &request).map(|g| g.text)
}

fn valid(doc: &str, what: &str) {
    if let Err(e) = common::xmllint(doc) {
        panic!("{what}: {e}\n--- document ---\n{doc}");
    }
}

#[test]
fn st_and_il_projects_of_every_example_validate() {
    for (name, _, _) in common::EXAMPLE_NETS {
        let net = common::example(name);
        for language in [Language::St, Language::Il] {
            for rule in RULES {
                for markings in [Markings::Auto, Markings::Int] {
                    let doc = project(&net, language, rule, markings).unwrap();
                    valid(&doc, &format!("{name} {language:?} {rule:?} {markings:?}"));
                }
            }
        }
    }
}

#[test]
fn ld_and_sfc_projects_of_the_examples_they_accept_validate() {
    let mut accepted = Vec::new();
    for (name, _, _) in common::EXAMPLE_NETS {
        let net = common::example(name);
        for language in [Language::Ld, Language::Sfc] {
            let rule = (StepRule::MaximalStep, Evolution::OnePass);
            if let Ok(doc) = project(&net, language, rule, Markings::Auto) {
                valid(&doc, &format!("{name} {language:?}"));
                accepted.push(format!("{name} {language:?}"));
            }
        }
    }
    // The seeds' own examples must be among them.
    for must in ["mixer Ld", "mixer Sfc", "blink Ld"] {
        assert!(
            accepted.iter().any(|a| a == must),
            "{must} refused: {accepted:?}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_nets_give_valid_projects(d in common::random::arb_desc(), rule in 0..4usize) {
        let net = common::random::build(&d);
        for language in [Language::St, Language::Il, Language::Ld, Language::Sfc] {
            // LD and SFC refuse some nets (with an error saying why); what they write validates.
            if let Ok(doc) = project(&net, language, RULES[rule], Markings::Auto) {
                valid(&doc, &format!("{language:?}"));
            }
        }
    }
}

/// Nets with no places, transitions, inputs or outputs: every language either writes a
/// valid project or refuses the net with a reason; none writes an invalid one.
#[test]
fn degenerate_nets_validate_in_every_language_or_are_refused() {
    for (name, net) in common::degenerate_nets() {
        for language in [Language::St, Language::Il, Language::Ld, Language::Sfc] {
            for rule in RULES {
                for markings in [Markings::Auto, Markings::Int] {
                    let what = format!("{name} {language:?} {rule:?} {markings:?}");
                    match project(&net, language, rule, markings) {
                        Ok(doc) => valid(&doc, &what),
                        Err(e) => {
                            assert!(
                                matches!(language, Language::Ld | Language::Sfc),
                                "{what}: {e}"
                            );
                            assert!(!e.to_string().is_empty(), "{what}");
                        }
                    }
                }
            }
        }
    }
}
