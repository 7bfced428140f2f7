//! `petriplc check`: the IEC 61131-3 compiler's checks alone, for editors and CI.

use petriplc_iec::{Natives, Select, Sources};

use crate::args::CheckArgs;
use crate::failure::{BadInputExt, Failure};

pub fn run(args: CheckArgs) -> Result<(), Failure> {
    let mut sources = Sources::new();
    sources.dialect = args.dialect;
    sources.overflow = args.overflow.into();
    sources.libs = args.lib.clone();
    for f in &args.files {
        sources.add_path(f).bad_input()?;
    }
    let checked = petriplc_iec::check(&sources, &Natives::default()).bad_input()?;
    if !checked.warnings.is_empty() {
        crate::diagnostics::eprint(&checked.warnings.join("\n"));
    }
    // The POUs of the project's sources, not those a vendor library declares in ST.
    let ours = |span: &petriplc_iec::syntax::source::Span| {
        !petriplc_iec::syntax::builtin::is_builtin(span.file)
    };
    let pous = checked
        .project
        .pous
        .iter()
        .filter(|p| ours(&p.span))
        .count();
    let programs = checked
        .project
        .programs()
        .filter(|(_, p)| ours(&p.span))
        .count();
    if let Some(pou) = &args.pou {
        petriplc_iec::build(&sources, &Select::Pou(pou.clone()), Natives::default()).bad_input()?;
    }
    let names: Vec<String> = args.files.iter().map(|f| f.display().to_string()).collect();
    eprintln!(
        "ok: {} ({pous} POU{}, {programs} PROGRAM{}{}){}",
        names.join(", "),
        if pous == 1 { "" } else { "s" },
        if programs == 1 { "" } else { "s" },
        checked
            .project
            .configuration
            .as_ref()
            .map_or(String::new(), |c| format!(", CONFIGURATION {}", c.name)),
        if checked.warnings.is_empty() {
            String::new()
        } else {
            format!(", {} warning(s)", checked.warnings.len())
        }
    );
    Ok(())
}
