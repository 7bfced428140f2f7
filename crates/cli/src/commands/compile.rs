//! `petriplc compile`: lower a net once and write it as ST, IL, LD, SFC (PLCopen XML) or C.

use std::time::{SystemTime, UNIX_EPOCH};

use anyhow::Context;
use petriplc_codegen::{generate, Form, Language, Markings, Options, Request};

use crate::args::{CompileArgs, LangArg, MarkingsArg};
use crate::failure::{BadInputExt, Failure};
use crate::output::{to_stdout, write_file};

pub fn run(args: CompileArgs) -> Result<(), Failure> {
    let net = super::read_net(&args.net, args.names)?;
    let language = match args.lang {
        LangArg::St => Language::St,
        LangArg::Il => Language::Il,
        LangArg::Ld => Language::Ld,
        LangArg::Sfc => Language::Sfc,
        LangArg::C => Language::C,
    };
    let mut options = Options::of(&net);
    options.step = args.step.map_or(net.step, Into::into);
    options.evolve = args.evolve.map_or(net.evolve, Into::into);
    options.max_passes = args.max_passes;
    options.markings = match args.markings {
        MarkingsArg::Auto => Markings::Auto,
        MarkingsArg::Bool => Markings::Bool,
        MarkingsArg::Int => Markings::Int,
    };
    options.pou = args.pou.clone();
    options.period = args.period;
    let request = Request {
        language,
        form: if args.plain {
            Form::Plain
        } else {
            Form::Project
        },
        options,
        created: creation_time(),
    };
    let generated = generate(&net, &request)
        .with_context(|| {
            format!(
                "cannot compile {} to {}",
                args.net.display(),
                language.name()
            )
        })
        .bad_input()?;
    for note in &generated.notes {
        eprintln!("note: {note}");
    }
    match &args.out {
        Some(path) => write_file(
            path,
            generated.text.as_bytes(),
            &describe(language, request.form, &generated.text),
        ),
        None => to_stdout(|w| w.write_all(generated.text.as_bytes())),
    }
}

/// What a generated file holds, for the `wrote …` line: `SFC in a PLCopen XML project, 1
/// POU, 240 lines`.
fn describe(language: Language, form: Form, text: &str) -> String {
    let lines = text.lines().count();
    let lines = format!("{lines} line{}", if lines == 1 { "" } else { "s" });
    match (language, form) {
        (Language::C, _) => format!("C99, {lines}"),
        (_, Form::Plain) => format!("bare {}, {lines}", language.name()),
        (_, Form::Project) => {
            let pous = text.matches("<pou ").count();
            format!(
                "{} in a PLCopen XML project, {pous} POU{}, {lines}",
                language.name(),
                if pous == 1 { "" } else { "s" }
            )
        }
    }
}

/// `creationDateTime` for PLCopen XML: `SOURCE_DATE_EPOCH` when set (reproducible builds),
/// else now, in UTC.
fn creation_time() -> String {
    let secs = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.trim().parse::<u64>().ok())
        .unwrap_or_else(|| {
            SystemTime::now()
                .duration_since(UNIX_EPOCH)
                .map_or(0, |d| d.as_secs())
        });
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let (y, m, d) = petriplc_calendar::civil_from_days(days as i64);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}
