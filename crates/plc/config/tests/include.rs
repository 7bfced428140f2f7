//! `*include`: nesting, relative paths, read-once, circles and missing files.

use std::path::Path;

use petriplc_config::{parse_str, read_file, read_raw};

fn write(dir: &Path, name: &str, text: &str) {
    let path = dir.join(name);
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

#[test]
fn nested_includes_are_relative_to_the_including_file() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write(
        d,
        "a.conf",
        "[PLC]\nmodule m x\n*include sub/b.conf\npoint p \"P\" m\n",
    );
    write(
        d,
        "sub/b.conf",
        "[m]\nk = 1\n*include \"c d.conf\"\nj = 2\n",
    );
    write(d, "sub/c d.conf", "[PLC]\npoint q \"Q\" m at 0.3\n");
    let c = read_file(&d.join("a.conf")).unwrap_or_else(|e| panic!("{e}"));
    let points: Vec<String> = c
        .points
        .iter()
        .map(|p| format!("{} {}", p.name, p.origin))
        .collect();
    let a = d.join("a.conf").display().to_string();
    let cd = d.join("sub/c d.conf").display().to_string();
    // The include ends [m] nowhere: line 4 of a.conf is back in [PLC].
    assert_eq!(points, [format!("q {cd}:2"), format!("p {a}:4")]);
    let m = &c.modules[0];
    assert_eq!(m.settings["k"].value, "1");
    assert_eq!(m.settings["j"].value, "2");
}

#[test]
fn a_file_included_twice_is_read_once() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write(
        d,
        "a.conf",
        "*include b.conf\n*include c.conf\n*include b.conf\n",
    );
    write(d, "b.conf", "*include d.conf\n");
    write(d, "c.conf", "*include d.conf\n");
    write(d, "d.conf", "[PLC]\nmodule m x\n");
    let c = read_file(&d.join("a.conf")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(c.modules.len(), 1);
}

#[test]
fn circular_include_names_the_chain() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write(d, "a.conf", "[PLC]\n\n*include b.conf\n");
    write(d, "b.conf", "# b\n*include a.conf\n");
    let a = d.join("a.conf").display().to_string();
    let b = d.join("b.conf").display().to_string();
    let err = read_raw(&d.join("a.conf")).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "{b}:2: error[C002]: circular include: {a}:3 includes {b}, which includes {a}; \
             remove one of these `*include` lines"
        )
    );
}

#[test]
fn longer_circles_and_self_includes() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write(d, "a.conf", "*include b.conf\n");
    write(d, "b.conf", "\n*include sub/../c.conf\n");
    write(d, "c.conf", "*include ./a.conf\n");
    std::fs::create_dir(d.join("sub")).unwrap();
    let p = |n: &str| d.join(n).display().to_string();
    let err = read_file(&d.join("a.conf")).unwrap_err();
    // Names are shown as written (joined to the including file's directory); the circle is
    // found on the files themselves.
    assert_eq!(
        err.to_string(),
        format!(
            "{c}:1: error[C002]: circular include: {a}:1 includes {b}, which includes {c} \
             ({b}:2), which includes {a}; remove one of these `*include` lines",
            a = p("a.conf"),
            b = p("b.conf"),
            c = p("sub/../c.conf"),
        )
    );

    write(d, "self.conf", "[PLC]\n*include self.conf\n");
    let s = p("self.conf");
    assert_eq!(
        read_file(&d.join("self.conf")).unwrap_err().to_string(),
        format!(
            "{s}:2: error[C002]: circular include: {s}:2 includes {s}; remove one of these \
             `*include` lines"
        )
    );
}

#[test]
fn missing_include_names_file_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let err = parse_str(
        "[PLC]\nmodule m x\n*include nowhere.conf # gone\n",
        "main.conf",
        d,
    )
    .unwrap_err();
    assert_eq!(err.diagnostics.len(), 1);
    let diag = &err.diagnostics[0];
    assert_eq!(
        (diag.span.file.as_str(), diag.span.line, diag.code.0),
        ("main.conf", 3, "C001")
    );
    assert_eq!(
        diag.message,
        format!(
            "cannot read included file `{}`: no such file; check the \
             name (it is relative to the directory of `main.conf`)",
            d.join("nowhere.conf").display()
        )
    );
}

#[test]
fn unreadable_files() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::create_dir(d.join("dir.conf")).unwrap();
    let err = parse_str("*include dir.conf\n*include /dev/zero\n", "m.conf", d).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "m.conf:1: error[C001]: cannot read included file `{}`: it is a directory; name a configuration file\n\
             m.conf:2: error[C001]: cannot read included file `/dev/zero`: it is a device, not a regular file; name a configuration file",
            d.join("dir.conf").display()
        )
    );
    let missing = d.join("none.conf");
    assert_eq!(
        read_file(&missing).unwrap_err().to_string(),
        format!(
            "{}: error[C001]: cannot read the configuration: no such file",
            missing.display()
        )
    );
}

#[test]
fn sections_do_not_continue_into_an_included_file() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write(d, "a.conf", "[PLC]\n*include b.conf\n");
    write(d, "b.conf", "# no header\nmodule m x\nPLC: module n y\n");
    let b = d.join("b.conf").display().to_string();
    let err = read_file(&d.join("a.conf")).unwrap_err();
    assert_eq!(err.codes(), ["C005"]);
    assert_eq!(err.diagnostics[0].span.to_string(), format!("{b}:2"));
}
