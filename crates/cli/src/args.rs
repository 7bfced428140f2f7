//! Command-line options, validated into typed values by clap's parsers.

use std::path::PathBuf;
use std::time::Duration;

use clap::{Args, Parser, Subcommand, ValueEnum};
use petriplc_net::{Evolution, StepRule};

#[derive(Debug, Parser)]
#[command(
    name = "petriplc",
    version,
    about = "Petri-net soft PLC toolchain: model, simulate, analyse, generate code, run"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Simulate a net scan by scan against a timeline of inputs and/or a plant.
    Sim(SimArgs),
    /// Check a net: invariants, boundedness, reachability graph, deadlocks, liveness,
    /// conflicts, SIPN checks, and closed-loop properties against a plant net.
    Analyze(AnalyzeArgs),
    /// Generate PLC code: ST, IL, LD or SFC in a PLCopen XML project, or C.
    Compile(CompileArgs),
    /// Run the soft PLC a configuration file describes, until stopped.
    Run(RunArgs),
    /// Print the modules of a running PLC: state, process, scans, cycle times, overruns.
    Status(PlcIdArgs),
    /// Stop a running PLC cleanly.
    Stop(PlcIdArgs),
}

/// How names in the PNML file are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Names {
    /// Names are just labels; signals come from petriplc's toolspecific data.
    Plain,
    /// Seed 002's SIPN convention: a place's name is its output, a transition's name its
    /// input condition (`!B1` negates), `default…` names are internal; capacity 1 everywhere.
    Sipn,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum StepArg {
    /// All transitions judged against the marking at the start of the pass (seed 003).
    MaximalStep,
    /// Each transition fires at once in priority order (seed 004's C).
    Sequential,
}

impl From<StepArg> for StepRule {
    fn from(s: StepArg) -> Self {
        match s {
            StepArg::MaximalStep => StepRule::MaximalStep,
            StepArg::Sequential => StepRule::Sequential,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EvolveArg {
    /// One pass per scan (seed 002's and 003's generated code).
    OnePass,
    /// Passes repeat within the scan until none fires (seed 004, SIPN).
    UntilStable,
}

impl From<EvolveArg> for Evolution {
    fn from(e: EvolveArg) -> Self {
        match e {
            EvolveArg::OnePass => Evolution::OnePass,
            EvolveArg::UntilStable => Evolution::UntilStable,
        }
    }
}

#[derive(Debug, Args)]
#[command(after_long_help = "Examples:\n  \
    petriplc sim examples/mixer/mixer.pnml --names sipn --inputs examples/mixer/timeline.csv --out trace.csv --plot trace.svg\n  \
    petriplc sim examples/busy-beaver/busy-beaver.pnml --plant tape --until 1s\n  \
    petriplc sim examples/keyboard/keyboard.pnml --plant keyboard --inputs examples/keyboard/timeline.csv --plot out/keys.svg --signals line1,col1,accepted1 --from 1s --to 1.2s\n  \
    petriplc sim examples/mixer/mixer.pnml --names sipn --step-through\n\n\
    Exit codes: 0 success, 1 the simulation failed (e.g. an unstable net), 2 bad input.")]
pub struct SimArgs {
    /// The controller net (PNML).
    pub net: PathBuf,
    /// How names in the net are read.
    #[arg(long, value_enum, default_value = "plain")]
    pub names: Names,
    /// Input timeline: CSV with header `time,SIG1,SIG2,...`; a value holds until the next row.
    #[arg(long, value_name = "CSV")]
    pub inputs: Option<PathBuf>,
    /// A plant: a built-in name (`tape`, `keyboard`, `tank`) or a plant net (PNML) whose
    /// outputs feed the controller's inputs by name.
    #[arg(long, value_name = "NAME|PNML")]
    pub plant: Option<String>,
    /// Scan period (`10ms`, `T#10ms`, `0.01`).
    #[arg(long, default_value = "10ms", value_parser = parse_period)]
    pub period: Duration,
    /// Simulated time to stop at [default: 1 s after the timeline's last row, or 10 s].
    #[arg(long, value_parser = parse_time)]
    pub until: Option<Duration>,
    /// Step rule [default: the net's own, else maximal-step].
    #[arg(long, value_enum)]
    pub step: Option<StepArg>,
    /// Evolution per scan [default: the net's own, else one-pass].
    #[arg(long, value_enum)]
    pub evolve: Option<EvolveArg>,
    /// With `until-stable`: the most passes one scan may make.
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u32).range(1..))]
    pub max_passes: u32,
    /// Write the trace here (CSV); without --out or --plot it goes to standard output.
    #[arg(long, value_name = "CSV")]
    pub out: Option<PathBuf>,
    /// Write an SVG step plot of inputs, outputs and markings.
    #[arg(long, value_name = "SVG")]
    pub plot: Option<PathBuf>,
    /// The plot's lanes, in this order: input and output names, `m:PLACE` for a marking
    /// [default: every input, output and marking, less markings that repeat an output].
    #[arg(long, value_name = "NAME,…", value_delimiter = ',', requires = "plot")]
    pub signals: Option<Vec<String>>,
    /// The plot's time window starts here (`2s`, `1.5`) [default: 0].
    #[arg(long, value_name = "TIME", value_parser = parse_time, requires = "plot")]
    pub from: Option<Duration>,
    /// The plot's time window ends here [default: the end of the run].
    #[arg(long, value_name = "TIME", value_parser = parse_time, requires = "plot")]
    pub to: Option<Duration>,
    /// Interactive stepwise simulation: Enter runs a scan, a signal name toggles it.
    #[arg(long, conflicts_with_all = ["out", "plot"])]
    pub step_through: bool,
}

#[derive(Debug, Args)]
#[command(after_long_help = "Examples:\n  \
    petriplc analyze ../shared/data/mcc/Kanban-PT-00005/model.pnml --json\n  \
    petriplc analyze examples/mixer/mixer.pnml --names sipn --svg out/mixer-rg.svg\n  \
    petriplc analyze examples/mixer/mixer.pnml --names sipn --plant examples/mixer/tank.pnml --never overfill\n\n\
    Exit codes: 0 analysed; 1 --never found the place reachable, or the analysis failed; 2 bad input.\n\
    The JSON format is documented in docs/analysis.md.")]
pub struct AnalyzeArgs {
    /// The net (PNML).
    pub net: PathBuf,
    /// How names in the net are read.
    #[arg(long, value_enum, default_value = "plain")]
    pub names: Names,
    /// Print the report as JSON (docs/analysis.md) instead of text.
    #[arg(long)]
    pub json: bool,
    /// Write the reachability graph in Graphviz DOT.
    #[arg(long, value_name = "FILE")]
    pub dot: Option<PathBuf>,
    /// Write the reachability graph as SVG (needs Graphviz's `dot`).
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
    /// The most states a drawn graph may have.
    #[arg(long, default_value_t = 1000, value_name = "N")]
    pub graph_limit: u64,
    /// Stop exploring after this many states (the report is then marked incomplete).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_states: Option<u64>,
    /// Stop exploring when the state space holds this much memory (`512M`, `2G`, bytes), and
    /// skip the liveness checks that would need more; the report is then marked incomplete.
    /// Default: half the machine's physical memory.
    #[arg(long, value_name = "SIZE", value_parser = parse_size)]
    pub max_memory: Option<u64>,
    /// A plant net whose outputs feed the controller's inputs by name (closed loop).
    #[arg(long, value_name = "PNML")]
    pub plant: Option<PathBuf>,
    /// Prove that this place (`NAME`, `plant:NAME` or `controller:NAME`) is never marked in
    /// the closed loop, or print a counterexample timeline.
    #[arg(long, value_name = "PLACE", requires = "plant")]
    pub never: Option<String>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LangArg {
    /// Structured Text (PLCopen XML, or bare text with --plain).
    St,
    /// Instruction List (PLCopen XML, or bare text with --plain).
    Il,
    /// Ladder Diagram in PLCopen XML (safe nets).
    Ld,
    /// Sequential Function Chart in PLCopen XML (safe nets meeting seed 002's constraints).
    Sfc,
    /// One C99 file with `step()`; build with -DPETRIPLC_MAIN for a timeline-driven main.
    C,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MarkingsArg {
    /// BOOL when every place is provably safe, else integers.
    Auto,
    /// BOOL markings (seed 002); refused for a net not provably safe.
    Bool,
    /// Integer markings (seed 003, seed 004).
    Int,
}

#[derive(Debug, Args)]
#[command(after_long_help = "Examples:\n  \
    petriplc compile examples/mixer/mixer.pnml --names sipn --lang st --out mixer.xml\n  \
    petriplc compile examples/mixer/mixer.pnml --names sipn --lang sfc --out mixer-sfc.xml\n  \
    petriplc compile examples/blink/blink.pnml --lang st --plain\n  \
    petriplc compile examples/blink/blink.pnml --lang c --out blink.c && cc -DPETRIPLC_MAIN -o blink blink.c && ./blink examples/blink/timeline.csv --until 9s\n\n\
    Exit codes: 0 written, 2 bad input (including a net the language cannot express).\n\
    The generated code is described in docs/codegen.md.")]
pub struct CompileArgs {
    /// The net (PNML).
    pub net: PathBuf,
    /// The target language.
    #[arg(long, value_enum)]
    pub lang: LangArg,
    /// Write here instead of standard output.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Bare ST or IL text instead of a PLCopen XML project.
    #[arg(long)]
    pub plain: bool,
    /// How names in the net are read.
    #[arg(long, value_enum, default_value = "plain")]
    pub names: Names,
    /// Step rule [default: the net's own, else maximal-step].
    #[arg(long, value_enum)]
    pub step: Option<StepArg>,
    /// Evolution per scan [default: the net's own, else one-pass].
    #[arg(long, value_enum)]
    pub evolve: Option<EvolveArg>,
    /// With `until-stable`: the most passes one scan may make.
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u32).range(1..))]
    pub max_passes: u32,
    /// How markings are represented.
    #[arg(long, value_enum, default_value = "auto")]
    pub markings: MarkingsArg,
    /// The program's name [default: the net's name].
    #[arg(long, value_name = "NAME")]
    pub pou: Option<String>,
    /// The period of the PLC task (PLCopen XML) and of the C main's scans.
    #[arg(long, default_value = "10ms", value_parser = parse_period)]
    pub period: Duration,
}

/// The default PLC id: the one `petriplc run` uses without `--plc-id`.
pub const DEFAULT_PLC_ID: &str = "petriplc";

#[derive(Debug, Args)]
#[command(after_long_help = "Examples:\n  \
    petriplc run examples/mixer/plc.conf\n  \
    petriplc run examples/mixer/plc.conf --plc-id line2 --for 30s --log out/plc.log\n\n\
    The configuration syntax is MatPLC's (docs/runtime.md). Stop with Ctrl-C or `petriplc stop`.\n\
    Exit codes: 0 stopped cleanly, 1 a module failed or the PLC could not start, 2 bad configuration.")]
pub struct RunArgs {
    /// The configuration file.
    pub config: PathBuf,
    /// Names this PLC's shared memory, so several run side by side.
    #[arg(long, default_value = DEFAULT_PLC_ID, value_name = "ID")]
    pub plc_id: String,
    /// Stop after this long (`30s`, `T#1m`).
    #[arg(long = "for", value_name = "DURATION", value_parser = parse_time)]
    pub duration: Option<Duration>,
    /// Also write the log to this file.
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// The least important messages shown.
    #[arg(long, default_value = "info", value_parser = ["error", "warn", "info", "debug", "trace"])]
    pub log_level: String,
    /// Overrides a setting of a module's section, e.g. `--set hmi:listen=127.0.0.1:8081`
    /// (repeatable).
    #[arg(long = "set", value_name = "MODULE:SETTING=VALUE")]
    pub overrides: Vec<petriplc_config::Override>,
}

#[derive(Debug, Args)]
pub struct PlcIdArgs {
    /// Which PLC.
    #[arg(long, default_value = DEFAULT_PLC_ID, value_name = "ID")]
    pub plc_id: String,
}

fn parse_time(s: &str) -> Result<Duration, String> {
    petriplc_net::time::parse_duration(s).map_err(|e| e.to_string())
}

/// A size in bytes: a whole or decimal number with an optional unit K, M, G or T (powers of
/// 1024; `KB`, `MiB` and lower case also accepted).
pub(crate) fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let shift = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kb" | "kib" => 10,
        "m" | "mb" | "mib" => 20,
        "g" | "gb" | "gib" => 30,
        "t" | "tb" | "tib" => 40,
        _ => return Err(format!("`{s}`: write a size such as 512M, 2G or 1.5G")),
    };
    let v: f64 = num
        .parse()
        .map_err(|_| format!("`{s}`: write a size such as 512M, 2G or 1.5G"))?;
    let bytes = v * (1u64 << shift) as f64;
    if !(1.0..1.8e19).contains(&bytes) {
        return Err(format!(
            "`{s}`: a size of at least 1 byte, such as 512M or 2G"
        ));
    }
    Ok(bytes as u64)
}

fn parse_period(s: &str) -> Result<Duration, String> {
    let d = parse_time(s)?;
    if d.is_zero() {
        return Err("the scan period must be longer than 0 (e.g. `10ms`)".into());
    }
    Ok(d)
}
