//! Which PLC and module a process belongs to: MatPLC-style `--PLCxxx=` arguments, then the
//! environment the runner sets, then the module's own default name.
//!
//! Pure functions of the arguments and an environment lookup, so the precedence rules are
//! tested without touching the process environment (which tests running in parallel share).

use std::ffi::OsString;
use std::os::unix::ffi::OsStringExt;
use std::path::PathBuf;

use crate::{Error, PLC_ERR_ARGS};

/// The environment variables `petriplc run` sets for an external module process.
pub const ENV_CONFIG: &str = "PETRIPLC_CONFIG";
pub const ENV_MODULE: &str = "PETRIPLC_MODULE";
pub const ENV_PLC_ID: &str = "PETRIPLC_PLC_ID";

const OPT_CONFIG: &str = "--PLCconfig=";
const OPT_MODULE: &str = "--PLCmodule=";
const OPT_PLC_ID: &str = "--PLCplc_id=";

/// The `--PLC` options found in argv, and the arguments left for the module.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct Parsed {
    pub config: Option<OsString>,
    pub module: Option<String>,
    pub plc_id: Option<String>,
    /// Indices into argv of the arguments the module keeps (argv\[0\] always).
    pub keep: Vec<usize>,
}

/// Where the module attaches.
#[derive(Debug, PartialEq, Eq)]
pub struct Target {
    pub config: PathBuf,
    pub module: String,
    /// `None`: take the configuration's `[PLC] plc_id` once it is read.
    pub plc_id: Option<String>,
}

fn utf8(option: &str, value: &[u8]) -> Result<String, Error> {
    String::from_utf8(value.to_vec()).map_err(|_| {
        Error::new(
            PLC_ERR_ARGS,
            format!("{option}: the value is not valid UTF-8"),
        )
    })
}

/// Takes the `--PLC` options out of `args` (argv, program name first). A `--` ends them:
/// what follows is the module's, untouched.
pub fn parse(args: &[&[u8]]) -> Result<Parsed, Error> {
    let mut parsed = Parsed {
        keep: if args.is_empty() { vec![] } else { vec![0] },
        ..Parsed::default()
    };
    let mut ended = false;
    for (i, arg) in args.iter().enumerate().skip(1) {
        if ended || !arg.starts_with(b"--PLC") {
            ended |= *arg == b"--";
            parsed.keep.push(i);
            continue;
        }
        if let Some(v) = arg.strip_prefix(OPT_CONFIG.as_bytes()) {
            parsed.config = Some(OsString::from_vec(v.to_vec()));
        } else if let Some(v) = arg.strip_prefix(OPT_MODULE.as_bytes()) {
            parsed.module = Some(utf8(OPT_MODULE, v)?);
        } else if let Some(v) = arg.strip_prefix(OPT_PLC_ID.as_bytes()) {
            parsed.plc_id = Some(utf8(OPT_PLC_ID, v)?);
        } else {
            // A misspelt option silently handed to the module would attach it to the wrong
            // PLC or module: refuse it.
            return Err(Error::new(
                PLC_ERR_ARGS,
                format!(
                    "unknown option `{}`: the library takes {OPT_CONFIG}FILE, \
                     {OPT_MODULE}NAME and {OPT_PLC_ID}ID (put `--` before arguments of the \
                     module's own that start with --PLC)",
                    String::from_utf8_lossy(arg)
                ),
            ));
        }
    }
    Ok(parsed)
}

/// Applies the precedence: command line, then environment, then `default_module` (the name
/// the program passed to `plc_init`).
pub fn resolve(
    parsed: &Parsed,
    env: impl Fn(&str) -> Option<OsString>,
    default_module: Option<&str>,
) -> Result<Target, Error> {
    let nonempty = |v: Option<OsString>| v.filter(|v| !v.is_empty());
    let module = match parsed.module.clone() {
        Some(m) => Some(m),
        None => match nonempty(env(ENV_MODULE)) {
            Some(m) => Some(m.into_string().map_err(|_| {
                Error::new(PLC_ERR_ARGS, format!("{ENV_MODULE} is not valid UTF-8"))
            })?),
            None => default_module.map(str::to_string),
        },
    };
    let module = module.filter(|m| !m.is_empty()).ok_or_else(|| {
        Error::new(
            PLC_ERR_ARGS,
            format!(
                "no module name: start the module from `petriplc run` (which sets \
                 {ENV_MODULE}), pass {OPT_MODULE}NAME, or give plc_init a default name"
            ),
        )
    })?;
    let config = match parsed.config.clone().or_else(|| nonempty(env(ENV_CONFIG))) {
        Some(c) if !c.is_empty() => PathBuf::from(c),
        _ => {
            return Err(Error::new(
                PLC_ERR_ARGS,
                format!(
                    "module `{module}`: no configuration file: start the module from \
                     `petriplc run` (which sets {ENV_CONFIG}), or pass {OPT_CONFIG}FILE"
                ),
            ))
        }
    };
    let plc_id = match parsed.plc_id.clone() {
        Some(id) => Some(id),
        None => match nonempty(env(ENV_PLC_ID)) {
            Some(id) => Some(id.into_string().map_err(|_| {
                Error::new(PLC_ERR_ARGS, format!("{ENV_PLC_ID} is not valid UTF-8"))
            })?),
            None => None,
        },
    };
    Ok(Target {
        config,
        module,
        plc_id,
    })
}

/// The message for a module that found no PLC id anywhere.
pub fn no_plc_id(module: &str) -> Error {
    Error::new(
        PLC_ERR_ARGS,
        format!(
            "module `{module}`: no PLC id: start the module from `petriplc run` (which sets \
             {ENV_PLC_ID}), pass {OPT_PLC_ID}ID, or set `plc_id` in the configuration's [PLC] \
             section"
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(list: &[&'static str]) -> Vec<&'static [u8]> {
        list.iter().map(|a| a.as_bytes()).collect()
    }

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<OsString> + 'a {
        move |name| {
            vars.iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| OsString::from(v))
        }
    }

    #[test]
    fn plc_options_are_taken_out_and_the_rest_kept_in_order() {
        let p = parse(&args(&[
            "prog",
            "-v",
            "--PLCmodule=m",
            "x",
            "--PLCconfig=/etc/p.conf",
            "--PLCplc_id=7",
            "--",
            "--PLCmodule=not-ours",
        ]))
        .unwrap();
        assert_eq!(p.module.as_deref(), Some("m"));
        assert_eq!(p.plc_id.as_deref(), Some("7"));
        assert_eq!(p.config, Some(OsString::from("/etc/p.conf")));
        assert_eq!(p.keep, vec![0, 1, 3, 6, 7]);
        assert_eq!(parse(&[]).unwrap().keep, Vec::<usize>::new());
    }

    #[test]
    fn unknown_plc_options_are_refused() {
        let e = parse(&args(&["prog", "--PLCshared"])).unwrap_err();
        assert_eq!(e.code, PLC_ERR_ARGS);
        assert!(e.message.contains("unknown option `--PLCshared`"), "{e:?}");
        let e = parse(&args(&["prog", "--PLCmodule"])).unwrap_err();
        assert!(e.message.contains("--PLCmodule=NAME"), "{e:?}");
    }

    #[test]
    fn command_line_beats_environment_beats_default() {
        let vars = [
            (ENV_CONFIG, "/env.conf"),
            (ENV_MODULE, "env_mod"),
            (ENV_PLC_ID, "env_id"),
        ];
        let none = Parsed::default();
        let t = resolve(&none, env(&vars), Some("dflt")).unwrap();
        assert_eq!(
            t,
            Target {
                config: "/env.conf".into(),
                module: "env_mod".into(),
                plc_id: Some("env_id".into()),
            }
        );
        let cli = parse(&args(&[
            "p",
            "--PLCconfig=/cli.conf",
            "--PLCmodule=cli_mod",
            "--PLCplc_id=cli_id",
        ]))
        .unwrap();
        let t = resolve(&cli, env(&vars), Some("dflt")).unwrap();
        assert_eq!(t.config, PathBuf::from("/cli.conf"));
        assert_eq!(t.module, "cli_mod");
        assert_eq!(t.plc_id.as_deref(), Some("cli_id"));
        let t = resolve(&none, env(&[(ENV_CONFIG, "/c")]), Some("dflt")).unwrap();
        assert_eq!((t.module.as_str(), t.plc_id), ("dflt", None));
    }

    #[test]
    fn missing_pieces_say_how_to_start_the_module() {
        let none = Parsed::default();
        let e = resolve(&none, env(&[]), None).unwrap_err();
        assert!(e.message.contains("no module name"), "{e:?}");
        assert!(e.message.contains("petriplc run"), "{e:?}");
        let e = resolve(&none, env(&[]), Some("m")).unwrap_err();
        assert!(e.message.contains("--PLCconfig=FILE"), "{e:?}");
        assert!(e.message.contains(ENV_CONFIG), "{e:?}");
        let e = no_plc_id("m");
        assert!(e.message.contains("--PLCplc_id=ID"), "{e:?}");
        assert!(e.message.contains("petriplc run"), "{e:?}");
    }
}
