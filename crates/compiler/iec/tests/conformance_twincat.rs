//! The TwinCAT 3 reader against the same code extracted to Structured Text: every OSCAT
//! POU of TcOscatBasic read from its original `.TcPOU`/`.TcDUT`/`.TcGVL` file (and those of its
//! dependencies) must get the verdict its extracted `.st` copy in `../shared/corpora/oscat/tcoscat`
//! gets (accepted, or refused with the same first error code), except where the original holds
//! methods, properties or actions (E190), which the extraction left out; and the whole
//! `.plcproj` is read.
//!
//! The originals are not in `../shared`: the test reads a checkout of
//! github.com/mihaiginta/TcOscatBasic (commit a58501f) named by `PETRIPLC_TCOSCAT`, and says in
//! one line that it was skipped without it. `scripts/conformance-twincat.sh` fetches it and runs
//! this test.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use petriplc_iec::{check, Dialect, Natives, Sources};

mod oscat;

/// A TwinCAT manifest entry with its original file, relative to the repository.
struct Entry {
    file: String,
    deps: Vec<String>,
    original: String,
}

fn manifest(root: &Path) -> Vec<Entry> {
    oscat::manifest(root)
        .into_iter()
        .filter(|e| e.set == "tcoscat")
        .map(|e| {
            let path = e.source.split_once(':').unwrap().1;
            let original = path.split("  (").next().unwrap().trim().to_string();
            Entry {
                file: e.file,
                deps: e.deps,
                original,
            }
        })
        .collect()
}

/// The verdict on a set of files: `None` when they check, else the code of the first error of
/// `own` (the file the entry is about), or of any file.
fn verdict(files: &[PathBuf], own: &Path) -> Option<String> {
    let mut sources = Sources::new();
    // The extracted `.st` copies in TwinCAT's dialect, as conformance_oscat checks them (the
    // originals are detected as TwinCAT's files): both load its vendor library.
    sources.dialect = Some(Dialect::Twincat);
    for f in files {
        if let Err(e) = sources.add_path(f) {
            return Some(format!("io: {e}"));
        }
    }
    let err = check(&sources, &Natives::default()).err()?.to_string();
    let own = own.display().to_string();
    let line = err
        .lines()
        .find(|l| l.starts_with(&own) && l.contains("error["))
        .or_else(|| err.lines().find(|l| l.contains("error[")))
        .unwrap_or(&err);
    Some(
        line.split_once("error[")
            .and_then(|(_, r)| r.split_once(']'))
            .map_or("other", |(c, _)| c)
            .to_string(),
    )
}

#[test]
fn twincat_originals_read_as_their_extracted_text() {
    let Some(repo) = std::env::var_os("PETRIPLC_TCOSCAT").map(PathBuf::from) else {
        eprintln!("conformance test twincat_originals_read_as_their_extracted_text skipped: PETRIPLC_TCOSCAT (a checkout of mihaiginta/TcOscatBasic) is not set; scripts/conformance-twincat.sh sets it");
        return;
    };
    let Some(corpus) = petriplc_testnet::data::conformance(
        "twincat_originals_read_as_their_extracted_text",
        "corpora/oscat",
    ) else {
        return;
    };
    let entries = manifest(&corpus);
    let originals: BTreeMap<&str, &str> = entries
        .iter()
        .map(|e| (e.file.as_str(), e.original.as_str()))
        .collect();
    let (mut same, mut accepted, mut methods) = (0, 0, 0);
    let mut differ = Vec::new();
    for e in &entries {
        let chain = || e.deps.iter().chain(std::iter::once(&e.file));
        let st: Vec<PathBuf> = chain().map(|f| corpus.join(f)).collect();
        let tc: Vec<PathBuf> = chain().map(|f| repo.join(originals[f.as_str()])).collect();
        let want = verdict(&st, &corpus.join(&e.file));
        let got = verdict(&tc, &repo.join(&e.original));
        if got.is_none() {
            accepted += 1;
        }
        if want == got {
            same += 1;
        } else if got.as_deref() == Some("E190") {
            methods += 1;
        } else {
            differ.push(format!(
                "{}: extracted {want:?}, original {got:?}",
                e.original
            ));
        }
    }
    println!(
        "TcOscatBasic originals: {accepted} of {} accepted; {same} as their extracted text, {methods} refused for their methods/properties/actions",
        entries.len()
    );
    assert!(differ.is_empty(), "{}", differ.join("\n"));

    // The project file names every original, and they are read together.
    let proj = repo.join("TcOscatBasic/TcOscatBasic/TcOscatBasic.plcproj");
    let mut s = Sources::new();
    s.add_path(&proj).unwrap();
    let names: std::collections::BTreeSet<&str> =
        s.map.files().map(|(_, f)| f.name.as_str()).collect();
    println!("TcOscatBasic.plcproj: {} files read", names.len() - 1);
    for e in entries
        .iter()
        .filter(|e| e.original.starts_with("TcOscatBasic/TcOscatBasic/"))
    {
        let path = repo.join(&e.original).display().to_string();
        assert!(names.contains(path.as_str()), "{path} not read");
    }
    assert!(!s.diags.items.iter().any(|d| d.code.0 == "E056"));
}
