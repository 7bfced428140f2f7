//! The names of a PLC's POSIX shared memory objects (`/petriplc-ID-image`,
//! `/petriplc-ID-synch`), derived from its id by one rule, and their removal; and the
//! directory its lock and status files live in (`owner` and `status` both name files there).

use nix::errno::Errno;
use nix::sys::mman::shm_unlink;

/// The directory of the status and lock files: /dev/shm, where the shared memory objects
/// are, or the temporary directory where there is none.
pub fn state_dir() -> std::path::PathBuf {
    let shm = std::path::Path::new("/dev/shm");
    if shm.is_dir() {
        shm.to_path_buf()
    } else {
        std::env::temp_dir()
    }
}

/// The name of object `object` of PLC `plc_id`, or why the id cannot name one.
pub(crate) fn object_name(plc_id: &str, object: &str) -> Result<String, &'static str> {
    if plc_id.is_empty() {
        return Err("it is empty");
    }
    if plc_id.len() > 200 {
        return Err("it is longer than 200 characters");
    }
    // A portable shm name is one path component; keeping ids to these characters also keeps
    // them usable in file names and on command lines.
    if !plc_id
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
    {
        return Err("use only letters, digits, `_`, `-` and `.`");
    }
    Ok(format!("/petriplc-{plc_id}-{object}"))
}

/// Removes object `name`; says whether it existed.
pub(crate) fn unlink(name: &str) -> Result<bool, Errno> {
    match shm_unlink(name) {
        Ok(()) => Ok(true),
        Err(Errno::ENOENT) => Ok(false),
        Err(e) => Err(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(plc_id: &str, expect: Result<&str, &'static str>) {
        let got = object_name(plc_id, "image");
        assert_eq!(got.as_deref().map_err(|e| *e), expect, "{plc_id}");
    }

    #[test]
    fn ids_name_one_path_component() {
        check("line-2.a_b", Ok("/petriplc-line-2.a_b-image"));
        check("", Err("it is empty"));
        check("a/b", Err("use only letters, digits, `_`, `-` and `.`"));
        check(
            "with space",
            Err("use only letters, digits, `_`, `-` and `.`"),
        );
        check(&"x".repeat(201), Err("it is longer than 200 characters"));
    }
}
