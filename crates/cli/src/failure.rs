//! Failures of a command, split by whose fault they are so the exit code can say so, and the
//! one table of exit codes every command's `--help` ends with.

/// The exit codes of every command, as `--help` shows them (also in README.md).
macro_rules! exit_codes {
    () => {
        "Exit codes (the same for every command):\n  \
        0    success\n  \
        1    the check, simulation or run failed: a property violated, an unstable net,\n       \
             a module failed\n  \
        2    bad input or usage: a file, option, net or configuration is wrong (the\n       \
             message says where)\n  \
        3    could not start: a port or a PLC id already in use, a resource missing\n  \
        4    no PLC with that id (status, stop)\n  \
        5    status: that PLC is not running; it exited without stopping (stale)\n  \
        130  interrupted by Ctrl-C"
    };
}
pub(crate) use exit_codes;

/// Why a command failed.
#[derive(Debug)]
pub enum Failure {
    /// The input (a file, an option, a net) is wrong: exit code 2.
    BadInput(anyhow::Error),
    /// The input was fine but running it failed (an unstable net, a write error): exit code 1.
    Run(anyhow::Error),
    /// Could not start: the PLC id is taken, a resource is missing or refused: exit code 3.
    CannotStart(anyhow::Error),
    /// `status`, `stop`: no PLC has that id: exit code 4.
    NoSuchPlc(anyhow::Error),
    /// `status`: the PLC is not running, it exited without stopping: exit code 5.
    Stale(anyhow::Error),
    /// Interrupted by Ctrl-C: exit code 130.
    Interrupted(anyhow::Error),
}

impl Failure {
    pub fn error(&self) -> &anyhow::Error {
        match self {
            Failure::BadInput(e)
            | Failure::Run(e)
            | Failure::CannotStart(e)
            | Failure::NoSuchPlc(e)
            | Failure::Stale(e)
            | Failure::Interrupted(e) => e,
        }
    }

    pub fn exit_code(&self) -> u8 {
        match self {
            Failure::BadInput(_) => 2,
            Failure::Run(_) => 1,
            Failure::CannotStart(_) => 3,
            Failure::NoSuchPlc(_) => 4,
            Failure::Stale(_) => 5,
            Failure::Interrupted(_) => 130,
        }
    }
}

/// Marks an error as the user's input being wrong.
pub trait BadInputExt<T> {
    fn bad_input(self) -> Result<T, Failure>;
}

impl<T, E: Into<anyhow::Error>> BadInputExt<T> for Result<T, E> {
    fn bad_input(self) -> Result<T, Failure> {
        self.map_err(|e| Failure::BadInput(e.into()))
    }
}

/// Marks an error as a failure while running.
pub trait RunExt<T> {
    fn run_failure(self) -> Result<T, Failure>;
}

impl<T, E: Into<anyhow::Error>> RunExt<T> for Result<T, E> {
    fn run_failure(self) -> Result<T, Failure> {
        self.map_err(|e| Failure::Run(e.into()))
    }
}
