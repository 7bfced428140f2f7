//! IEC 61131-3 programs in one call: read sources (Structured Text and Instruction List files, PLCopen XML
//! projects, TwinCAT 3 files and projects, folders of them: [`project`]), check them, choose what runs (a configuration's tasks, or one PROGRAM) and
//! compile it for the engine ([`build`]); simulate a program against a timeline and a plant
//! with the trace format of `petriplc sim` ([`sim`]).

#[cfg(test)]
mod code_examples;
pub mod dsp_fbs;
pub mod project;
pub mod sim;

use std::path::Path;
use std::sync::Arc;

use petriplc_iec_sema::ir::{PouKind, Project};
use petriplc_iec_syntax::ast::{Element, Library};
use petriplc_iec_syntax::diag::{self, Diagnostic, Diagnostics, Severity};
use petriplc_iec_syntax::source::{SourceMap, Span};
use petriplc_iec_vm::{Engine, InstanceSpec, NativeFb};

#[cfg(feature = "jit")]
pub use petriplc_iec_jit as jit;
pub use petriplc_iec_sema as sema;
pub use petriplc_iec_syntax as syntax;
pub use petriplc_iec_vm as vm;

/// Sources read and parsed, with their diagnostics so far.
#[derive(Debug, Default)]
pub struct Sources {
    pub map: SourceMap,
    pub lib: Library,
    pub diags: Diagnostics,
}

/// The largest file read: [`petriplc_files::IEC_SOURCE`].
pub const MAX_SOURCE_BYTES: u64 = petriplc_files::IEC_SOURCE.bytes;

/// Why sources could not be used.
#[derive(Debug, thiserror::Error)]
pub enum IecError {
    /// A source file that cannot be read, and why (said once: the reason is not also the
    /// error's source, which would print it twice in a chain of causes).
    #[error("cannot read {path}: {reason}")]
    Io { path: String, reason: String },
    /// Every error, rendered `file:line:col: error[Ennn]: …`, one per line.
    #[error("{0}")]
    Invalid(String),
    #[error("{0}")]
    Compile(#[from] petriplc_iec_vm::CompileError),
}

impl Sources {
    pub fn new() -> Self {
        Sources::default()
    }

    /// Adds a file: a TwinCAT 3 file (`.TcPOU`, `.TcDUT`, `.TcGVL`, `.TcTTO`, `.TcIO`) or a
    /// PLCopen XML project when it looks like one, Instruction List when its name ends in
    /// `.il`, Structured Text otherwise. A folder or a `.plcproj`: [`Sources::add_path`].
    /// Only a regular file of at most [`MAX_SOURCE_BYTES`] is read: a directory, a device
    /// (`/dev/zero` would never end) or a pipe is refused with what to name instead.
    pub fn add_file(&mut self, path: &Path) -> Result<(), IecError> {
        let text = read_source(path).map_err(|reason| IecError::Io {
            path: path.display().to_string(),
            reason,
        })?;
        let text = String::from_utf8_lossy(&text).into_owned();
        self.add_text(&path.display().to_string(), &text);
        Ok(())
    }

    /// Adds a source by its text; `name` is what messages print.
    pub fn add_text(&mut self, name: &str, text: &str) {
        let lib = if syntax::twincat::is_twincat(name, text) {
            syntax::twincat::read(&mut self.map, name, text, &mut self.diags)
        } else if syntax::plcopen::is_plcopen(text)
            || (name.to_ascii_lowercase().ends_with(".xml") && text.trim_start().starts_with('<'))
        {
            syntax::plcopen::read(&mut self.map, name, text, &mut self.diags)
        } else {
            let f = self.map.add(name, text);
            if name.to_ascii_lowercase().ends_with(".il") {
                syntax::parse_il(f, text, &mut self.diags)
            } else {
                syntax::parse(f, text, &mut self.diags)
            }
        };
        for e in lib.elements {
            self.push_element(e);
        }
    }

    /// Adds an element; the tasks of TwinCAT's task objects go into one configuration, the
    /// project's, whichever file they come from.
    fn push_element(&mut self, e: Element) {
        let existing = match &e {
            Element::Configuration(c) if self.is_twincat_tasks(c) => {
                self.lib.elements.iter().position(
                    |x| matches!(x, Element::Configuration(o) if self.is_twincat_tasks(o)),
                )
            }
            _ => None,
        };
        match (existing, e) {
            (Some(i), Element::Configuration(c)) => {
                if let Element::Configuration(o) = &mut self.lib.elements[i] {
                    for (ours, theirs) in o.resources.iter_mut().zip(c.resources) {
                        ours.tasks.extend(theirs.tasks);
                        ours.programs.extend(theirs.programs);
                    }
                }
            }
            (_, e) => self.lib.elements.push(e),
        }
    }

    fn is_twincat_tasks(&self, c: &syntax::ast::Configuration) -> bool {
        c.name.is(syntax::twincat::TASKS_CONFIGURATION)
            && self.map.get(c.span.file).is_some_and(|f| f.from_twincat)
    }

    /// Every diagnostic rendered, one per line.
    pub fn render(&self, diags: &Diagnostics) -> String {
        diags.render(&self.map)
    }
}

/// The bytes of a source file, or why not (for a person).
fn read_source(path: &Path) -> Result<Vec<u8>, String> {
    petriplc_files::read(path, petriplc_files::IEC_SOURCE).map_err(|e| e.reason())
}

/// What to run.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub enum Select {
    /// The configuration's program instances, or the only PROGRAM.
    #[default]
    Auto,
    /// One PROGRAM by name (case-insensitive).
    Pou(String),
}

/// The function blocks implemented in Rust that programs may use: the standard ones, and
/// any added (DSP blocks…).
pub struct Natives {
    pub fbs: Vec<Box<dyn NativeFb>>,
}

impl Default for Natives {
    fn default() -> Self {
        let mut fbs = petriplc_iec_vm::native::standard();
        fbs.extend(dsp_fbs::blocks());
        Natives { fbs }
    }
}

impl Natives {
    /// Adds a block; programs use it by its signature's name.
    pub fn with(mut self, fb: Box<dyn NativeFb>) -> Self {
        self.fbs.push(fb);
        self
    }

    fn extra_signatures(&self) -> Vec<sema::ir::NativeSig> {
        let std = petriplc_iec_sema::standard_fbs().len();
        self.fbs[std..].iter().map(|f| f.signature()).collect()
    }
}

/// A checked project.
pub struct Checked {
    pub project: Project,
    /// Warnings, rendered.
    pub warnings: Vec<String>,
}

/// Checks sources: every error at once, rendered, or the project and its warnings.
pub fn check(sources: &Sources, natives: &Natives) -> Result<Checked, IecError> {
    let mut all = sources.diags.clone();
    let options = sema::Options {
        natives: natives.extra_signatures(),
    };
    // A source with syntax errors is not checked further (its tree is partial).
    let project = if all.has_errors() {
        None
    } else {
        let (p, d) = sema::check(&sources.lib, &options);
        all.extend(d);
        p
    };
    let all = all.sorted();
    if all.has_errors() {
        return Err(IecError::Invalid(
            sources.render(&all).trim_end().to_string(),
        ));
    }
    let warnings = all
        .items
        .iter()
        .filter(|d| d.severity == Severity::Warning)
        .map(|d| d.render(&sources.map))
        .collect();
    match project {
        Some(project) => Ok(Checked { project, warnings }),
        None => Err(IecError::Invalid("no project".into())),
    }
}

/// A compiled program, ready for machines.
pub struct Build {
    pub engine: Arc<Engine>,
    pub warnings: Vec<String>,
}

/// The program instances `select` names in a checked project.
pub fn instances(
    project: &Project,
    select: &Select,
    map: &SourceMap,
) -> Result<Vec<InstanceSpec>, IecError> {
    let err = |span: Span, msg: String| {
        let d = Diagnostic::error(diag::NO_PROGRAM, span, msg);
        IecError::Invalid(d.render(map))
    };
    let any_span = project.pous.first().map(|p| p.span).unwrap_or_default();
    match select {
        Select::Pou(name) => {
            let Some(p) = project.pou_by_name(name) else {
                let programs: Vec<&str> =
                    project.programs().map(|(_, p)| p.name.as_str()).collect();
                return Err(err(
                    any_span,
                    format!(
                        "no POU named `{name}`; the programs are {}",
                        list(&programs)
                    ),
                ));
            };
            let pou = project.pou(p);
            if pou.kind != PouKind::Program {
                return Err(err(
                    pou.span,
                    format!("{name} is a {}; choose a PROGRAM", pou.kind.keyword()),
                ));
            }
            Ok(vec![InstanceSpec {
                name: pou.name.clone(),
                pou: p,
                task: None,
                inputs: Vec::new(),
                outputs: Vec::new(),
            }])
        }
        Select::Auto => {
            if let Some(c) = &project.configuration {
                if c.programs.is_empty() {
                    return Err(err(c.span, format!("CONFIGURATION {} runs no program; add `PROGRAM name WITH task : type;` to a RESOURCE", c.name)));
                }
                return Ok(c
                    .programs
                    .iter()
                    .map(|pi| InstanceSpec {
                        name: pi.name.clone(),
                        pou: pi.pou,
                        task: pi.task,
                        inputs: pi.inputs.clone(),
                        outputs: pi.outputs.clone(),
                    })
                    .collect());
            }
            let programs: Vec<(u32, &sema::ir::Pou)> =
                project.programs().filter(|(_, p)| p.runnable).collect();
            match programs.as_slice() {
                [(id, p)] => Ok(vec![InstanceSpec {
                    name: p.name.clone(),
                    pou: *id,
                    task: None,
                    inputs: Vec::new(),
                    outputs: Vec::new(),
                }]),
                [] => Err(err(
                    any_span,
                    "no PROGRAM to run; declare one (PROGRAM main … END_PROGRAM)".into(),
                )),
                many => {
                    let names: Vec<&str> = many.iter().map(|(_, p)| p.name.as_str()).collect();
                    Err(err(many[1].1.span, format!("several programs ({}); choose one (--pou NAME, or `pou = NAME`) or add a CONFIGURATION", list(&names))))
                }
            }
        }
    }
}

fn list(names: &[&str]) -> String {
    if names.is_empty() {
        "(none)".into()
    } else {
        names.join(", ")
    }
}

/// Checks and compiles sources for what `select` names.
pub fn build(sources: &Sources, select: &Select, natives: Natives) -> Result<Build, IecError> {
    let checked = check(sources, &natives)?;
    let specs = instances(&checked.project, select, &sources.map)?;
    #[cfg_attr(not(feature = "jit"), allow(unused_mut))]
    let mut engine = Engine::new(checked.project, &specs, natives.fbs, &sources.map)?;
    // Machine code for the programs (docs/iec.md, "Speed"), made when the first machine is;
    // the VM runs them when it cannot be made, or when the `jit` feature is left out.
    #[cfg(feature = "jit")]
    if let Some(e) = Arc::get_mut(&mut engine) {
        e.set_compiler(Box::new(|e| {
            petriplc_iec_jit::compile(e)
                .ok()
                .map(|j| Box::new(j) as Box<dyn petriplc_iec_vm::Compiled>)
        }));
    }
    Ok(Build {
        engine,
        warnings: checked.warnings,
    })
}

/// Reads, checks and compiles one file, folder or TwinCAT project ([`Sources::add_path`]).
pub fn build_file(path: &Path, select: &Select) -> Result<Build, IecError> {
    let mut s = Sources::new();
    s.add_path(path)?;
    build(&s, select, Natives::default())
}

/// Builds from a text (tests, examples).
pub fn build_text(name: &str, text: &str, select: &Select) -> Result<Build, IecError> {
    let mut s = Sources::new();
    s.add_text(name, text);
    build(&s, select, Natives::default())
}
