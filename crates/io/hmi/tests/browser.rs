//! The HMI page in a real browser: the mixer PLC runs in-process (petriplc-plc) with the hmi
//! on a free port and a fixed token, and tests/browser/hmi.mjs (playwright-core driving
//! Debian's chromium; both installed by scripts/test-all.sh) loads the page, sees values and
//! tokens move, is refused a force without the token, then forces B1 with it.

mod common;

use std::io::Read;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::*;

const PLAYWRIGHT: &str = "playwright-core@1.65.1";

/// Where playwright-core is installed: $PETRIPLC_NODE_MODULES, else target/node/node_modules.
fn node_modules() -> PathBuf {
    let dir = std::env::var_os("PETRIPLC_NODE_MODULES").map_or_else(
        || {
            PathBuf::from(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../../target/node/node_modules"
            ))
        },
        PathBuf::from,
    );
    assert!(
        dir.join("playwright-core/package.json").is_file(),
        "playwright-core not found in {}: run scripts/test-all.sh (it runs `npm install \
         --prefix target/node {PLAYWRIGHT}`), or set PETRIPLC_NODE_MODULES",
        dir.display()
    );
    dir
}

/// Debian's chromium: $PETRIPLC_CHROMIUM, else /usr/bin/chromium.
fn chromium() -> PathBuf {
    let path = std::env::var_os("PETRIPLC_CHROMIUM")
        .map_or_else(|| PathBuf::from("/usr/bin/chromium"), PathBuf::from);
    assert!(
        path.is_file(),
        "{} not found: run scripts/test-all.sh (it runs `apt-get install chromium`), or set \
         PETRIPLC_CHROMIUM",
        path.display()
    );
    path
}

#[test]
fn the_page_shows_the_plc_live_and_forces_with_the_token() {
    let (modules, chromium) = (node_modules(), chromium());
    let script = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/browser/hmi.mjs"
    ));
    let mut run = run_mixer();
    let out = run.path().join("browser");
    std::fs::create_dir_all(&out).unwrap();
    let mut child = Command::new("node")
        .arg(&script)
        .arg(&run.url)
        .arg(TOKEN)
        .arg(&out)
        .env("PETRIPLC_NODE_MODULES", &modules)
        .env("PETRIPLC_CHROMIUM", &chromium)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run node (apt-get install nodejs): {e}"));
    // Read both pipes on threads, so that a chatty browser cannot block on a full pipe.
    let pipe = |mut r: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut s = String::new();
            let _ = r.read_to_string(&mut s);
            s
        })
    };
    let stdout = pipe(Box::new(child.stdout.take().unwrap()));
    let stderr = pipe(Box::new(child.stderr.take().unwrap()));
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break Some(s);
        }
        if start.elapsed() > Duration::from_secs(180) {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let (stdout, stderr) = (stdout.join().unwrap(), stderr.join().unwrap());
    let last = run.stop().unwrap();
    match status {
        Some(s) if s.success() => {}
        Some(s) => panic!(
            "node {} exited with {s}\n--- stdout\n{stdout}\n--- stderr\n{stderr}",
            script.display()
        ),
        None => panic!(
            "node {} took over 180 s\n--- stdout\n{stdout}\n--- stderr\n{stderr}",
            script.display()
        ),
    }
    print!("{stdout}");
    for want in [
        "connected",
        "values changed",
        "marked places moved",
        "without the token: Refused",
        "forced:",
        "released",
    ] {
        assert!(
            stdout.contains(want),
            "no `{want}` in the script's output:\n{stdout}"
        );
    }
    let png = std::fs::read(out.join("hmi.png")).expect("no screenshot");
    assert!(png.starts_with(b"\x89PNG"), "the screenshot is not a PNG");
    // To look at it: PETRIPLC_HMI_SCREENSHOT=/tmp/hmi.png cargo test -p petriplc-hmi --test browser
    if let Some(keep) = std::env::var_os("PETRIPLC_HMI_SCREENSHOT") {
        std::fs::write(&keep, &png).unwrap();
    }
    assert!(
        last.modules.iter().all(|m| m.state.as_str() != "failed"),
        "{last}"
    );
}
