//! Taking the terminal and always giving it back: raw mode, the alternate screen and a
//! hidden cursor while a vitrine draws; restored by [`Screen`]'s `Drop` (close, failures,
//! unwinding) and by a panic hook before a panic's message prints.

use std::io::{IsTerminal, Stdout};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, Once, PoisonError};
use std::thread::ThreadId;

use petriplc_config::PlcConfig;
use ratatui::backend::CrosstermBackend;
use ratatui::crossterm::{cursor, execute, terminal};
use ratatui::Terminal;

use crate::logring;

/// Whether a vitrine holds the terminal now (there is one terminal: one vitrine draws).
static HELD: AtomicBool = AtomicBool::new(false);

/// The thread that scans the vitrine holding the terminal: its panics restore the terminal;
/// other threads' panics go to the log while the display stays up.
static OWNER: Mutex<Option<ThreadId>> = Mutex::new(None);

static HOOK: Once = Once::new();

/// Whether `petriplc run` will have a vitrine draw on the terminal: the configuration has a
/// `vitrine` module and standard output is a terminal. Log lines must then go to
/// [`crate::log_writer`], not to the terminal.
pub fn takes_terminal(config: &PlcConfig) -> bool {
    config.modules.iter().any(|m| m.kind == crate::setup::KIND) && std::io::stdout().is_terminal()
}

/// The terminal while a vitrine holds it.
pub(crate) struct Screen {
    pub terminal: Terminal<CrosstermBackend<Stdout>>,
}

/// Why the terminal could not be taken.
pub(crate) enum TakeError {
    /// Standard output is a file or pipe.
    NotTerminal,
    /// Another vitrine holds it.
    Held,
    Io(std::io::Error),
}

impl Screen {
    pub fn take() -> Result<Screen, TakeError> {
        if !std::io::stdout().is_terminal() {
            return Err(TakeError::NotTerminal);
        }
        if HELD.swap(true, Ordering::SeqCst) {
            return Err(TakeError::Held);
        }
        install_hook();
        logring::hold();
        let setup = || -> std::io::Result<Terminal<CrosstermBackend<Stdout>>> {
            terminal::enable_raw_mode()?;
            execute!(
                std::io::stdout(),
                terminal::EnterAlternateScreen,
                cursor::Hide
            )?;
            let mut t = Terminal::new(CrosstermBackend::new(std::io::stdout()))?;
            t.clear()?;
            Ok(t)
        };
        match setup() {
            Ok(terminal) => Ok(Screen { terminal }),
            Err(e) => {
                restore();
                Err(TakeError::Io(e))
            }
        }
    }

    /// Marks the calling thread as the one that draws (see [`OWNER`]).
    pub fn claim_thread(&self) {
        *OWNER.lock().unwrap_or_else(PoisonError::into_inner) = Some(std::thread::current().id());
    }
}

impl Drop for Screen {
    fn drop(&mut self) {
        restore();
    }
}

/// Gives the terminal back if a vitrine holds it, and prints what was logged meanwhile.
fn restore() {
    if !HELD.swap(false, Ordering::SeqCst) {
        return;
    }
    // Best effort: the terminal may already be gone (hang-up), and there is no one left to
    // tell.
    let _ = execute!(
        std::io::stdout(),
        terminal::LeaveAlternateScreen,
        cursor::Show
    );
    let _ = terminal::disable_raw_mode();
    *OWNER.lock().unwrap_or_else(PoisonError::into_inner) = None;
    logring::release();
}

fn install_hook() {
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let here = std::thread::current();
            let owner = *OWNER.lock().unwrap_or_else(PoisonError::into_inner);
            // A panic of another module's thread is a module failure the runner handles
            // (stop, restart, ignore): tell it in the log, which the display shows and
            // prints when it closes, rather than scribbling over the screen. The main
            // thread's and the vitrine's own end the display.
            if HELD.load(Ordering::SeqCst)
                && owner.is_some_and(|o| o != here.id())
                && here.name() != Some("main")
            {
                logring::push(format!(
                    "thread '{}' {info}",
                    here.name().unwrap_or("<unnamed>")
                ));
                return;
            }
            restore();
            previous(info);
        }));
    });
}
