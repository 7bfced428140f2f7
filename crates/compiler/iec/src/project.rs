//! Projects as users keep them, read as one set of sources: a folder of `.st`/`.il`/PLCopen
//! XML/TwinCAT files, or a TwinCAT `.plcproj` and the files it compiles ([`Sources::add_path`]).
//!
//! A folder is walked in a fixed order (paths compared byte by byte), bounded in files, bytes
//! and depth; links to sources and folders are followed only inside the folder, and a link
//! back to a folder being walked is refused (it would never end).

use std::collections::BTreeSet;
use std::fs;
use std::path::{Component, Path, PathBuf};

use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::twincat;

use crate::{read_source, IecError, Sources, MAX_SOURCE_BYTES};

/// The extensions of the files a folder contributes (lower case, without the dot); an `.xml`
/// file counts only when it is a PLCopen or TwinCAT file (a folder may hold other XML).
pub const FOLDER_EXTENSIONS: &[&str] = &[
    "st", "il", "xml", "tcpou", "tcdut", "tcgvl", "tctto", "tcio", "tctleo",
];

/// Most files read for one folder or project.
pub const MAX_FILES: usize = 20_000;
/// Most folders deep below the one named.
pub const MAX_DEPTH: usize = 32;

fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// Whether `path` names a project rather than one source: a folder or a `.plcproj`.
pub fn is_project(path: &Path) -> bool {
    path.is_dir() || extension(path) == "plcproj"
}

/// Whether `path` is something [`Sources::add_path`] reads as IEC 61131-3 code by its name
/// alone: a folder, a `.plcproj`, a `.st`/`.il` file or a TwinCAT file.
pub fn is_iec_path(path: &Path) -> bool {
    let ext = extension(path);
    is_project(path) || (ext != "xml" && FOLDER_EXTENSIONS.contains(&ext.as_str()))
}

fn io(path: &Path, reason: impl Into<String>) -> IecError {
    IecError::Io {
        path: path.display().to_string(),
        reason: reason.into(),
    }
}

impl Sources {
    /// Adds a file, a folder (every source below it, as one project) or a TwinCAT `.plcproj`
    /// (the files it compiles).
    pub fn add_path(&mut self, path: &Path) -> Result<(), IecError> {
        if path.is_dir() {
            self.add_dir(path)
        } else if extension(path) == "plcproj" {
            self.add_plcproj(path)
        } else {
            self.add_file(path)
        }
    }

    fn add_dir(&mut self, root: &Path) -> Result<(), IecError> {
        let files = walk(root)?;
        let mut added = 0;
        let mut total = 0u64;
        for f in &files {
            let bytes = read_source(f).map_err(|reason| io(f, reason))?;
            total += bytes.len() as u64;
            if total > MAX_SOURCE_BYTES {
                return Err(io(
                    root,
                    format!("its sources hold more than {MAX_SOURCE_BYTES} bytes together"),
                ));
            }
            let text = String::from_utf8_lossy(&bytes);
            let name = f.display().to_string();
            if extension(f) == "xml"
                && !petriplc_iec_syntax::plcopen::is_plcopen(&text)
                && !twincat::is_twincat(&name, &text)
            {
                continue;
            }
            self.add_text(&name, &text);
            added += 1;
        }
        if added == 0 {
            return Err(io(
                root,
                "the folder holds no IEC 61131-3 source (.st, .il, PLCopen .xml, .TcPOU, .TcDUT, .TcGVL, .TcTTO); name a folder that does, or the files themselves",
            ));
        }
        Ok(())
    }

    fn add_plcproj(&mut self, path: &Path) -> Result<(), IecError> {
        let bytes = read_source(path).map_err(|reason| io(path, reason))?;
        let text = String::from_utf8_lossy(&bytes);
        let name = path.display().to_string();
        let items = twincat::project_files(&mut self.map, &name, &text, &mut self.diags);
        let dir = path.parent().unwrap_or(Path::new(""));
        let mut seen = BTreeSet::new();
        let mut total = 0u64;
        if items.len() > MAX_FILES {
            return Err(io(path, format!("it names more than {MAX_FILES} files")));
        }
        for (rel, span) in items {
            let Some(file) = resolve(dir, &rel) else {
                self.diags.error(
                    diag::PROJECT_FILE,
                    span,
                    format!("the project compiles {rel}, which does not exist beside it; restore the file or remove its <Compile> item"),
                );
                continue;
            };
            if !seen.insert(file.clone()) {
                continue;
            }
            match read_source(&file) {
                Ok(bytes) => {
                    total += bytes.len() as u64;
                    if total > MAX_SOURCE_BYTES {
                        return Err(io(
                            path,
                            format!("the files it compiles hold more than {MAX_SOURCE_BYTES} bytes together"),
                        ));
                    }
                    let text = String::from_utf8_lossy(&bytes);
                    self.add_text(&file.display().to_string(), &text);
                }
                Err(reason) => self.diags.error(
                    diag::PROJECT_FILE,
                    span,
                    format!("the project compiles {rel}, which cannot be read: {reason}"),
                ),
            }
        }
        Ok(())
    }
}

/// `rel` (a project's path, `/`-separated) below `dir`, each part matched without regard to
/// case when it is not found as written (TwinCAT projects come from Windows, whose file names
/// ignore case).
fn resolve(dir: &Path, rel: &str) -> Option<PathBuf> {
    let exact = dir.join(rel);
    if exact.is_file() {
        return Some(exact);
    }
    let mut at = dir.to_path_buf();
    for part in Path::new(rel).components() {
        match part {
            Component::Normal(p) => {
                let want = p.to_string_lossy();
                let direct = at.join(p);
                if direct.exists() {
                    at = direct;
                    continue;
                }
                let found = fs::read_dir(&at)
                    .ok()?
                    .flatten()
                    .find(|e| e.file_name().to_string_lossy().eq_ignore_ascii_case(&want))?;
                at = found.path();
            }
            other => at.push(other.as_os_str()),
        }
    }
    at.is_file().then_some(at)
}

/// The source files below `root`, in the order of their paths: folders whose name starts with
/// `.` are left out; a link is followed when it points inside `root`, and refused when it
/// points outside or back to a folder above it.
fn walk(root: &Path) -> Result<Vec<PathBuf>, IecError> {
    let top = fs::canonicalize(root).map_err(|e| io(root, e.to_string()))?;
    let mut files = Vec::new();
    let mut real_files = BTreeSet::new();
    let mut real_dirs = BTreeSet::from([top.clone()]);
    // (path as named, its canonical form, depth)
    let mut stack = vec![(root.to_path_buf(), top.clone(), 0usize)];
    while let Some((dir, real_dir, depth)) = stack.pop() {
        let mut entries: Vec<_> = fs::read_dir(&dir)
            .map_err(|e| io(&dir, e.to_string()))?
            .flatten()
            .map(|e| e.path())
            .collect();
        entries.sort();
        // Reversed onto the stack, so that folders are walked in order.
        let mut subdirs = Vec::new();
        for path in entries {
            let hidden = path
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with('.'));
            let meta = fs::symlink_metadata(&path).map_err(|e| io(&path, e.to_string()))?;
            let source = FOLDER_EXTENSIONS.contains(&extension(&path).as_str());
            let (real, is_dir) = if meta.file_type().is_symlink() {
                let Ok(target) = fs::canonicalize(&path) else {
                    if !source {
                        continue;
                    }
                    return Err(io(
                        &path,
                        "it is a link to nothing; remove it or restore its target",
                    ));
                };
                // A link to another kind of file is not read, wherever it points.
                if !source && !target.is_dir() {
                    continue;
                }
                if !target.starts_with(&top) {
                    return Err(io(
                        &path,
                        format!("it links outside the folder {} (to {}); copy the files in, or name them separately", root.display(), target.display()),
                    ));
                }
                if target.is_dir() && real_dir.starts_with(&target) {
                    return Err(io(
                        &path,
                        format!(
                            "it links back to {}, a folder that holds it (a loop); remove the link",
                            target.display()
                        ),
                    ));
                }
                let d = target.is_dir();
                (target, d)
            } else {
                (path.clone(), meta.is_dir())
            };
            if is_dir {
                if hidden {
                    continue;
                }
                if depth + 1 > MAX_DEPTH {
                    return Err(io(
                        &path,
                        format!(
                            "folders nested more than {MAX_DEPTH} deep below {}",
                            root.display()
                        ),
                    ));
                }
                let real = if meta.file_type().is_symlink() {
                    real
                } else {
                    real_dir.join(path.file_name().unwrap_or_default())
                };
                if real_dirs.insert(real.clone()) {
                    subdirs.push((path, real, depth + 1));
                }
                continue;
            }
            if !source {
                continue;
            }
            let real = if meta.file_type().is_symlink() {
                real
            } else {
                real_dir.join(path.file_name().unwrap_or_default())
            };
            if real_files.insert(real) {
                files.push(path);
                if files.len() > MAX_FILES {
                    return Err(io(
                        root,
                        format!(
                            "it holds more than {MAX_FILES} source files; name a smaller folder"
                        ),
                    ));
                }
            }
        }
        stack.extend(subdirs.into_iter().rev());
    }
    files.sort();
    Ok(files)
}

#[cfg(test)]
mod tests;
