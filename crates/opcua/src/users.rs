//! The password file of `users = FILE`: one `NAME:HASH` line per user, HASH a bcrypt hash
//! (`$2y$…`, `$2b$…`, `$2a$…`) as `htpasswd -B` writes it; `#` comments and blank lines.
//! Passwords are never stored or logged in clear.

use std::collections::BTreeMap;
use std::path::Path;

/// User name → bcrypt hash.
#[derive(Clone, Debug, Default)]
pub struct Users(BTreeMap<String, String>);

impl Users {
    /// Reads and checks the file; every bad line is reported with file:line.
    pub fn read(path: &Path, shown: &str) -> Result<Users, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("`users = {shown}`: cannot read {}: {e}", path.display()))?;
        Users::parse(&text, &path.display().to_string())
    }

    pub fn parse(text: &str, file: &str) -> Result<Users, String> {
        let mut users = BTreeMap::new();
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
            let bcrypt = ["$2a$", "$2b$", "$2y$", "$2x$"]
                .iter()
                .any(|p| hash.starts_with(p))
                && hash.len() == 60;
            if !bcrypt {
                problems.push(format!(
                    "{at}: the password of `{name}` is not a bcrypt hash; write hashes, never \
                     passwords: `htpasswd -B -C 12 FILE {name}` adds one"
                ));
                continue;
            }
            if users.insert(name.to_string(), hash.to_string()).is_some() {
                problems.push(format!("{at}: user `{name}` appears twice"));
            }
        }
        if !problems.is_empty() {
            return Err(problems.join("\n"));
        }
        if users.is_empty() {
            return Err(format!(
                "{file} has no user; add `NAME:HASH` lines (`htpasswd -B -C 12 {file} NAME`)"
            ));
        }
        Ok(Users(users))
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
}
