//! Test support (for this crate's tests, the binary's and the benchmarks): Debian's
//! `mosquitto` broker started on a free loopback port, stopped (or killed and started again
//! on the same port) by the test. `PETRIPLC_MOSQUITTO` names another binary.

use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A mosquitto process on 127.0.0.1 with its own configuration file.
pub struct Broker {
    pub port: u16,
    dir: tempfile_dir::Dir,
    child: Option<Child>,
}

/// The broker binary: `PETRIPLC_MOSQUITTO`, else `mosquitto` on the PATH or in /usr/sbin.
pub fn mosquitto() -> PathBuf {
    if let Some(p) = std::env::var_os("PETRIPLC_MOSQUITTO") {
        return PathBuf::from(p);
    }
    for dir in std::env::var("PATH").unwrap_or_default().split(':') {
        let p = Path::new(dir).join("mosquitto");
        if p.exists() {
            return p;
        }
    }
    PathBuf::from("/usr/sbin/mosquitto")
}

fn is_root() -> bool {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("Uid:"))
                .map(|l| l.split_whitespace().nth(2) == Some("0"))
        })
        .unwrap_or(false)
}

/// A port nobody listens on right now.
pub fn free_port() -> u16 {
    let l = TcpListener::bind("127.0.0.1:0").expect("bind a free port");
    l.local_addr().unwrap().port()
}

impl Broker {
    /// Starts an anonymous broker on a free loopback port; panics with how to install
    /// mosquitto when it cannot.
    pub fn start() -> Broker {
        Broker::start_with("")
    }

    /// Starts a broker with extra lines for its listener (e.g. `password_file`, TLS files).
    pub fn start_with(extra: &str) -> Broker {
        let dir = tempfile_dir::Dir::new();
        let port = free_port();
        let mut b = Broker {
            port,
            dir,
            child: None,
        };
        // As root, mosquitto drops to user `mosquitto`, who cannot read the test's files.
        let user = if is_root() { "user root\n" } else { "" };
        let conf = format!(
            "{user}listener {port} 127.0.0.1\nset_tcp_nodelay true\n{}\npersistence false\nlog_dest stderr\n\
             log_type error\n",
            if extra.contains("password_file") {
                extra.to_string()
            } else {
                format!("allow_anonymous true\n{extra}")
            }
        );
        std::fs::write(b.dir.path().join("mosquitto.conf"), conf).unwrap();
        b.restart();
        b
    }

    pub fn addr(&self) -> SocketAddr {
        SocketAddr::from(([127, 0, 0, 1], self.port))
    }

    /// `127.0.0.1:PORT`, for `broker = ...`.
    pub fn address(&self) -> String {
        self.addr().to_string()
    }

    /// The folder of its configuration, for the files a test adds.
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// Starts the broker (again, on the same port) and waits until it accepts connections.
    pub fn restart(&mut self) {
        let bin = mosquitto();
        let child = Command::new(&bin)
            .arg("-c")
            .arg(self.dir.path().join("mosquitto.conf"))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| {
                panic!(
                    "cannot start {} ({e}): install Debian's mosquitto (scripts/test-all.sh \
                     does) or set PETRIPLC_MOSQUITTO",
                    bin.display()
                )
            });
        self.child = Some(child);
        let start = Instant::now();
        while TcpStream::connect_timeout(&self.addr(), Duration::from_millis(100)).is_err() {
            if let Some(Ok(Some(status))) = self.child.as_mut().map(|c| c.try_wait()) {
                let mut err = String::new();
                if let Some(mut e) = self.child.take().and_then(|c| c.stderr) {
                    use std::io::Read;
                    let _ = e.read_to_string(&mut err);
                }
                panic!("mosquitto exited ({status}) on port {}: {err}", self.port);
            }
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "mosquitto did not listen on {}",
                self.port
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Kills the broker at once (SIGKILL: no clean goodbye to its clients).
    pub fn kill(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

impl Drop for Broker {
    fn drop(&mut self) {
        self.kill();
    }
}

/// A temporary folder removed on drop (tempfile is only a dev-dependency).
mod tempfile_dir {
    use std::path::{Path, PathBuf};
    use std::sync::atomic::{AtomicU32, Ordering};

    pub struct Dir(PathBuf);

    impl Dir {
        pub fn new() -> Dir {
            static N: AtomicU32 = AtomicU32::new(0);
            let p = std::env::temp_dir().join(format!(
                "petriplc-mosquitto-{}-{}",
                std::process::id(),
                N.fetch_add(1, Ordering::Relaxed)
            ));
            std::fs::create_dir_all(&p).expect("create a temporary folder");
            Dir(p)
        }

        pub fn path(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for Dir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}
