//! IEC 61131-3 programs in one call: read sources (Structured Text and Instruction List files, PLCopen XML
//! projects, TwinCAT 3 files and projects, folders of them: [`project`]), check them, choose what runs (a configuration's tasks, or one PROGRAM) and
//! compile it for the engine ([`build`]); simulate a program against a timeline and a plant
//! with the trace format of `petriplc sim` ([`sim`]).

pub mod beremiz;
#[cfg(test)]
mod code_examples;
pub mod dsp_fbs;
pub mod project;
pub mod sim;
pub mod vendor_fbs;

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
pub use petriplc_iec_syntax::Dialect;
pub use petriplc_iec_vm as vm;

pub use petriplc_iec_sema::vendor::vendor_libs_for;

/// Sources read and parsed, with their diagnostics so far.
#[derive(Clone, Debug, Default)]
pub struct Sources {
    pub map: SourceMap,
    pub lib: Library,
    pub diags: Diagnostics,
    /// The dialect chosen (`--dialect`, `dialect = …`); `None`: the one the files show
    /// ([`Sources::detected`]), else `iec` ([`Sources::dialect`]).
    pub dialect: Option<Dialect>,
    /// The dialect a file read so far shows it is written in (a TwinCAT file).
    pub detected: Option<Dialect>,
    /// What integer overflow does when the program runs: wrap (the default, as CODESYS,
    /// TwinCAT, matiec and OpenPLC) or fault (docs/iec.md). Set after [`Sources::new`].
    pub overflow: sema::Overflow,
    /// Vendor libraries to load (`codesys`, `twincat`, `pcworx`: docs/iec.md, "Vendor
    /// libraries"); a dialect's are [`vendor_libs_for`].
    pub libs: Vec<String>,
    /// Vendor libraries the files show they use: `beremiz` for a PLCopen project Beremiz
    /// wrote ([`beremiz::written_by_beremiz`]).
    pub detected_libs: Vec<String>,
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
    /// A vendor library name that is not one (`--lib`, `libs =`), with the known ones.
    #[error("{0}")]
    UnknownLibrary(String),
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
        let name = path.display().to_string();
        match String::from_utf8(text) {
            Ok(text) => self.add_text(&name, &text),
            // Not UTF-8: a file saved in a single-byte code page, as CODESYS, TwinCAT and
            // PCWorx write them (OSCAT's `ä`, `°`): read as Latin-1, each byte one character,
            // so a STRING literal holds the file's bytes (the lexer makes every character up
            // to U+00FF one byte, whatever the encoding).
            Err(e) => {
                let text: String = e.into_bytes().iter().map(|&b| b as char).collect();
                self.add_text(&name, &text);
            }
        }
        Ok(())
    }

    /// The dialect the project is checked in: the one chosen, else the one detected, else
    /// the standard's.
    pub fn dialect(&self) -> Dialect {
        self.dialect.or(self.detected).unwrap_or_default()
    }

    /// The vendor libraries loaded: those asked for ([`Sources::libs`] the field: `--lib`,
    /// `libs = …`), then the dialect's own (`codesys` for CODESYS, `codesys` and `twincat`
    /// for TwinCAT, `pcworx` for PCWorx; none for `iec`), each once.
    pub fn libs(&self) -> Vec<String> {
        let mut libs = self.libs.clone();
        let dialect = sema::vendor::vendor_libs_for(self.dialect().name());
        for l in self.detected_libs.iter().cloned().chain(dialect) {
            if !libs.iter().any(|x| x.eq_ignore_ascii_case(&l)) {
                libs.push(l);
            }
        }
        libs
    }

    /// Adds a source by its text; `name` is what messages print.
    pub fn add_text(&mut self, name: &str, text: &str) {
        if self.detected.is_none() {
            self.detected = Dialect::detect(name, text);
        }
        let lib = if syntax::twincat::is_twincat(name, text) {
            syntax::twincat::read(&mut self.map, name, text, &mut self.diags)
        } else if syntax::plcopen::is_plcopen(text)
            || (name.to_ascii_lowercase().ends_with(".xml") && text.trim_start().starts_with('<'))
        {
            if beremiz::written_by_beremiz(text) && self.detected_libs.is_empty() {
                self.detected_libs.push("beremiz".into());
            }
            syntax::plcopen::read(&mut self.map, name, text, &mut self.diags)
        } else {
            let f = self.map.add(name, text);
            let lib = if name.to_ascii_lowercase().ends_with(".il") {
                syntax::parse_il(f, text, &mut self.diags)
            } else {
                syntax::parse(f, text, &mut self.diags)
            };
            if beremiz::generated_by_beremiz(&lib) && self.detected_libs.is_empty() {
                self.detected_libs.push("beremiz".into());
            }
            lib
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

    /// The standard blocks (always first) as `dialect` names their inputs: the project is
    /// checked with those names ([`Sources::dialect`]), and the engine must run the same.
    pub fn in_dialect(mut self, dialect: Dialect) -> Self {
        let std = petriplc_iec_sema::standard_fbs().len();
        self.fbs
            .splice(0..std, petriplc_iec_vm::native::standard_in(dialect));
        self
    }

    /// Adds the function blocks of vendor libraries `libs`: what [`build`] does with
    /// [`Sources::libs`], for a caller that makes its own engine. A loaded library's block
    /// replaces, in its place, a block of the same name (CODESYS's HYSTERESIS the DSP one):
    /// the library was asked for by name.
    pub fn with_libs(mut self, libs: &[String]) -> Self {
        let std = petriplc_iec_sema::standard_fbs().len();
        for fb in vendor_fbs::blocks(libs) {
            let name = fb.signature().name;
            match self.fbs[std..]
                .iter()
                .position(|f| f.signature().name == name)
            {
                Some(i) => self.fbs[std + i] = fb,
                None => self.fbs.push(fb),
            }
        }
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

/// Checks sources: every error at once, rendered, or the project and its warnings. The
/// sources may be a library checked alone: a VAR_EXTERNAL whose global is elsewhere is a
/// warning here (W021), an error when a program is built ([`build`]).
pub fn check(sources: &Sources, natives: &Natives) -> Result<Checked, IecError> {
    check_as(sources, natives, true)
}

/// Checks sources that are to run (the `iec` module, `petriplc sim`): [`check`], but a
/// VAR_EXTERNAL whose global is missing is the error E106, as in [`build`].
pub fn check_to_run(sources: &Sources, natives: &Natives) -> Result<Checked, IecError> {
    check_as(sources, natives, false)
}

/// [`check`], of a `library` or of a program to run, with the vendor libraries' blocks.
fn check_as(sources: &Sources, natives: &Natives, library: bool) -> Result<Checked, IecError> {
    // As `Natives::with_libs` places them (the same signature twice is harmless).
    let mut extra = natives.extra_signatures();
    for sig in sema::vendor::signatures(&sources.libs()) {
        match extra.iter().position(|e| e.name == sig.name) {
            Some(i) => extra[i] = sig,
            None => extra.push(sig),
        }
    }
    check_with(sources, extra, library)
}

/// [`check`] with the native function blocks beside the standard ones (`extra`: the
/// caller's, then the vendor libraries', in the order the engine gets them).
fn check_with(
    sources: &Sources,
    extra: Vec<sema::ir::NativeSig>,
    library: bool,
) -> Result<Checked, IecError> {
    let libs = sources.libs();
    sema::vendor::check_names(&libs).map_err(IecError::UnknownLibrary)?;
    let mut all = sources.diags.clone();
    let options = sema::Options {
        natives: extra,
        dialect: sources.dialect(),
        library,
        overflow: sources.overflow,
        libs,
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
        // A library replacing a standard block (Beremiz's PID) is what loading it asks for.
        .filter(|d| !syntax::builtin::is_builtin(d.span.file))
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
    let natives = natives
        .in_dialect(sources.dialect())
        .with_libs(&sources.libs());
    let checked = check_with(sources, natives.extra_signatures(), false)?;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A library names a global its user declares: checked alone it warns, built to run it
    /// is refused.
    #[test]
    fn a_missing_global_is_an_error_only_to_run() {
        let src =
            "FUNCTION_BLOCK ticks VAR_EXTERNAL PLC_TICKS_PER_SEC : INT; END_VAR END_FUNCTION_BLOCK
PROGRAM main VAR t : ticks; END_VAR t(); END_PROGRAM";
        let mut s = Sources::new();
        s.add_text("lib.st", src);
        let checked = check(&s, &Natives::default()).expect("checks as a library");
        assert_eq!(checked.warnings.len(), 1, "{:?}", checked.warnings);
        assert!(
            checked.warnings[0].contains("lib.st:1:35: warning[W021]"),
            "{:?}",
            checked.warnings
        );
        for e in [
            check_to_run(&s, &Natives::default()).err(),
            build(&s, &Select::Auto, Natives::default()).err(),
        ] {
            let e = e.expect("refused to run").to_string();
            assert!(
                e.contains(
                    "lib.st:1:35: error[E106]: VAR_EXTERNAL PLC_TICKS_PER_SEC has no VAR_GLOBAL"
                ),
                "{e}"
            );
        }
    }
}
