//! The password file of `users = FILE`: one `NAME:HASH` line per user, HASH a bcrypt hash
//! (`$2a$`, `$2b$`, `$2x$` or `$2y$`, as `petriplc user add` or `htpasswd -B` write them);
//! `#` comments and blank lines. Passwords are never stored or logged in clear. Also the
//! edits of `petriplc user`: a user added, its hash replaced or the user removed, every other
//! line kept as it was.

use std::collections::BTreeMap;
use std::path::Path;

/// The prefixes of the bcrypt hashes the file may hold (all four verify the same way for
/// ASCII passwords; docs/opcua.md says what `$2x$` means for others).
pub const BCRYPT_PREFIXES: [&str; 4] = ["$2a$", "$2b$", "$2x$", "$2y$"];

/// The longest password bcrypt reads whole: it ignores the bytes after the 72nd (the 72nd
/// being the password's terminating zero byte).
pub const MAX_PASSWORD_BYTES: usize = 71;

/// The text of a users file: a regular file of at most 1 MiB (thousands of users).
pub fn read_text(path: &Path) -> Result<String, String> {
    petriplc_files::read_to_string(path, petriplc_files::SMALL).map_err(|e| e.to_string())
}

/// User name → bcrypt hash.
#[derive(Clone, Debug, Default)]
pub struct Users(BTreeMap<String, String>);

/// Why a users file cannot be edited as asked.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum EditError {
    #[error("user name `{shown}`: {why}", shown = .name.escape_debug())]
    BadName { name: String, why: &'static str },
    #[error(
        "{file}:{line}: user `{name}` exists; `petriplc user add {file} {name} --replace` \
         gives it a new password"
    )]
    Exists {
        file: String,
        line: usize,
        name: String,
    },
    #[error("{file} has no user `{name}`")]
    Missing { file: String, name: String },
    #[error("{problems}\nfix these lines first: nothing was changed")]
    Malformed { problems: String },
    #[error("the password {0}")]
    BadPassword(&'static str),
    /// bcrypt's own refusal (a cost outside 4–31, no random salt), as text.
    #[error("cannot hash the password: {0}")]
    Hash(String),
}

/// What an edit did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edit {
    Added,
    Replaced,
}

/// The checked lines of a file: (line index, name, hash) and every problem, with file:line.
fn lines<'a>(text: &'a str, file: &str) -> (Vec<(usize, &'a str, &'a str)>, Vec<String>) {
    let mut users: Vec<(usize, &str, &str)> = Vec::new();
    let mut problems = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let at = format!("{file}:{}", i + 1);
        let Some((name, hash)) = line.split_once(':') else {
            problems.push(format!("{at}: a line is `NAME:BCRYPT_HASH`"));
            continue;
        };
        if name.is_empty() {
            problems.push(format!("{at}: the user name is empty"));
            continue;
        }
        let bcrypt = BCRYPT_PREFIXES.iter().any(|p| hash.starts_with(p)) && hash.len() == 60;
        if !bcrypt {
            problems.push(format!(
                "{at}: the password of `{name}` is not a bcrypt hash; write hashes, never \
                 passwords: `petriplc user add {file} {name}` adds one"
            ));
            continue;
        }
        if users.iter().any(|(_, n, _)| *n == name) {
            problems.push(format!("{at}: user `{name}` appears twice"));
            continue;
        }
        users.push((i, name, hash));
    }
    (users, problems)
}

impl Users {
    /// Reads and checks the file; every bad line is reported with file:line.
    pub fn read(path: &Path, shown: &str) -> Result<Users, String> {
        let text = read_text(path).map_err(|e| format!("`users = {shown}`: {e}"))?;
        Users::parse(&text, &path.display().to_string())
    }

    pub fn parse(text: &str, file: &str) -> Result<Users, String> {
        let (users, problems) = lines(text, file);
        if !problems.is_empty() {
            return Err(problems.join("\n"));
        }
        if users.is_empty() {
            return Err(format!(
                "{file} has no user; add one with `petriplc user add {file} NAME`"
            ));
        }
        Ok(Users(
            users
                .into_iter()
                .map(|(_, n, h)| (n.to_string(), h.to_string()))
                .collect(),
        ))
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Whether `password` is `name`'s (bcrypt compares in constant time for a given hash).
    pub fn check(&self, name: &str, password: &str) -> bool {
        match self.0.get(name) {
            Some(hash) => bcrypt::verify(password, hash).unwrap_or(false),
            None => false,
        }
    }
}

/// The bcrypt hash (`$2b$`) of a password, at `cost` (4 to 31: 2^cost rounds).
pub fn hash_password(password: &str, cost: u32) -> Result<String, EditError> {
    if password.is_empty() {
        return Err(EditError::BadPassword("is empty"));
    }
    if password.len() > MAX_PASSWORD_BYTES {
        return Err(EditError::BadPassword(
            "is longer than 71 bytes, of which bcrypt would ignore the rest",
        ));
    }
    if password.contains('\0') {
        return Err(EditError::BadPassword("holds a zero byte"));
    }
    bcrypt::non_truncating_hash(password, cost).map_err(|e| EditError::Hash(e.to_string()))
}

/// Whether `name` can be a user of the file (and a user name a client types).
pub fn check_name(name: &str) -> Result<(), EditError> {
    let why = if name.is_empty() {
        Some("empty")
    } else if name.contains(':') {
        Some("`:` separates the name from the hash in the file")
    } else if name.starts_with('#') {
        Some("a line starting with `#` is a comment")
    } else if name.trim() != name {
        Some("spaces at its start or end would be lost")
    } else if name.chars().any(char::is_control) {
        Some("control characters")
    } else if name.chars().count() > 64 {
        Some("longer than 64 characters")
    } else {
        None
    };
    match why {
        Some(why) => Err(EditError::BadName {
            name: name.chars().take(80).collect(),
            why,
        }),
        None => Ok(()),
    }
}

/// `text` (the file's contents, `file` its name for messages) with user `name` holding
/// `hash`: a new line at the end, or, with `replace`, its line replaced in place. A file
/// with bad lines is not edited.
pub fn with_user(
    text: &str,
    file: &str,
    name: &str,
    hash: &str,
    replace: bool,
) -> Result<(String, Edit), EditError> {
    let entry = format!("{name}:{hash}");
    match may_set(text, file, name, replace)? {
        Some(line) => Ok((set_line(text, line, Some(&entry)), Edit::Replaced)),
        None => {
            let mut out = text.to_string();
            if !out.is_empty() && !out.ends_with('\n') {
                out.push('\n');
            }
            out.push_str(&entry);
            out.push('\n');
            Ok((out, Edit::Added))
        }
    }
}

/// Whether [`with_user`] would succeed, before a password is asked for: the index of the
/// user's line to replace, or `None` to add one.
pub fn may_set(
    text: &str,
    file: &str,
    name: &str,
    replace: bool,
) -> Result<Option<usize>, EditError> {
    check_name(name)?;
    let (users, problems) = lines(text, file);
    if !problems.is_empty() {
        return Err(EditError::Malformed {
            problems: problems.join("\n"),
        });
    }
    match users.iter().find(|(_, n, _)| *n == name) {
        Some(&(line, _, _)) if replace => Ok(Some(line)),
        Some(&(line, _, _)) => Err(EditError::Exists {
            file: file.to_string(),
            line: line + 1,
            name: name.to_string(),
        }),
        None => Ok(None),
    }
}

/// `text` without user `name`'s line.
pub fn without_user(text: &str, file: &str, name: &str) -> Result<String, EditError> {
    let (users, problems) = lines(text, file);
    if !problems.is_empty() {
        return Err(EditError::Malformed {
            problems: problems.join("\n"),
        });
    }
    match users.iter().find(|(_, n, _)| *n == name) {
        Some(&(line, _, _)) => Ok(set_line(text, line, None)),
        None => Err(EditError::Missing {
            file: file.to_string(),
            name: name.to_string(),
        }),
    }
}

/// `text` with line `index` replaced by `new` (or removed); line ends kept.
fn set_line(text: &str, index: usize, new: Option<&str>) -> String {
    let mut out = String::with_capacity(text.len() + 64);
    for (i, line) in text.split_inclusive('\n').enumerate() {
        if i != index {
            out.push_str(line);
            continue;
        }
        if let Some(new) = new {
            out.push_str(new);
            let end = &line[line.trim_end_matches(['\r', '\n']).len()..];
            out.push_str(if end.is_empty() { "\n" } else { end });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str, expect: Result<usize, &str>) {
        match (Users::parse(text, "u"), expect) {
            (Ok(u), Ok(n)) => assert_eq!(u.0.len(), n),
            (Err(e), Err(why)) => assert!(e.contains(why), "{e}"),
            (got, want) => panic!("got {got:?}, expected {want:?}"),
        }
    }

    #[test]
    fn password_files_hold_bcrypt_hashes_only() {
        let hash = bcrypt::hash("pw", 4).unwrap();
        check(&format!("# users\n\nop:{hash}\n"), Ok(1));
        check(
            &format!("op:{hash}\nop:{hash}\n"),
            Err("u:2: user `op` appears twice"),
        );
        check(
            "op:secret\n",
            Err("u:1: the password of `op` is not a bcrypt hash"),
        );
        check("op\n", Err("u:1: a line is `NAME:BCRYPT_HASH`"));
        check("# nobody\n", Err("has no user"));
        let users = Users::parse(&format!("op:{hash}\n"), "u").unwrap();
        assert!(users.check("op", "pw"));
        assert!(!users.check("op", "pW"));
        assert!(!users.check("other", "pw"));
        // htpasswd -B writes $2y$ hashes.
        let y = hash.replacen("$2b$", "$2y$", 1);
        assert!(Users::parse(&format!("op:{y}\n"), "u")
            .unwrap()
            .check("op", "pw"));
    }

    /// Hashes made by another implementation, libxcrypt's crypt(3) (glibc's `crypt`, through
    /// Python's `crypt.crypt("correct horse", "$2?$05$CCCCCCCCCCCCCCCCCCCCC.")`), one per
    /// accepted prefix, and the first test vector of Openwall's crypt_blowfish.
    #[test]
    fn hashes_of_every_accepted_prefix_verify() {
        let known = [
            (
                "correct horse",
                "$2a$05$CCCCCCCCCCCCCCCCCCCCC.WrAwgFxicHZ3kL7zMvXYXHKosDn8ot2",
            ),
            (
                "correct horse",
                "$2b$05$CCCCCCCCCCCCCCCCCCCCC.WrAwgFxicHZ3kL7zMvXYXHKosDn8ot2",
            ),
            (
                "correct horse",
                "$2x$05$CCCCCCCCCCCCCCCCCCCCC.WrAwgFxicHZ3kL7zMvXYXHKosDn8ot2",
            ),
            (
                "correct horse",
                "$2y$05$CCCCCCCCCCCCCCCCCCCCC.WrAwgFxicHZ3kL7zMvXYXHKosDn8ot2",
            ),
            (
                "U*U",
                "$2a$05$CCCCCCCCCCCCCCCCCCCCC.E5YPO9kmyuRGyh0XouQYb4YMJKvyOeW",
            ),
        ];
        for (password, hash) in known {
            let users = Users::parse(&format!("op:{hash}\n"), "u").unwrap();
            assert!(users.check("op", password), "{hash}");
            assert!(!users.check("op", "correct horse "), "{hash}");
        }
        // `$2x$` marks crypt_blowfish's hashes of its sign-extension bug: for a password with
        // bytes above 127 they differ from `$2a$`'s, and only the correct one is known here.
        let pound = "\u{a3}";
        let b = "$2b$05$/OK.fbVrR/bpIqNJ5ianF.crQZGxQ7hWEf.fNKRjrYcudfgPvGbVK";
        let x = "$2x$05$/OK.fbVrR/bpIqNJ5ianF.ZWGqVwLKgsYeGeOWNzCYbZCI.oWeH2C";
        assert!(Users::parse(&format!("op:{b}\n"), "u")
            .unwrap()
            .check("op", pound));
        assert!(!Users::parse(&format!("op:{x}\n"), "u")
            .unwrap()
            .check("op", pound));
        // Another prefix, or a hash cut short, is not a bcrypt hash.
        check(
            "op:$2c$05$CCCCCCCCCCCCCCCCCCCCC.WrAwgFxicHZ3kL7zMvXYXHKosDn8ot2\n",
            Err("not a bcrypt hash"),
        );
        check(
            "op:$2b$05$CCCCCCCCCCCCCCCCCCCCC.WrAwgFxicHZ3kL7zMvXYXHKosDn8ot\n",
            Err("not a bcrypt hash"),
        );
    }

    const H1: &str = "$2b$05$CCCCCCCCCCCCCCCCCCCCC.WrAwgFxicHZ3kL7zMvXYXHKosDn8ot2";
    const H2: &str = "$2a$05$CCCCCCCCCCCCCCCCCCCCC.E5YPO9kmyuRGyh0XouQYb4YMJKvyOeW";

    #[test]
    fn users_are_added_replaced_and_removed_keeping_every_other_line() {
        // A new file, and one with comments only.
        assert_eq!(
            with_user("", "u", "op", H1, false),
            Ok((format!("op:{H1}\n"), Edit::Added))
        );
        assert_eq!(
            with_user("# users\n", "u", "op", H1, false),
            Ok((format!("# users\nop:{H1}\n"), Edit::Added))
        );
        // A last line without its newline.
        let text = format!("# plant\r\nop:{H1}\r\n\nmaint:{H2}");
        assert_eq!(
            with_user(&text, "u", "x", H2, false),
            Ok((format!("{text}\nx:{H2}\n"), Edit::Added))
        );
        assert_eq!(
            with_user(&text, "u", "op", H2, false),
            Err(EditError::Exists {
                file: "u".into(),
                line: 2,
                name: "op".into()
            })
        );
        assert_eq!(
            with_user(&text, "u", "op", H2, true),
            Ok((
                format!("# plant\r\nop:{H2}\r\n\nmaint:{H2}"),
                Edit::Replaced
            ))
        );
        // --replace of a user not there adds it.
        assert_eq!(
            with_user(&text, "u", "new", H2, true).map(|r| r.1),
            Ok(Edit::Added)
        );
        assert_eq!(
            with_user(&text, "u", "maint", H1, true),
            Ok((
                format!("# plant\r\nop:{H1}\r\n\nmaint:{H1}\n"),
                Edit::Replaced
            ))
        );
        assert_eq!(
            without_user(&text, "u", "op"),
            Ok(format!("# plant\r\n\nmaint:{H2}"))
        );
        assert_eq!(
            without_user(&text, "u", "nobody"),
            Err(EditError::Missing {
                file: "u".into(),
                name: "nobody".into()
            })
        );
        // A file with bad lines is not touched.
        let e = with_user("op:secret\n", "u", "x", H1, false).unwrap_err();
        assert!(e
            .to_string()
            .contains("u:1: the password of `op` is not a bcrypt hash"));
        assert!(e.to_string().contains("nothing was changed"));
    }

    #[test]
    fn passwords_are_hashed_whole_or_refused() {
        let h = hash_password("op-pass", 4).unwrap();
        assert!(h.starts_with("$2b$04$") && h.len() == 60, "{h}");
        let users = Users::parse(&format!("op:{h}\n"), "u").unwrap();
        assert!(users.check("op", "op-pass"));
        assert!(hash_password(&"x".repeat(71), 4).is_ok());
        for (pw, why) in [
            ("", "is empty"),
            (&*"x".repeat(72), "longer than 71 bytes"),
            ("a\0b", "zero byte"),
        ] {
            let e = hash_password(pw, 4).unwrap_err().to_string();
            assert!(e.contains(why), "{e}");
        }
        assert!(hash_password("pw", 3).is_err());
    }

    #[test]
    fn user_names_must_survive_the_file_and_a_client() {
        for (name, why) in [
            ("", "empty"),
            ("a:b", "`:` separates"),
            ("#op", "comment"),
            (" op", "spaces"),
            ("op\n", "spaces"),
            ("o\tp", "control"),
            (&"x".repeat(65), "longer than 64"),
        ] {
            let e = check_name(name).unwrap_err().to_string();
            assert!(e.contains(why), "{name:?}: {e}");
        }
        assert!(check_name("opérateur 2").is_ok());
        assert_eq!(
            check_name("a\u{1b}[31m").unwrap_err().to_string(),
            "user name `a\\u{1b}[31m`: control characters"
        );
    }
}
