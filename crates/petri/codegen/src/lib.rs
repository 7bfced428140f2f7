//! Code generation: a net lowered once ([`lower::Program`]) and rendered as IEC 61131-3
//! Structured Text, Instruction List, Ladder Diagram or Sequential Function Chart inside a
//! PLCopen XML (TC6 v2.01) project, or as a self-contained C99 file. Every backend means what
//! `petriplc sim` does (docs/semantics.md); docs/codegen.md describes the generated code.

pub mod c;
pub mod enabling;
pub mod il;
pub mod ld;
pub mod lower;
pub mod names;
pub mod plcopen;
pub mod sfc;
pub mod spell;
pub mod st;
pub(crate) mod text;

use std::time::Duration;

use petriplc_net::Net;

pub use lower::{Markings, Options, Program};

/// A target language.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Language {
    St,
    Il,
    Ld,
    Sfc,
    C,
}

impl Language {
    pub fn name(self) -> &'static str {
        match self {
            Language::St => "ST",
            Language::Il => "IL",
            Language::Ld => "LD",
            Language::Sfc => "SFC",
            Language::C => "C",
        }
    }
}

/// What [`generate`] writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Form {
    /// A PLCopen XML project (ST, IL, LD, SFC) or a C file (C).
    Project,
    /// Bare ST or IL text.
    Plain,
}

/// Why code could not be generated; each message says what to change.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CodegenError {
    #[error("--markings bool: place {place} is not provably safe ({reason}); give it capacity 1, or use --markings int")]
    NotSafe { place: String, reason: String },
    #[error("{lang} needs a safe net with BOOL markings, but place {place} is not ({reason}); use --lang st, il or c, which handle integer markings")]
    NeedsSafeNet {
        lang: &'static str,
        place: String,
        reason: String,
    },
    #[error("--pou {name}: not a valid IEC 61131-3 identifier, or a reserved word; use letters, digits and single underscores, starting with a letter")]
    BadPouName { name: String },
    #[error("this net cannot be a sequential function chart: {reason}")]
    NotSfc { reason: String },
    #[error("{lang} cannot express {what}; {hint}")]
    Unsupported {
        lang: &'static str,
        what: String,
        hint: String,
    },
    #[error("arc {arc}: delay {delay} is not a whole number of milliseconds; the C code counts time in ms (round the delay, or use --lang st)")]
    DelayNotMilliseconds { arc: String, delay: String },
    #[error("--plain writes bare ST or IL text; {lang} is graphical (or C) and has no plain form")]
    NoPlainForm { lang: &'static str },
}

/// Everything about one generation run besides the net.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Request {
    pub language: Language,
    pub form: Form,
    pub options: Options,
    /// `creationDateTime` of a PLCopen XML file (`YYYY-MM-DDThh:mm:ss`): passed in so that
    /// output is reproducible.
    pub created: String,
}

/// Generated text, with notes for the user (conflicts resolved by priority, renamed names).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Generated {
    pub text: String,
    pub notes: Vec<String>,
}

/// Generates code for `net`.
pub fn generate(net: &Net, request: &Request) -> Result<Generated, CodegenError> {
    if request.form == Form::Plain && !matches!(request.language, Language::St | Language::Il) {
        return Err(CodegenError::NoPlainForm {
            lang: request.language.name(),
        });
    }
    let program = Program::lower(net, &request.options)?;
    if matches!(request.language, Language::Ld | Language::Sfc) && !program.boolean {
        let (place, reason) = lower::unsafe_place(net).unwrap_or_else(|| {
            (
                program
                    .places
                    .first()
                    .map_or(String::new(), |p| p.label.clone()),
                "--markings int asks for integer markings".into(),
            )
        });
        return Err(CodegenError::NeedsSafeNet {
            lang: request.language.name(),
            place,
            reason,
        });
    }
    let text = match (request.language, request.form) {
        (Language::St, Form::Plain) => st::program_text(&program),
        (Language::St, Form::Project) => plcopen::project(
            &program,
            &plcopen::program_interface(&program),
            &plcopen::Body::St(st::body(&program)),
            &request.created,
        ),
        (Language::Il, Form::Plain) => il::program_text(&program),
        (Language::Il, Form::Project) => plcopen::project(
            &program,
            &plcopen::program_interface(&program),
            &plcopen::Body::Il(il::body(&program)),
            &request.created,
        ),
        (Language::Ld, _) => ld::project(&program, &request.created)?,
        (Language::Sfc, _) => sfc::project(net, &program, &request.created)?,
        (Language::C, _) => c::file(&program)?,
    };
    Ok(Generated {
        text,
        notes: notes(&program),
    })
}

/// What the user should know about the generated code.
pub fn notes(program: &Program) -> Vec<String> {
    let mut notes = Vec::new();
    for c in &program.conflicts {
        notes.push(format!(
            "conflict: {} and {} both take tokens from {}; {} has priority (declared first)",
            c.first,
            c.second,
            c.places.join(", "),
            c.first
        ));
    }
    for (from, to) in &program.renamed {
        notes.push(format!("renamed: `{from}` is `{to}` in the generated code"));
    }
    notes
}

/// An IEC `TIME` literal (`T#500ms`).
pub(crate) fn iec_time(d: Duration) -> String {
    petriplc_net::time::format_iec(d)
}
