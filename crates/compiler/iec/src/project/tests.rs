use std::os::unix::fs::symlink;

use super::*;
use crate::{check, Natives};

fn write(dir: &Path, rel: &str, text: &str) {
    let p = dir.join(rel);
    fs::create_dir_all(p.parent().unwrap()).unwrap();
    fs::write(p, text).unwrap();
}

fn tcpou(decl: &str, body: &str) -> String {
    format!(
        "\u{feff}<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<TcPlcObject Version=\"1.1.0.1\">\n  <POU Name=\"x\">\n    <Declaration><![CDATA[{decl}]]></Declaration>\n    <Implementation>\n      <ST><![CDATA[{body}]]></ST>\n    </Implementation>\n  </POU>\n</TcPlcObject>\n"
    )
}

fn task(name: &str, us: u32, program: &str) -> String {
    format!("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<TcPlcObject Version=\"1.1.0.1\">\n  <Task Name=\"{name}\">\n    <CycleTime>{us}</CycleTime>\n    <Priority>20</Priority>\n    <PouCall>\n      <Name>{program}</Name>\n    </PouCall>\n  </Task>\n</TcPlcObject>\n")
}

fn names(s: &Sources) -> Vec<String> {
    let mut seen: Vec<String> = Vec::new();
    for (_, f) in s.map.files() {
        if seen.last() != Some(&f.name) {
            seen.push(f.name.clone());
        }
    }
    seen
}

#[test]
fn a_folder_is_one_project_read_in_path_order() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    write(
        root,
        "b/main.st",
        "PROGRAM main\nVAR c : Inc; END_VAR\nc();\nEND_PROGRAM\n",
    );
    write(
        root,
        "a/inc.st",
        "FUNCTION_BLOCK Inc\nVAR_OUTPUT n : INT; END_VAR\nn := n + 1;\nEND_FUNCTION_BLOCK\n",
    );
    write(root, "a/notes.txt", "not a source");
    write(root, "a/other.xml", "<settings/>");
    write(root, ".git/x.st", "broken(");
    let mut s = Sources::new();
    s.add_path(root).unwrap();
    let got: Vec<String> = names(&s)
        .iter()
        .map(|n| {
            n.strip_prefix(&root.display().to_string())
                .unwrap()
                .to_string()
        })
        .collect();
    assert_eq!(got, ["/a/inc.st", "/b/main.st"]);
    let checked = check(&s, &Natives::default()).unwrap();
    assert_eq!(checked.project.programs().count(), 1);
}

#[test]
fn an_empty_folder_is_refused() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "readme.md", "x");
    let e = Sources::new().add_path(d.path()).unwrap_err().to_string();
    assert!(e.contains("the folder holds no IEC 61131-3 source"), "{e}");
}

#[test]
fn links_are_followed_only_inside_the_folder_and_never_round() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path().join("p");
    write(&root, "src/a.st", "PROGRAM a\nEND_PROGRAM\n");
    // A link to a file of the folder is read once.
    symlink(root.join("src/a.st"), root.join("src/again.st")).unwrap();
    let mut s = Sources::new();
    s.add_path(&root).unwrap();
    assert_eq!(names(&s).len(), 1, "{:?}", names(&s));
    check(&s, &Natives::default()).unwrap();

    symlink(&root, root.join("src/up")).unwrap();
    let e = Sources::new().add_path(&root).unwrap_err().to_string();
    assert!(e.contains("src/up") && e.contains("a loop"), "{e}");
    fs::remove_file(root.join("src/up")).unwrap();

    // A link to another kind of file, inside or out, or to nothing, is left alone.
    write(d.path(), "outside/notes.txt", "x");
    symlink(d.path().join("outside/notes.txt"), root.join("notes.txt")).unwrap();
    symlink(d.path().join("gone"), root.join("gone.md")).unwrap();
    let mut s = Sources::new();
    s.add_path(&root).unwrap();
    assert_eq!(names(&s).len(), 1, "{:?}", names(&s));
    symlink(d.path().join("gone.st"), root.join("gone.st")).unwrap();
    let e = Sources::new().add_path(&root).unwrap_err().to_string();
    assert!(e.contains("gone.st: it is a link to nothing"), "{e}");
    fs::remove_file(root.join("gone.st")).unwrap();

    write(d.path(), "outside/b.st", "PROGRAM b\nEND_PROGRAM\n");
    symlink(d.path().join("outside"), root.join("out")).unwrap();
    let e = Sources::new().add_path(&root).unwrap_err().to_string();
    assert!(e.contains("it links outside the folder"), "{e}");
}

#[test]
fn a_twincat_project_compiles_its_files_and_runs_its_task() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    write(
        root,
        "POUs/MAIN.TcPOU",
        &tcpou("PROGRAM MAIN\nVAR\n\tn : INT;\nEND_VAR", "n := n + 1;"),
    );
    write(root, "PlcTask.TcTTO", &task("PlcTask", 10000, "MAIN"));
    write(root, "Unused.TcPOU", "broken");
    write(
        root,
        "Plc.plcproj",
        "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<Project xmlns=\"http://schemas.microsoft.com/developer/msbuild/2003\">\n  <ItemGroup>\n    <Compile Include=\"pous\\Main.TcPOU\" />\n    <Compile Include=\"PlcTask.TcTTO\" />\n  </ItemGroup>\n</Project>\n",
    );
    let mut s = Sources::new();
    s.add_path(&root.join("Plc.plcproj")).unwrap();
    let checked = check(&s, &Natives::default()).unwrap();
    let c = checked.project.configuration.as_ref().unwrap();
    assert_eq!(c.programs.len(), 1);
    assert!(s.map.files().all(|(_, f)| f.from_twincat));
    let build = crate::build_file(&root.join("Plc.plcproj"), &crate::Select::Auto).unwrap();
    drop(build);

    // A missing file is an error at its <Compile> item; the others are still read.
    write(
        root,
        "Broken.plcproj",
        "<Project>\n  <ItemGroup>\n    <Compile Include=\"POUs\\MAIN.TcPOU\" />\n    <Compile Include=\"POUs\\Gone.TcPOU\" />\n  </ItemGroup>\n</Project>\n",
    );
    let mut s = Sources::new();
    s.add_path(&root.join("Broken.plcproj")).unwrap();
    let e = check(&s, &Natives::default()).err().unwrap().to_string();
    assert!(
        e.contains("Broken.plcproj:4:5: error[E056]: the project compiles POUs/Gone.TcPOU, which does not exist beside it"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1, "{e}");
}

#[test]
fn the_tasks_of_a_folder_are_one_configuration() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    write(root, "Fast.TcPOU", &tcpou("PROGRAM Fast", ";"));
    write(root, "Slow.TcPOU", &tcpou("PROGRAM Slow", ";"));
    write(root, "FastTask.TcTTO", &task("FastTask", 1000, "Fast"));
    write(root, "SlowTask.TcTTO", &task("SlowTask", 100000, "Slow"));
    let mut s = Sources::new();
    s.add_path(root).unwrap();
    let checked = check(&s, &Natives::default()).unwrap();
    let c = checked.project.configuration.as_ref().unwrap();
    assert_eq!(c.programs.len(), 2);
    let specs = crate::instances(&checked.project, &crate::Select::Auto, &s.map).unwrap();
    assert_eq!(specs.len(), 2);
}

#[test]
fn project_paths_are_recognised() {
    let d = tempfile::tempdir().unwrap();
    assert!(is_iec_path(d.path()));
    assert!(is_iec_path(Path::new("x.plcproj")));
    assert!(is_iec_path(Path::new("x.TcPOU")));
    assert!(!is_iec_path(Path::new("x.xml")));
    assert!(!is_iec_path(Path::new("x.pnml")));
}
