//! Command-line options, validated into typed values by clap's parsers.

use std::path::PathBuf;
use std::time::Duration;

use clap::{Args, Parser, Subcommand, ValueEnum};
use petriplc_net::{Evolution, StepRule};

use crate::failure::exit_codes;

#[derive(Debug, Parser)]
#[command(
    name = "petriplc",
    version,
    about = "Petri-net soft PLC toolchain: model, simulate, analyse, generate code, run",
    after_help = exit_codes!()
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Simulate a net, or an IEC 61131-3 program, scan by scan against a timeline of inputs
    /// and/or a plant.
    Sim(SimArgs),
    /// Check IEC 61131-3 sources (Structured Text, PLCopen XML) without running them.
    Check(CheckArgs),
    /// Check a net: invariants, boundedness, reachability graph, deadlocks, liveness,
    /// conflicts, SIPN checks, and closed-loop properties against a plant net.
    Analyze(AnalyzeArgs),
    /// Generate PLC code: ST, IL, LD or SFC in a PLCopen XML project, or C.
    Compile(CompileArgs),
    /// Run the soft PLC a configuration file describes, until stopped.
    Run(RunArgs),
    /// Print the modules of a running PLC: state, process, scans, cycle times, overruns.
    #[command(after_long_help = concat!("Examples:\n  \
        petriplc status\n  \
        petriplc status line2\n\n\
    0 while the PLC runs (or starts), 4 when no PLC has that id, 5 when it exited without\n\
    stopping: `petriplc stop` or the next `petriplc run` removes what it left.\n\n",
        exit_codes!()))]
    Status(PlcIdArgs),
    /// Stop a running PLC cleanly; for one that exited without stopping, remove what it left.
    #[command(after_long_help = concat!("Examples:\n  \
        petriplc stop line2\n  \
        petriplc stop\n\n\
    0 once stopped (or cleaned up after a PLC that had exited), 1 when the PLC did not\n\
    stop, 4 when no PLC has that id.\n\n",
        exit_codes!()))]
    Stop(PlcIdArgs),
    /// Add, replace or remove a user of an OPC UA server's password file (bcrypt hashes).
    #[command(after_long_help = concat!("Examples:\n  \
        petriplc user add out/opcua.users operator --replace <<< 'op-pass'\n  \
        petriplc user add out/opcua.users maint --replace --cost 10 <<< 'maint-pass'\n  \
        petriplc user remove out/opcua.users maint\n\n\
    In a terminal, `petriplc user add opcua.users operator` asks for the password twice,\n\
    without echo; from a pipe or a file it reads the first line of standard input (as\n\
    above). The file (`users = FILE` of an opcua_server, docs/opcua.md) is created with\n\
    mode 600 if missing and replaced in one step: a kill leaves the old file or the new\n\
    one, never half of it. A running PLC reads it at start. 2 when the user exists (add\n\
    without --replace) or is missing (remove), the name or password is refused, or the\n\
    file holds bad lines (nothing is changed then).\n\n",
        exit_codes!()))]
    User(UserArgs),
}

#[derive(Debug, Args)]
pub struct UserArgs {
    #[command(subcommand)]
    pub command: UserCommand,
}

#[derive(Debug, Subcommand)]
pub enum UserCommand {
    /// Add a user (or, with --replace, give it a new password); the password is read from
    /// the terminal without echo, or from the first line of standard input.
    #[command(after_long_help = concat!("Examples:\n  \
        petriplc user add out/opcua.users operator --replace <<< 'op-pass'\n\n",
        exit_codes!()))]
    Add(UserAddArgs),
    /// Remove a user.
    #[command(after_long_help = concat!("Examples:\n  \
        petriplc user remove out/opcua.users operator\n\n",
        exit_codes!()))]
    Remove(UserRemoveArgs),
}

#[derive(Debug, Args)]
pub struct UserAddArgs {
    /// The password file (`users = FILE` of an opcua_server), created if missing.
    pub file: PathBuf,
    /// The user name.
    pub name: String,
    /// Replace the password of a user who exists (else that is an error); add one who
    /// does not.
    #[arg(long)]
    pub replace: bool,
    /// bcrypt's cost: 2^COST rounds; each step doubles the time a login and a guess take.
    #[arg(long, default_value_t = 12, value_parser = clap::value_parser!(u32).range(4..=31))]
    pub cost: u32,
}

#[derive(Debug, Args)]
pub struct UserRemoveArgs {
    /// The password file.
    pub file: PathBuf,
    /// The user name.
    pub name: String,
}

/// How names in the PNML file are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Names {
    /// Names are just labels; signals come from petriplc's toolspecific data.
    Plain,
    /// The SIPN convention of the SIPN-to-PLCopen paper: a place's name is its output, a
    /// transition's name its input condition (`!B1` negates), `default…` names are
    /// internal; capacity 1 everywhere.
    Sipn,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum StepArg {
    /// All transitions judged against the marking at the start of the pass (as in
    /// J. Gaspar's "Running a Petri net with I/O").
    MaximalStep,
    /// Each transition fires at once in priority order (the C of the rapid control
    /// prototyping paper).
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
    /// One pass per scan (the generated code of the SIPN-to-PLCopen paper and of
    /// "Running a Petri net with I/O").
    OnePass,
    /// Passes repeat within the scan until none fires (SIPN, and the rapid control
    /// prototyping paper).
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
#[command(after_long_help = concat!("Examples:\n  \
    petriplc sim examples/mixer/mixer.pnml --names sipn \\\n      \
        --inputs examples/mixer/timeline.csv \\\n      \
        --out out/mixer-trace.csv --plot out/mixer-trace.svg\n  \
    petriplc sim examples/busy-beaver/busy-beaver.pnml --plant tape --until 1s\n  \
    petriplc sim examples/keyboard/keyboard.pnml --plant keyboard \\\n      \
        --inputs examples/keyboard/timeline.csv --plot out/keys.svg \\\n      \
        --signals line1,col1,accepted1 --from 1s --to 1.2s\n  \
    petriplc sim examples/mixer/mixer.pnml --names sipn --step-through\n  \
    petriplc sim examples/chaser/chaser.st \\\n      \
        --inputs examples/chaser/timeline.csv --until 3s\n\n\
    An IEC 61131-3 program (.st, .il, or a PLCopen XML project) is simulated\n\
    the same way: timeline columns and plant outputs drive its VAR_INPUTs by\n\
    name (in:NAME columns), the trace has a column per VAR_OUTPUT (--vars:\n\
    every variable);\n\
    --pou picks a PROGRAM, else the CONFIGURATION's tasks or the only PROGRAM\n\
    run. A run-time fault in the program exits 1.\n\n",
    exit_codes!()))]
pub struct SimArgs {
    /// The controller: a net (PNML), or an IEC 61131-3 program (.st, .il), PLCopen XML project,
    /// TwinCAT .plcproj project or folder of sources.
    pub net: PathBuf,
    /// How names in the net are read.
    #[arg(long, value_enum, default_value = "plain")]
    pub names: Names,
    /// Input timeline: CSV with header `time,SIG1,SIG2,...`; a value holds until the next row.
    #[arg(long, value_name = "CSV")]
    pub inputs: Option<PathBuf>,
    /// A plant: a built-in name (`tape`, `keyboard`, `tank`, `turntable`, `thermal`) or a plant net
    /// (PNML) whose outputs feed the controller's inputs by name.
    #[arg(long, value_name = "NAME|PNML")]
    pub plant: Option<String>,
    /// A setting of a built-in plant, e.g. `--plant-set K_alpha=45` for the turntable
    /// (repeatable; docs/runtime.md lists them).
    #[arg(long, value_name = "NAME=VALUE", requires = "plant", value_parser = parse_setting)]
    pub plant_set: Vec<(String, String)>,
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
    /// The plot's lanes, in this order: input and output names, `m:PLACE` for a marking,
    /// `plant:NAME` for a plant output the controller does not read [default: those plant
    /// outputs, every input, output and marking, less markings that repeat an output].
    #[arg(long, value_name = "NAME,…", value_delimiter = ',', requires = "plot")]
    pub signals: Option<Vec<String>>,
    /// The plot's time window starts here (`2s`, `1.5`) [default: 0].
    #[arg(long, value_name = "TIME", value_parser = parse_time, requires = "plot")]
    pub from: Option<Duration>,
    /// The plot's time window ends here [default: the end of the run].
    #[arg(long, value_name = "TIME", value_parser = parse_time, requires = "plot")]
    pub to: Option<Duration>,
    /// Write the inputs the controller read, scan by scan, as a timeline (`--inputs`'s
    /// format): replaying it runs the controller alone through the same scans, e.g. the
    /// generated C of `petriplc compile --lang c`.
    #[arg(long, value_name = "CSV")]
    pub inputs_out: Option<PathBuf>,
    /// Interactive stepwise simulation: Enter runs a scan, a signal name toggles it.
    #[arg(long, conflicts_with_all = ["out", "plot"])]
    pub step_through: bool,
    /// IEC programs: the PROGRAM to run [default: the CONFIGURATION's tasks, or the only
    /// PROGRAM].
    #[arg(long, value_name = "NAME")]
    pub pou: Option<String>,
    /// IEC programs: trace every variable of the program, not only its outputs.
    #[arg(long)]
    pub vars: bool,
    /// IEC programs: the vendor dialect where vendors disagree (`iec`, `codesys`, `twincat`,
    /// `pcworx`; docs/iec.md, "Dialects and vendor code") [default: detected from TwinCAT
    /// files, else iec].
    #[arg(long, value_name = "DIALECT", value_parser = parse_dialect)]
    pub dialect: Option<petriplc_iec::Dialect>,
    /// IEC programs: what an integer result outside its type does (docs/iec.md): `wrap`
    /// keeps its low bits, as CODESYS, TwinCAT, matiec and OpenPLC; `fault` stops the run.
    #[arg(long, value_enum, default_value = "wrap")]
    pub overflow: OverflowArg,
    /// IEC programs: load a vendor library (`codesys`, `twincat`, `pcworx`, `beremiz`; repeatable or
    /// comma-separated): its functions, such as CODESYS's TIME() or PCWorx's GET_CHAR, become
    /// callable (docs/iec.md, "Vendor libraries").
    #[arg(long, value_name = "NAME", value_delimiter = ',')]
    pub lib: Vec<String>,
}

#[derive(Debug, Args)]
#[command(after_long_help = concat!("Examples:\n  \
    petriplc check examples/chaser/chaser.st\n  \
    petriplc compile examples/mixer/mixer.pnml --names sipn --lang ld \\\n      \
        --out out/mixer-ld.xml && petriplc check out/mixer-ld.xml\n\n\
    Every problem is printed at once as `file:line:col: error[Ennn]: message`\n\
    (codes in docs/iec.md): 0 when there is no error (warnings may be printed),\n\
    2 otherwise.\n\n",
    exit_codes!()))]
pub struct CheckArgs {
    /// Structured Text, Instruction List, PLCopen XML and TwinCAT 3 files, folders of them and
    /// TwinCAT .plcproj projects, checked together as one project.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Also compile the named PROGRAM (or, without it, what would run) for the engine.
    #[arg(long, value_name = "NAME")]
    pub pou: Option<String>,
    /// The vendor dialect where vendors disagree (`iec`, `codesys`, `twincat`, `pcworx`;
    /// docs/iec.md, "Dialects and vendor code") [default: detected from TwinCAT files, else
    /// iec].
    #[arg(long, value_name = "DIALECT", value_parser = parse_dialect)]
    pub dialect: Option<petriplc_iec::Dialect>,
    /// What an integer result outside its type does when the program runs: `wrap` or
    /// `fault` (constant conversions and shift counts fold by it).
    #[arg(long, value_enum, default_value = "wrap")]
    pub overflow: OverflowArg,
    /// Load a vendor library (`codesys`, `twincat`, `pcworx`, `beremiz`; repeatable or
    /// comma-separated): its functions, such as CODESYS's TIME() or PCWorx's GET_CHAR, become
    /// callable (docs/iec.md, "Vendor libraries").
    #[arg(long, value_name = "NAME", value_delimiter = ',')]
    pub lib: Vec<String>,
}

fn parse_dialect(s: &str) -> Result<petriplc_iec::Dialect, String> {
    s.parse()
        .map_err(|e: petriplc_iec::syntax::dialect::UnknownDialect| e.to_string())
}

/// `--overflow`: integer overflow, shift counts and REAL-to-integer conversions out of
/// range (docs/iec.md, "Rules where the standard leaves a choice").
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OverflowArg {
    /// Two's complement in the result's type.
    Wrap,
    /// A run-time fault.
    Fault,
}

impl From<OverflowArg> for petriplc_iec::sema::Overflow {
    fn from(o: OverflowArg) -> Self {
        match o {
            OverflowArg::Wrap => petriplc_iec::sema::Overflow::Wrap,
            OverflowArg::Fault => petriplc_iec::sema::Overflow::Fault,
        }
    }
}

#[derive(Debug, Args)]
#[command(after_long_help = concat!("Examples:\n  \
    petriplc analyze examples/philosophers/philosophers.pnml --json\n  \
    petriplc analyze examples/mixer/mixer.pnml --names sipn --svg out/mixer-rg.svg\n  \
    petriplc analyze examples/mixer/mixer.pnml --names sipn \\\n      \
        --plant examples/mixer/tank-observed.pnml --never both_open\n  \
    petriplc analyze examples/turntable/controller.pnml \\\n      \
        --plant examples/turntable/plant.pnml --period 10ms \\\n      \
        --never E_sector --never E_fall\n\n\
    The third proves that the mixer never opens its inlet and outlet valves together.\n\
    Without --period, --never answers about an abstraction of the closed loop: the\n\
    controller's scans are exact, but the plant net's delays are ignored (the plant may\n\
    move any number of times between two scans) and free inputs take any value. So\n\
    `proved` holds for every scan period and plant timing, while a counterexample may need\n\
    the plant to be faster than its delays allow (docs/analysis-plc.md, section 5). With\n\
    --period the closed loop is timed at that scan period: controller timers exact, the\n\
    plant's delays and deadlines kept as the bounds of its timing; the fourth proves that\n\
    the turntable never reaches an error place at a 10 ms scan. The JSON format is\n\
    documented in docs/analysis.md.\n\n",
    exit_codes!()))]
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
    /// the closed loop, or print a counterexample timeline (repeatable: one search for all).
    #[arg(long, value_name = "PLACE", requires = "plant")]
    pub never: Vec<String>,
    /// Analyse the closed loop at this scan period (`10ms`): controller timers exact, plant
    /// arc delays and transition deadlines kept. Without it: every timing.
    #[arg(long, value_name = "PERIOD", requires = "plant", value_parser = parse_period)]
    pub period: Option<Duration>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LangArg {
    /// Structured Text (PLCopen XML, or bare text with --plain).
    St,
    /// Instruction List (PLCopen XML, or bare text with --plain).
    Il,
    /// Ladder Diagram in PLCopen XML (safe nets).
    Ld,
    /// Sequential Function Chart in PLCopen XML (safe nets meeting the SIPN-to-PLCopen
    /// paper's constraints).
    Sfc,
    /// One C99 file with `step()`; build with -DPETRIPLC_MAIN for a timeline-driven main.
    C,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MarkingsArg {
    /// BOOL when every place is provably safe, else integers.
    Auto,
    /// BOOL markings (as the SIPN-to-PLCopen paper); refused for a net not provably safe.
    Bool,
    /// Integer markings.
    Int,
}

#[derive(Debug, Args)]
#[command(after_long_help = concat!("Examples:\n  \
    petriplc compile examples/mixer/mixer.pnml --names sipn --lang st \\\n      \
        --out out/mixer.xml\n  \
    petriplc compile examples/mixer/mixer.pnml --names sipn --lang sfc \\\n      \
        --out out/mixer-sfc.xml\n  \
    petriplc compile examples/blink/blink.pnml --lang st --plain\n  \
    petriplc compile examples/blink/blink.pnml --lang c --out out/blink.c && \\\n      \
        cc -DPETRIPLC_MAIN -o out/blink out/blink.c && \\\n      \
        out/blink examples/blink/timeline.csv --until 9s\n\n\
    The generated code is described in docs/codegen.md. A net the language cannot express\n\
    is bad input (exit code 2).\n\n",
    exit_codes!()))]
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
#[command(after_long_help = concat!("Examples:\n  \
    petriplc run examples/mixer/plc.conf\n  \
    petriplc run examples/mixer/plc.conf --plc-id line2 --for 30s \\\n      \
        --set modbus:listen=127.0.0.1:5021 --set hmi:listen=127.0.0.1:8081 \\\n      \
        --log out/line2.log\n\n\
    The second runs beside the first: its own PLC id, its own ports. The configuration\n\
    syntax is MatPLC's (docs/runtime.md). Ctrl-C, `q` in the vitrine or `petriplc stop`\n\
    stop the PLC cleanly (exit code 0). Before starting, every address a module listens on\n\
    and the PLC id are checked: what is taken is reported at once, each with its fix\n\
    (exit code 3).\n\n",
    exit_codes!()))]
pub struct RunArgs {
    /// The configuration file.
    pub config: PathBuf,
    /// Names this PLC's shared memory, so several run side by side [default: `plc_id` in
    /// the configuration's [PLC], else `petriplc`].
    #[arg(long, value_name = "ID")]
    pub plc_id: Option<String>,
    /// Stop after this long (`30s`, `T#1m`).
    #[arg(long = "for", value_name = "DURATION", value_parser = parse_time)]
    pub duration: Option<Duration>,
    /// Also write the log to this file.
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// The least important messages shown.
    #[arg(long, default_value = "info", value_parser = ["error", "warn", "info", "debug", "trace"])]
    pub log_level: String,
    /// Where log lines go: `auto` (the systemd journal when systemd connected standard error
    /// to it, else the terminal), `terminal`, `journal`, `syslog` (the local syslog socket),
    /// `syslog:PATH` (a syslog Unix socket), `syslog:HOST:PORT` (syslog over UDP).
    #[arg(long, value_name = "WHERE", default_value = "auto", value_parser = crate::logging::parse_log_to)]
    pub log_to: crate::logging::LogTo,
    /// Overrides a setting of a module's section, e.g. `--set hmi:listen=127.0.0.1:8081`,
    /// or one of its table rows, the row of that table with the same first cell: `--set
    /// 'io:device table tcp:127.0.0.1:5022 1 5ms 500ms'` (repeatable).
    #[arg(
        long = "set",
        value_name = "MODULE:SETTING=VALUE | MODULE:TABLE KEY CELL…"
    )]
    pub overrides: Vec<petriplc_config::Override>,
}

#[derive(Debug, Args)]
pub struct PlcIdArgs {
    /// Which PLC: the id `petriplc run` was given (`--plc-id`, or `plc_id` in [PLC])
    /// [default: petriplc]
    #[arg(value_name = "ID", conflicts_with = "plc_id")]
    id: Option<String>,
    /// The same, as an option (as `petriplc run` takes it)
    #[arg(long, value_name = "ID")]
    plc_id: Option<String>,
}

impl PlcIdArgs {
    /// The PLC id, however it was given.
    pub fn id(&self) -> &str {
        self.id
            .as_deref()
            .or(self.plc_id.as_deref())
            .unwrap_or(DEFAULT_PLC_ID)
    }
}

fn parse_time(s: &str) -> Result<Duration, String> {
    petriplc_net::time::parse_duration(s).map_err(|e| e.to_string())
}

fn parse_setting(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.trim().to_string())),
        _ => Err(format!("`{s}` is not NAME=VALUE (e.g. `K_alpha=45`)")),
    }
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
