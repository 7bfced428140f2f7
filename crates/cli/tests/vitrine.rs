//! The vitrine through the real `petriplc` binary in a real terminal: tmux runs `petriplc
//! run` in a detached session of fixed size; the test reads the screen (capture-pane),
//! types keys (send-keys), checks a key's force on screen and in the PLC (`petriplc
//! status`), stops with Ctrl-C and checks the terminal was given back. Without a terminal
//! the display is off and the PLC runs as usual.
//!
//! tmux (the Debian package) is installed by scripts/test-all.sh; `PETRIPLC_TMUX` names
//! another binary.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use tempfile::TempDir;

const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples");

fn tmux_bin() -> PathBuf {
    let path = std::env::var_os("PETRIPLC_TMUX")
        .map_or_else(|| PathBuf::from("/usr/bin/tmux"), PathBuf::from);
    assert!(
        path.exists(),
        "{} not found: scripts/test-all.sh installs tmux (apt-get install tmux), or set \
         PETRIPLC_TMUX",
        path.display()
    );
    path
}

fn petriplc() -> PathBuf {
    assert_cmd::cargo::cargo_bin("petriplc")
}

/// A tmux server of its own (socket `-L NAME`), killed when dropped, even when a check
/// failed.
struct Tmux {
    bin: PathBuf,
    socket: String,
}

impl Tmux {
    /// Starts `command` (a shell command line) in a detached `width` × `height` session.
    fn start(name: &str, width: u16, height: u16, command: &str) -> Tmux {
        let t = Tmux {
            bin: tmux_bin(),
            socket: format!("petriplc-{name}-{}", std::process::id()),
        };
        // No user configuration: the session must be the same everywhere.
        let out = t.run(&[
            "-f",
            "/dev/null",
            "new-session",
            "-d",
            "-x",
            &width.to_string(),
            "-y",
            &height.to_string(),
            command,
        ]);
        assert!(
            out.status.success(),
            "tmux: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        t
    }

    fn run(&self, args: &[&str]) -> Output {
        Command::new(&self.bin)
            .args(["-L", &self.socket])
            .args(args)
            .output()
            .expect("tmux runs")
    }

    fn screen(&self) -> String {
        String::from_utf8_lossy(&self.run(&["capture-pane", "-p"]).stdout).into_owned()
    }

    fn keys(&self, keys: &[&str]) {
        let mut args = vec!["send-keys"];
        args.extend_from_slice(keys);
        assert!(self.run(&args).status.success());
    }

    /// Whether the pane shows the alternate screen (a full-screen program holds it).
    fn alternate_on(&self) -> bool {
        let out = self.run(&["display-message", "-p", "#{alternate_on}"]);
        String::from_utf8_lossy(&out.stdout).trim() == "1"
    }

    /// Polls the screen until `ok` holds (at most 20 s); returns it.
    fn wait_for(&self, what: &str, ok: impl Fn(&str) -> bool) -> String {
        let start = Instant::now();
        loop {
            let screen = self.screen();
            if ok(&screen) {
                return screen;
            }
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "waited 20 s for {what}; the screen:\n{screen}"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        let _ = self.run(&["kill-server"]);
    }
}

/// The points table's row of `point`.
fn row<'a>(screen: &'a str, point: &str) -> Option<&'a str> {
    screen
        .lines()
        .find(|l| l.starts_with(&format!("│{point} ")))
}

/// The mixer without its operator's presses: `operator` owns B1 but leaves it off and
/// blinks BLINK, so the vitrine's `b` key must force B1 to start a cycle.
fn mixer_dir() -> TempDir {
    let dir = TempDir::new().unwrap();
    std::fs::copy(
        format!("{EXAMPLES}/mixer/mixer.pnml"),
        dir.path().join("mixer.pnml"),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("operator.csv"),
        "time,B1,BLINK\n0,0,0\n0.3,,1\n0.6,,0\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("plc.conf"),
        "\
[PLC]
module operator    timeline
module tank        plant
module controller  petrinet
module vitrine     vitrine
synch tank       -> controller
synch controller -> tank
synch_start tank
point B1    \"start button (key b)\"  operator
point BLINK \"blinks\"                operator
point N1    \"level sensor: empty\"   tank
point N2    \"level sensor: half\"    tank
point N3    \"level sensor: full\"    tank
point L1    \"lamp: ready\"           controller
point L2    \"lamp: filling\"         controller
point L3    \"lamp: draining\"        controller
point V1    \"valve: solvent\"        controller
point V2    \"valve: solute\"         controller
point V3    \"valve: drain\"          controller
point A1    \"heater\"                controller
point M1    \"mixer motor\"           controller
[operator]
file = operator.csv
repeat = yes
scan_period = T#10ms
[tank]
plant = tank
speed = 5
scan_period = T#10ms
[controller]
net = mixer.pnml
names = sipn
scan_period = T#10ms
[vitrine]
key b B1 toggle
graph BLINK
",
    )
    .unwrap();
    dir
}

fn status(plc_id: &str) -> String {
    let out = Command::new(petriplc())
        .args(["status", "--plc-id", plc_id])
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// How often transition `t` fired, from the controller's status line.
fn fired(report: &str, t: &str) -> Option<u64> {
    let line = report.lines().find(|l| l.contains("fired "))?;
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(&format!("{t}:")))
        .and_then(|n| n.parse().ok())
}

fn shell_quote(p: &Path) -> String {
    format!("'{}'", p.display().to_string().replace('\'', r"'\''"))
}

#[test]
fn keys_force_points_on_screen_and_in_the_plc_and_ctrl_c_gives_the_terminal_back() {
    let dir = mixer_dir();
    let plc_id = format!("test-vitrine-{}", std::process::id());
    // After the PLC: its exit code, and whether the terminal is back in cooked mode.
    let command = format!(
        "cd {dir} && {bin} run plc.conf --plc-id {plc_id}; echo \"EXIT=$?\"; \
         stty -a | grep -q ' icanon' && echo COOKED; echo CHECKED; sleep 600",
        dir = shell_quote(dir.path()),
        bin = shell_quote(&petriplc()),
    );
    let tmux = Tmux::start("vitrine", 120, 40, &command);

    let screen = tmux.wait_for("the display", |s| {
        s.contains("petriplc vitrine") && row(s, "B1").is_some() && s.contains("controller")
    });
    assert!(tmux.alternate_on(), "{screen}");
    assert!(screen.contains("b B1 toggle"), "{screen}");
    assert!(screen.contains("q/Ctrl-C stop the PLC"), "{screen}");
    assert!(row(&screen, "B1").unwrap().contains("off"), "{screen}");
    // Values change on screen: BLINK goes on and off every 0.3 s.
    tmux.wait_for("BLINK on", |s| {
        row(s, "BLINK").is_some_and(|r| r.contains(" ON "))
    });
    tmux.wait_for("BLINK off", |s| {
        row(s, "BLINK").is_some_and(|r| r.contains(" off "))
    });
    // The statistics and the controller's marking come from the PLC's status.
    let screen = tmux.wait_for("module statistics", |s| {
        s.contains("running") && s.contains("●L1")
    });
    assert!(screen.contains("○L2"), "{screen}");
    assert_eq!(fired(&status(&plc_id), "B1"), Some(0));

    // `b` forces B1 (the operator owns it) on: the controller starts filling.
    tmux.keys(&["b"]);
    let screen = tmux.wait_for("B1 forced on", |s| {
        row(s, "B1").is_some_and(|r| r.contains("ON F"))
    });
    assert!(screen.contains("B1 forced ON"), "{screen}");
    let start = Instant::now();
    while fired(&status(&plc_id), "B1").unwrap_or(0) == 0 {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "the controller never saw B1: {}",
            status(&plc_id)
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    tmux.wait_for("the marking to move on", |s| s.contains("○L1"));
    assert!(status(&plc_id).contains("1 point forced"));

    // Delete releases the force; the log line shows in the footer.
    tmux.keys(&["DC"]);
    tmux.wait_for("B1 released", |s| {
        row(s, "B1").is_some_and(|r| r.contains("off") && !r.contains(" F "))
    });
    // (The row may change before the footer: wait for the line itself.)
    tmux.wait_for("the log line in the footer", |s| {
        s.contains("released 1 force")
    });

    // Ctrl-C stops the PLC (raw mode: no SIGINT, the vitrine reads it as a key). The shell
    // prints the exit code, then checks the terminal's mode: wait for the end of both.
    tmux.keys(&["C-c"]);
    let screen = tmux.wait_for("the PLC to stop", |s| s.contains("CHECKED"));
    assert!(screen.contains("EXIT=0"), "{screen}");
    assert!(screen.contains("COOKED"), "raw mode left on:\n{screen}");
    assert!(!tmux.alternate_on(), "{screen}");
    // What was logged while the display was up is printed once it is gone.
    assert!(screen.contains("vitrine: stop key pressed"), "{screen}");
    assert!(
        screen.contains("vitrine      vitrine       stopped"),
        "{screen}"
    );
    assert!(status(&plc_id).is_empty(), "the PLC is gone");
}

#[test]
fn an_80x24_terminal_shows_every_panel_and_the_whole_hmi_token() {
    let dir = mixer_dir();
    // With the web HMI, whose forcing token the operator copies from the log pane.
    let conf = dir.path().join("plc.conf");
    let text = std::fs::read_to_string(&conf).unwrap();
    std::fs::write(
        &conf,
        format!("{text}[PLC]\nmodule hmi hmi\n[hmi]\nlisten = 127.0.0.1:0\n"),
    )
    .unwrap();
    let plc_id = format!("test-vitrine-small-{}", std::process::id());
    let command = format!(
        "cd {dir} && {bin} run plc.conf --plc-id {plc_id} --log plc.log; echo \"EXIT=$?\"; \
         sleep 600",
        dir = shell_quote(dir.path()),
        bin = shell_quote(&petriplc()),
    );
    let tmux = Tmux::start("vitrine-small", 80, 24, &command);
    let screen = tmux.wait_for("every panel", |s| {
        [
            " points ",
            " modules ",
            " nets ",
            " graphs ",
            " log ",
            "●L1",
            "running",
        ]
        .iter()
        .all(|p| s.contains(p))
    });
    assert!(row(&screen, "B1").is_some(), "{screen}");
    let log = std::fs::read_to_string(dir.path().join("plc.log")).unwrap();
    let token = log
        .lines()
        .find_map(|l| l.split("forcing token ").nth(1))
        .unwrap_or_else(|| panic!("no token in the log:\n{log}"));
    tmux.wait_for("the whole token in the log pane", |s| s.contains(token));
    tmux.keys(&["q"]);
    let screen = tmux.wait_for("the PLC to stop", |s| s.contains("EXIT="));
    assert!(screen.contains("EXIT=0"), "{screen}");
}

#[test]
fn without_a_terminal_the_display_is_off_and_the_plc_runs() {
    let dir = mixer_dir();
    let out = Command::new(petriplc())
        .current_dir(dir.path())
        .args(["run", "plc.conf", "--for", "1s"])
        .args([
            "--plc-id",
            &format!("test-vitrine-pipe-{}", std::process::id()),
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("vitrine: standard output is not a terminal; the display is off"),
        "{stderr}"
    );
    // Nothing was drawn: no escape sequences on standard output.
    assert!(
        !out.stdout.contains(&0x1b),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(
        stderr.contains("vitrine      vitrine       stopped"),
        "{stderr}"
    );
}
