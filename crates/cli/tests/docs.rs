//! Every documented command, run as written: each ```sh block of README.md, CONTRIBUTING.md,
//! docs/*.md, examples/*/README.md and the crate groups' READMEs, and every example of every
//! subcommand's `--help`, from the repository root with `petriplc` on the PATH meaning the
//! binary under test. Documents added later are picked up by these globs; the convention
//! (CONTRIBUTING.md, "Documented commands are tests"):
//!
//! - a ```sh block is run, line by line (`\` continues a line); any other language (```text
//!   for synopses and output samples) is not run, and every fence must name its language;
//! - `cargo run --release -p petriplc --` stands for `petriplc`;
//! - every command must exit 0; a command containing `petriplc run` may instead still be
//!   running once its PLC is up: it then goes on while the rest of its document runs (as if
//!   in another terminal), and is stopped with SIGINT at the end of the document, after
//!   which it must exit 0;
//! - a configuration is fenced ```conf: a complete one is written under `out/docs-conf/` and
//!   started for 2 s (exit 0); ```conf excerpt=FILE shows lines of an example file, which
//!   must be that file's lines in order, and the file is started instead; ```conf refused
//!   is a configuration petriplc refuses (docs/diagnostics.md's examples, each checked to
//!   get its code by crates/plc/config's `codes` test), not started; any other block
//!   holding a `[SECTION]` line fails;
//! - a document may write only under `out/` (git-ignored): new untracked files elsewhere fail;
//! - a document listed in [`RUN_ELSEWHERE`] has its fences checked here but its commands run
//!   by a test of its own, which checks what they print (and runs every block: it says so).
//!
//! The `--help` examples of all subcommands form one document, in the order `petriplc --help`
//! lists the subcommands, so `status` and `stop` examples find the PLC the `run` examples
//! started.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use nix::sys::signal::{killpg, Signal};
use nix::unistd::Pid;

/// How long a finite command may take (a hung one fails instead of hanging the suite).
const FINITE: Duration = Duration::from_secs(180);
/// How long a `petriplc run` may take to come up.
const START: Duration = Duration::from_secs(30);
/// How long a PLC may take to stop after SIGINT.
const STOP: Duration = Duration::from_secs(20);

/// Documents whose ```sh blocks a test of their own runs, checking their output, and the
/// test: running them here too would only repeat the same long commands.
const RUN_ELSEWHERE: &[(&str, &str)] = &[
    (
        "examples/turntable/README.md",
        "crates/cli/tests/turntable.rs",
    ),
    (
        "examples/two-cells/README.md",
        "crates/cli/tests/two_cells.rs",
    ),
];

/// The tests of this file share ports 5020 and 8080 and the default PLC id: one at a time.
static SERIAL: Mutex<()> = Mutex::new(());

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// One logical command of a document and where it is.
#[derive(Clone, Debug)]
struct Cmd {
    at: String,
    text: String,
}

/// A fenced block: the line of its opening fence, its info string (`sh`, `conf
/// excerpt=FILE`), and its lines with their indexes.
struct Fence<'a> {
    line: usize,
    info: &'a str,
    body: Vec<(usize, &'a str)>,
}

/// A document's fenced blocks.
fn fences(text: &str) -> Vec<Fence<'_>> {
    let mut out = Vec::new();
    let mut lines = text.lines().enumerate();
    while let Some((i, line)) = lines.next() {
        let trimmed = line.trim_start();
        let Some(info) = trimmed.strip_prefix("```") else {
            continue;
        };
        let indent = line.len() - trimmed.len();
        let mut body = Vec::new();
        for (j, l) in lines.by_ref() {
            if l.trim_start().starts_with("```") {
                break;
            }
            body.push((j, l.get(indent..).unwrap_or(l.trim_start())));
        }
        out.push(Fence {
            line: i + 1,
            info: info.trim(),
            body,
        });
    }
    out
}

/// A line that opens a section of a configuration: `[NAME]`, perhaps with a comment.
fn section_header(line: &str) -> bool {
    let l = line.split(" #").next().unwrap_or("").trim();
    l.len() > 2
        && l.starts_with('[')
        && l.ends_with(']')
        && l[1..l.len() - 1]
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// A document's fenced blocks: the commands of its ```sh blocks, and problems with fences.
fn sh_commands(file: &str, text: &str) -> (Vec<Cmd>, Vec<String>) {
    let mut commands = Vec::new();
    let mut problems = Vec::new();
    for f in fences(text) {
        let lang = f.info.split_whitespace().next().unwrap_or("");
        if lang.is_empty() {
            problems.push(format!(
                "{file}:{}: a fenced block without a language: write ```sh for commands the \
                 docs test runs, ```text (or the format's name) for anything else",
                f.line
            ));
        }
        if lang == "sh" {
            commands.extend(logical_lines(file, &f.body));
        }
        if lang != "conf" && f.body.iter().any(|(_, l)| section_header(l)) {
            problems.push(format!(
                "{file}:{}: this block holds a configuration (a `[SECTION]` line): fence it \
                 ```conf, a complete configuration the docs test starts, or ```conf \
                 excerpt=examples/NAME/FILE.conf, lines of that file, which the docs test \
                 starts instead",
                f.line
            ));
        }
    }
    (commands, problems)
}

/// A configuration shown in a document: whole (`excerpt: None`), or lines of an example
/// file.
#[derive(Clone, Debug)]
struct Conf {
    at: String,
    text: String,
    excerpt: Option<String>,
}

/// The ```conf blocks of a document.
fn conf_blocks(file: &str, text: &str) -> Vec<Conf> {
    fences(text)
        .into_iter()
        .filter(|f| {
            let mut words = f.info.split_whitespace();
            words.next() == Some("conf") && !words.any(|w| w == "refused")
        })
        .map(|f| Conf {
            at: format!("{file}:{}", f.line),
            text: f.body.iter().map(|(_, l)| format!("{l}\n")).collect(),
            excerpt: f
                .info
                .split_whitespace()
                .find_map(|w| w.strip_prefix("excerpt="))
                .map(str::to_string),
        })
        .collect()
}

/// A configuration line as compared with an example file: its comment dropped (a `#` after
/// a space), its spaces collapsed; `None` for a blank or comment line.
fn conf_line(line: &str) -> Option<String> {
    let code = match line.find(" #") {
        Some(i) => &line[..i],
        None => line,
    };
    let code = code.split_whitespace().collect::<Vec<_>>().join(" ");
    (!code.is_empty() && !code.starts_with('#')).then_some(code)
}

/// What is wrong with an excerpt: a line that is not in its file, in order.
fn excerpt_problems(conf: &Conf, file: &str, file_text: &str) -> Vec<String> {
    let mut lines = file_text.lines().filter_map(conf_line);
    let mut problems = Vec::new();
    for want in conf.text.lines().filter_map(conf_line) {
        if !lines.any(|l| l == want) {
            problems.push(format!(
                "{}: `{want}` is not in {file} (or not in this order): the excerpt must show \
                 that file's lines as they are",
                conf.at
            ));
            break;
        }
    }
    problems
}

/// Checks and starts every configuration of a document: a whole one is written under
/// `out/docs-conf/` and started; an excerpt is matched against its file, which is started.
/// Each must run for two seconds and stop with exit code 0.
fn run_confs(doc: &str, confs: &[Conf]) -> Vec<String> {
    let mut failures = Vec::new();
    let mut commands: Vec<Cmd> = Vec::new();
    let dir = root().join("out/docs-conf");
    fs::create_dir_all(&dir).unwrap();
    for (k, conf) in confs.iter().enumerate() {
        let id = format!("docs-conf-{k}");
        let file = match &conf.excerpt {
            Some(file) => {
                let Ok(text) = fs::read_to_string(root().join(file)) else {
                    failures.push(format!("{}: excerpt={file}: no such file", conf.at));
                    continue;
                };
                failures.extend(excerpt_problems(conf, file, &text));
                if commands
                    .iter()
                    .any(|c| c.text.contains(&format!(" {file} ")))
                {
                    continue;
                }
                file.clone()
            }
            None => {
                let name = format!("{}-{k}.conf", doc.replace(['/', '.'], "-"));
                fs::write(dir.join(&name), &conf.text).unwrap();
                format!("out/docs-conf/{name}")
            }
        };
        commands.push(Cmd {
            at: conf.at.clone(),
            text: format!("petriplc run {file} --for 2s --plc-id {id} --log-to terminal"),
        });
    }
    let bin = bin_dir();
    for cmd in &commands {
        let mut job = Job::start(cmd, bin.path());
        match job.wait(FINITE, || false) {
            Some(s) if s.success() => {}
            Some(s) => failures.push(job.report(&format!(
                "failed ({s}): a ```conf block must run as written"
            ))),
            None => {
                job.signal(Signal::SIGKILL);
                let _ = job.child.wait();
                failures.push(job.report(&format!("did not finish within {FINITE:?}")));
            }
        }
    }
    failures
}

/// Joins `\`-continued lines; drops blank and comment lines.
fn logical_lines(file: &str, body: &[(usize, &str)]) -> Vec<Cmd> {
    let mut out = Vec::new();
    let mut current: Option<Cmd> = None;
    for &(i, l) in body {
        let (part, continued) = match l.trim_end().strip_suffix('\\') {
            Some(p) => (p, true),
            None => (l.trim_end(), false),
        };
        let cmd = current.get_or_insert_with(|| Cmd {
            at: format!("{file}:{}", i + 1),
            text: String::new(),
        });
        cmd.text.push_str(part.trim());
        if continued {
            cmd.text.push(' ');
            continue;
        }
        let done = current.take().unwrap();
        let t = done.text.trim();
        if !t.is_empty() && !t.starts_with('#') {
            out.push(Cmd {
                at: done.at,
                text: t.replace("cargo run --release -p petriplc --", "petriplc"),
            });
        }
    }
    out.extend(current.filter(|c| !c.text.trim().is_empty()));
    out
}

/// A directory with `petriplc` in it: the binary under test.
fn bin_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_petriplc"), dir.path().join("petriplc"))
        .unwrap();
    dir
}

/// A command that would run the test suite or the benchmarks inside this test.
fn recursive(text: &str) -> bool {
    ["scripts/test-all.sh", "cargo test", "cargo bench", "bench/"]
        .iter()
        .any(|p| text.contains(p))
}

/// A command running, its output going to files.
struct Job {
    cmd: Cmd,
    child: Child,
    out: tempfile::NamedTempFile,
    err: tempfile::NamedTempFile,
}

impl Job {
    fn start(cmd: &Cmd, bin: &Path) -> Job {
        use std::os::unix::process::CommandExt;
        let text = &cmd.text;
        let out = tempfile::NamedTempFile::new().unwrap();
        let err = tempfile::NamedTempFile::new().unwrap();
        let path = format!(
            "{}:{}",
            bin.display(),
            std::env::var("PATH").unwrap_or_default()
        );
        let child = Command::new("bash")
            .args(["-c", text])
            .current_dir(root())
            .env("PATH", path)
            .stdin(Stdio::null())
            .stdout(out.reopen().unwrap())
            .stderr(err.reopen().unwrap())
            .process_group(0)
            .spawn()
            .unwrap();
        Job {
            cmd: cmd.clone(),
            child,
            out,
            err,
        }
    }

    /// Waits until the job exits or `limit` has passed (`None`: still running).
    fn wait(&mut self, limit: Duration, ready: impl Fn() -> bool) -> Option<ExitStatus> {
        let started = Instant::now();
        loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                return Some(s);
            }
            if started.elapsed() >= limit || ready() {
                return None;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn signal(&self, s: Signal) {
        let _ = killpg(Pid::from_raw(self.child.id() as i32), s);
    }

    fn report(&self, what: &str) -> String {
        format!(
            "{}: `{}` {what}\n--- stdout\n{}--- stderr\n{}",
            self.cmd.at,
            self.cmd.text,
            tail(self.out.path()),
            tail(self.err.path())
        )
    }
}

/// The last lines of a file, enough to see why a command failed.
fn tail(path: &Path) -> String {
    let text = fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    let from = lines.len().saturating_sub(40);
    lines[from..].iter().map(|l| format!("{l}\n")).collect()
}

/// The PLC id a `petriplc run` command uses.
fn plc_id(text: &str) -> String {
    let words: Vec<&str> = text.split_whitespace().collect();
    words
        .iter()
        .position(|w| *w == "--plc-id")
        .and_then(|i| words.get(i + 1))
        .map_or_else(|| "petriplc".to_string(), |s| s.to_string())
}

/// Untracked files outside git-ignored folders (`None` without git).
fn untracked() -> Option<Vec<String>> {
    let out = Command::new("git")
        .args(["status", "--porcelain=v1", "--untracked-files=all"])
        .current_dir(root())
        .output()
        .ok()?;
    out.status.success().then(|| {
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter(|l| l.starts_with("??"))
            .map(str::to_string)
            .collect()
    })
}

/// Runs a document's commands; returns what went wrong.
fn run_document(name: &str, commands: &[Cmd]) -> Vec<String> {
    let bin = bin_dir();
    let before = untracked();
    let mut failures = Vec::new();
    let mut servers: Vec<Job> = Vec::new();
    for cmd in commands {
        if recursive(&cmd.text) {
            failures.push(format!(
                "{}: `{}` would run the test suite or the benchmarks inside the docs test: \
                 put it in a ```text block",
                cmd.at, cmd.text
            ));
            continue;
        }
        let mut job = Job::start(cmd, bin.path());
        if cmd.text.contains("petriplc run") {
            let status = petriplc_runtime::status::path(&plc_id(&cmd.text));
            match job.wait(START, || status.exists()) {
                Some(s) if s.success() => {}
                Some(s) => failures.push(job.report(&format!("failed ({s})"))),
                None if status.exists() => {
                    // Give the PLC's servers the moment between publishing its status and
                    // accepting connections.
                    std::thread::sleep(Duration::from_millis(300));
                    servers.push(job);
                }
                None => {
                    job.signal(Signal::SIGKILL);
                    let _ = job.child.wait();
                    failures.push(job.report(&format!(
                        "did not bring PLC `{}` up within {START:?}",
                        plc_id(&cmd.text)
                    )));
                }
            }
        } else {
            match job.wait(FINITE, || false) {
                Some(s) if s.success() => {}
                Some(s) => failures.push(job.report(&format!("failed ({s})"))),
                None => {
                    job.signal(Signal::SIGKILL);
                    let _ = job.child.wait();
                    failures.push(job.report(&format!("did not finish within {FINITE:?}")));
                }
            }
        }
    }
    for mut job in servers {
        job.signal(Signal::SIGINT);
        match job.wait(STOP, || false) {
            Some(s) if s.success() => {}
            Some(s) => failures.push(job.report(&format!("exited with {s} after SIGINT"))),
            None => {
                job.signal(Signal::SIGKILL);
                let _ = job.child.wait();
                failures.push(job.report(&format!("did not stop within {STOP:?} of SIGINT")));
            }
        }
    }
    if let (Some(before), Some(after)) = (before, untracked()) {
        for f in after.iter().filter(|f| !before.contains(f)) {
            failures.push(format!(
                "{name}: its commands wrote `{}` outside out/: write files under out/",
                &f[3..]
            ));
        }
    }
    failures
}

/// README.md, CONTRIBUTING.md, docs/*.md, examples/*/README.md and the crate groups'
/// crates/README.md and crates/*/README.md, relative to the root, sorted.
fn documents() -> Vec<String> {
    let root = root();
    let mut docs = vec!["README.md".to_string(), "CONTRIBUTING.md".to_string()];
    let mut more = vec!["crates/README.md".to_string()];
    for entry in fs::read_dir(root.join("crates")).unwrap() {
        let p = entry.unwrap().path().join("README.md");
        if p.is_file() {
            let dir = p.parent().unwrap().file_name().unwrap().to_string_lossy();
            more.push(format!("crates/{dir}/README.md"));
        }
    }
    for entry in fs::read_dir(root.join("docs")).unwrap() {
        let p = entry.unwrap().path();
        if p.extension().is_some_and(|e| e == "md") {
            more.push(format!("docs/{}", p.file_name().unwrap().to_string_lossy()));
        }
    }
    for entry in fs::read_dir(root.join("examples")).unwrap() {
        let p = entry.unwrap().path().join("README.md");
        if p.is_file() {
            let dir = p.parent().unwrap().file_name().unwrap().to_string_lossy();
            more.push(format!("examples/{dir}/README.md"));
        }
    }
    more.sort();
    docs.extend(more);
    docs
}

/// What [`RUN_ELSEWHERE`] names exists: a document renamed away is not silently unrun.
#[test]
fn documents_run_elsewhere_exist_with_their_tests() {
    for (doc, test) in RUN_ELSEWHERE {
        assert!(root().join(doc).is_file(), "{doc}");
        let test_text = fs::read_to_string(root().join(test)).unwrap();
        assert!(test_text.contains(doc), "{test} does not run {doc}");
    }
}

#[test]
fn every_documented_command_runs_as_written() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let mut failures = Vec::new();
    let mut ran = 0;
    let mut configurations = 0;
    for doc in documents() {
        let text = fs::read_to_string(root().join(&doc)).unwrap();
        let (commands, problems) = sh_commands(&doc, &text);
        failures.extend(problems);
        let confs = conf_blocks(&doc, &text);
        configurations += confs.len();
        failures.extend(run_confs(&doc, &confs));
        if RUN_ELSEWHERE.iter().any(|(d, _)| *d == doc) {
            continue;
        }
        ran += commands.len();
        failures.extend(run_document(&doc, &commands));
    }
    assert!(ran >= 10, "only {ran} documented commands found");
    assert!(
        configurations >= 5,
        "only {configurations} documented configurations found"
    );
    assert!(failures.is_empty(), "\n{}", failures.join("\n\n"));
}

/// `petriplc --help`'s subcommands, in its order.
fn subcommands() -> Vec<String> {
    let help = petriplc(&["--help"]);
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

fn petriplc(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_petriplc"))
        .args(args)
        .output()
        .unwrap();
    assert!(out.status.success(), "petriplc {args:?}: {out:?}");
    String::from_utf8(out.stdout).unwrap()
}

/// The commands under `Examples:` in a help text: lines starting with `  petriplc ` or other
/// commands, `\` continuing them, up to the first blank line.
fn help_examples(sub: &str, help: &str) -> Vec<Cmd> {
    let body: Vec<(usize, &str)> = help
        .lines()
        .enumerate()
        .skip_while(|(_, l)| l.trim() != "Examples:")
        .skip(1)
        .take_while(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| (i, l.trim()))
        .collect();
    logical_lines(&format!("petriplc {sub} --help, line"), &body)
}

#[test]
fn every_help_example_runs_as_written_and_every_help_ends_with_the_exit_codes() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let mut failures = Vec::new();
    let mut commands = Vec::new();
    let subs = subcommands();
    assert!(subs.len() >= 6, "subcommands: {subs:?}");
    for sub in &subs {
        let help = petriplc(&[sub, "--help"]);
        let examples = help_examples(sub, &help);
        if examples.is_empty() {
            failures.push(format!("petriplc {sub} --help has no `Examples:`"));
        }
        for e in &examples {
            if !e.text.starts_with("petriplc ") {
                failures.push(format!(
                    "{}: `{}`: an example starts with `petriplc` (a line wrapped by the \
                     terminal's width? keep example lines under 80 columns, `\\` continuing)",
                    e.at, e.text
                ));
            }
        }
        commands.extend(examples);
        let tail: String = help
            .lines()
            .skip_while(|l| !l.starts_with("Exit codes"))
            .collect::<Vec<_>>()
            .join("\n");
        for code in ["0 ", "1 ", "2 ", "3 ", "4 ", "5 ", "130 "] {
            if !tail.lines().any(|l| l.trim_start().starts_with(code)) {
                failures.push(format!(
                    "petriplc {sub} --help: the exit code table at its end lacks code {code}"
                ));
            }
        }
    }
    failures.extend(run_document("the --help examples", &commands));
    assert!(failures.is_empty(), "\n{}", failures.join("\n\n"));
}

#[cfg(test)]
mod parsing {
    use super::*;

    fn check(doc: &str, expect: &[&str], expect_problems: usize) {
        let (cmds, problems) = sh_commands("d.md", doc);
        let got: Vec<String> = cmds
            .iter()
            .map(|c| format!("{} {}", c.at, c.text))
            .collect();
        assert_eq!(got, expect);
        assert_eq!(problems.len(), expect_problems, "{problems:?}");
    }

    #[test]
    fn sh_blocks_give_their_logical_lines_and_other_blocks_nothing() {
        check(
            "text\n```sh\n# comment\npetriplc a \\\n  --b c\n\nls   # note\n```\n```text\nno\n```\n",
            &["d.md:4 petriplc a --b c", "d.md:7 ls   # note"],
            0,
        );
        check(
            "- item\n  ```sh\n  echo hi\n  ```\n",
            &["d.md:3 echo hi"],
            0,
        );
        check("```\nanything\n```\n", &[], 1);
        // A configuration must say what it is.
        check("```text\n[PLC]\nmodule a b\n```\n", &[], 1);
        check(
            "```conf\n[PLC] # top\n```\n```text\nARRAY[1..2] OF INT\n```\n",
            &[],
            0,
        );
    }

    #[test]
    fn conf_blocks_are_whole_or_excerpts_matched_line_by_line() {
        let confs = conf_blocks(
            "d.md",
            "```conf\n[PLC]\n```\n\n```conf excerpt=examples/x/plc.conf\n[io]   # the io\nport = 5\n```\n",
        );
        assert_eq!(confs.len(), 2);
        assert_eq!(
            (confs[0].at.as_str(), confs[0].excerpt.as_deref()),
            ("d.md:1", None)
        );
        assert_eq!(confs[1].excerpt.as_deref(), Some("examples/x/plc.conf"));
        let file = "# head\n[PLC]\nmodule io x\n[io]\nport  =  5   # five\nretain_write = T#5ms\n";
        assert!(excerpt_problems(&confs[1], "f", file).is_empty());
        let swapped = "[PLC]\nport = 5\n[io]\n";
        assert_eq!(excerpt_problems(&confs[1], "f", swapped).len(), 1);
        assert_eq!(
            conf_line("retain_write = T#5ms"),
            Some("retain_write = T#5ms".into())
        );
    }
}
