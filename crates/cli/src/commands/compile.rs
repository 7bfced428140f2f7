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
    let (y, m, d) = civil_from_days(days as i64);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// The proleptic Gregorian date of a day count since 1970-01-01 (H. Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

#[cfg(test)]
mod tests {
    use super::civil_from_days;

    #[test]
    fn days_map_to_dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(20_454), (2026, 1, 1));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
    }
}
