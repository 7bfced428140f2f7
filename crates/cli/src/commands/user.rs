//! `petriplc user add|remove`: the users of an OPC UA server's password file (`users = FILE`,
//! docs/opcua.md) on a machine without `htpasswd`. The password comes from the terminal
//! without echo (asked twice) or from the first line of standard input; the file is replaced
//! in one step (a temporary file renamed over it), so a kill never leaves half of it.

use std::fs::{self, OpenOptions};
use std::io::{self, BufRead, IsTerminal, Read, Write};
use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context};
use petriplc_opcua::Edit;

use crate::args::{UserAddArgs, UserArgs, UserCommand, UserRemoveArgs};
use crate::failure::{BadInputExt, Failure, RunExt};

/// The most bytes of standard input read for the password's line.
const MAX_LINE: u64 = 4096;

pub fn run(args: UserArgs) -> Result<(), Failure> {
    match args.command {
        UserCommand::Add(a) => add(a),
        UserCommand::Remove(a) => remove(a),
    }
}

fn add(args: UserAddArgs) -> Result<(), Failure> {
    let (path, text) = read(&args.file)?;
    let shown = args.file.display().to_string();
    // Refused before a password is asked for and thrown away.
    petriplc_opcua::may_set(&text, &shown, &args.name, args.replace).bad_input()?;
    let password = password(&args.name)?;
    let hash = petriplc_opcua::hash_password(&password, args.cost).bad_input()?;
    let (new, edit) =
        petriplc_opcua::with_user(&text, &shown, &args.name, &hash, args.replace).bad_input()?;
    write(&path, &new)?;
    eprintln!(
        "{} user `{}` {} {shown} (bcrypt, cost {}); a running PLC reads it at its next start",
        match edit {
            Edit::Added => "added",
            Edit::Replaced => "new password for",
        },
        args.name,
        match edit {
            Edit::Added => "to",
            Edit::Replaced => "in",
        },
        args.cost
    );
    Ok(())
}

fn remove(args: UserRemoveArgs) -> Result<(), Failure> {
    let (path, text) = read(&args.file)?;
    if text.is_empty() && !path.exists() {
        return Err(anyhow!("{} does not exist", args.file.display())).bad_input();
    }
    let shown = args.file.display().to_string();
    let new = petriplc_opcua::without_user(&text, &shown, &args.name).bad_input()?;
    write(&path, &new)?;
    let left = petriplc_opcua::Users::parse(&new, &shown).is_ok();
    eprintln!(
        "removed user `{}` from {shown}{}",
        args.name,
        if left {
            ""
        } else {
            "; it has no user left: an opcua_server refuses it until one is added"
        }
    );
    Ok(())
}

/// The file to write (a symbolic link's target) and its text (empty if it does not exist).
fn read(file: &Path) -> Result<(PathBuf, String), Failure> {
    match fs::metadata(file) {
        Ok(_) => {}
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return Ok((file.to_path_buf(), String::new()))
        }
        Err(e) => return Err(anyhow!("cannot read {}: {e}", file.display())).bad_input(),
    }
    let path = fs::canonicalize(file)
        .with_context(|| format!("cannot resolve {}", file.display()))
        .bad_input()?;
    let text = petriplc_opcua::read_text(&path)
        .map_err(|e| anyhow!("{e}"))
        .bad_input()?;
    Ok((path, text))
}

/// Writes `text` to a new file beside `path` and renames it over `path`: readers see the
/// old file or the new one. A new file gets mode 600, an existing one keeps its mode.
fn write(path: &Path, text: &str) -> Result<(), Failure> {
    crate::output::create_parent(path)?;
    let mode = fs::metadata(path).map_or(0o600, |m| m.permissions().mode() & 0o7777);
    let dir = match path.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(d) => d.to_path_buf(),
        None => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| -> io::Result<()> {
        let mut f = OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(mode)
            .open(&tmp)?;
        // The mode asked for is masked by the umask; the file's must be exact.
        f.set_permissions(fs::Permissions::from_mode(mode))?;
        f.write_all(text.as_bytes())?;
        f.sync_all()?;
        fs::rename(&tmp, path)?;
        // The rename itself survives a power cut once the folder is synced.
        fs::File::open(&dir)?.sync_all()
    })();
    if let Err(e) = result {
        let _ = fs::remove_file(&tmp);
        return Err(anyhow!("cannot write {}: {e}", path.display())).run_failure();
    }
    Ok(())
}

/// The password: asked twice without echo in a terminal, else the first line of standard
/// input.
fn password(name: &str) -> Result<String, Failure> {
    let stdin = io::stdin();
    if !stdin.is_terminal() {
        let mut line = Vec::new();
        stdin
            .lock()
            .take(MAX_LINE)
            .read_until(b'\n', &mut line)
            .context("cannot read the password from standard input")
            .bad_input()?;
        if line.is_empty() {
            return Err(anyhow!(
                "no password on standard input: give it as its first line (e.g. `<<< 'PASSWORD'`), \
                 or run in a terminal to be asked"
            ))
            .bad_input();
        }
        if !line.ends_with(b"\n") && line.len() as u64 == MAX_LINE {
            return Err(anyhow!(
                "the first line of standard input is too long for a password"
            ))
            .bad_input();
        }
        let text = String::from_utf8(line)
            .map_err(|_| anyhow!("the password on standard input is not UTF-8"))
            .bad_input()?;
        return Ok(text.trim_end_matches(['\n', '\r']).to_string());
    }
    let first = ask(&format!("password for {name}: "))?;
    petriplc_opcua::hash_password(&first, 4).bad_input()?;
    let again = ask("the same password again: ")?;
    if first != again {
        return Err(anyhow!("the two passwords differ; nothing was changed")).bad_input();
    }
    Ok(first)
}

/// One line typed at the terminal without echo. Ctrl-C puts the echo back before ending.
fn ask(prompt: &str) -> Result<String, Failure> {
    use nix::sys::termios::{tcgetattr, tcsetattr, LocalFlags, SetArg};
    let stdin = io::stdin();
    let saved = tcgetattr(&stdin)
        .context("cannot read the terminal's settings")
        .run_failure()?;
    let mut quiet = saved.clone();
    quiet.local_flags.remove(LocalFlags::ECHO);
    quiet.local_flags.insert(LocalFlags::ECHONL);
    {
        let saved = saved.clone();
        // Set once per process; a second prompt finds it set (and the settings the same).
        let _ = ctrlc::set_handler(move || {
            let _ = tcsetattr(io::stdin(), SetArg::TCSANOW, &saved);
            eprintln!();
            std::process::exit(130);
        });
    }
    // Echo off before the prompt: what is typed once it shows is never echoed.
    tcsetattr(&stdin, SetArg::TCSAFLUSH, &quiet)
        .context("cannot turn the terminal's echo off")
        .run_failure()?;
    eprint!("{prompt}");
    let _ = io::stderr().flush();
    let mut line = String::new();
    let read = stdin.lock().take(MAX_LINE).read_line(&mut line);
    let restored = tcsetattr(&stdin, SetArg::TCSANOW, &saved);
    read.context("cannot read the password").bad_input()?;
    restored
        .context("cannot turn the terminal's echo back on")
        .run_failure()?;
    Ok(line.trim_end_matches(['\n', '\r']).to_string())
}
