//! A C module with `location = isolate`: `plc_init` forks the proxy in a single-threaded C
//! process, values flow both ways through `plc_update` while the module process never maps
//! the global map, ownership is still enforced, and a process that already has threads is
//! refused.
//!
//! The library is found as in `c_module.rs`: the cdylib built next to this test binary.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::TestPlc;

const MODULE: &str = r#"
#include <petriplc.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

static void *idle(void *arg) { for (;;) pause(); return arg; }

/* 1 if this process maps the PLC's image. */
static int maps_image(void) {
    char line[4096];
    int found = 0;
    FILE *f = fopen("/proc/self/maps", "r");
    if (!f) return -1;
    while (fgets(line, sizeof line, f))
        if (strstr(line, "/dev/shm/petriplc-") && strstr(line, "-image")) found = 1;
    fclose(f);
    return found;
}

int main(int argc, char **argv) {
    if (argc > 1 && strcmp(argv[1], "threaded") == 0) {
        pthread_t t;
        pthread_create(&t, NULL, idle, NULL);
        int rc = plc_init(NULL, &argc, argv);
        printf("init %d: %s\n", rc, plc_last_error());
        return rc == PLC_ERR_CONFIG ? 0 : 1;
    }
    if (plc_init(NULL, &argc, argv) != PLC_OK) {
        fprintf(stderr, "%s\n", plc_last_error());
        return 1;
    }
    plc_pt_t in = plc_pt_by_name("to_iso"), out = plc_pt_by_name("from_iso");
    if (plc_update() != PLC_OK) return 2;
    uint32_t v = plc_get(in);
    if (plc_set(in, 1) != PLC_ERR_NOT_OWNER) return 3;
    if (plc_set(out, v + 1) != PLC_OK) return 4;
    if (plc_update() != PLC_OK) return 5;
    printf("maps image: %d\n", maps_image());
    plc_close();
    return 0;
}
"#;

const CONFIG: &str = "\
[PLC]
module iso test
module peer test
point to_iso \"\" peer u16
point from_iso \"\" iso u16

[iso]
location = isolate
";

fn build(dir: &Path) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let lib = exe.parent().unwrap().join("libpetriplc.so");
    assert!(lib.exists(), "{} is missing", lib.display());
    std::fs::copy(&lib, dir.join("libpetriplc.so")).unwrap();
    let source = dir.join("iso.c");
    std::fs::write(&source, MODULE).unwrap();
    let bin = dir.join("iso");
    let include = Path::new(env!("CARGO_MANIFEST_DIR")).join("include");
    let out = Command::new("cc")
        .args([
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-D_POSIX_C_SOURCE=200809L",
            "-I",
        ])
        .arg(&include)
        .arg(&source)
        .arg("-L")
        .arg(dir)
        .args(["-lpetriplc", "-lpthread", "-o"])
        .arg(&bin)
        .output()
        .expect("a C compiler `cc` is needed");
    assert!(
        out.status.success(),
        "cc failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    bin
}

fn run(plc: &TestPlc, bin: &Path, args: &[&str]) -> Output {
    let out = Command::new(bin)
        .args(args)
        .env("PETRIPLC_CONFIG", &plc.config_path)
        .env("PETRIPLC_MODULE", "iso")
        .env("PETRIPLC_PLC_ID", &plc.id)
        .env("LD_LIBRARY_PATH", plc.dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "the C module failed ({}):\n{}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

#[test]
fn an_isolated_c_module_updates_through_its_proxy() {
    let plc = TestPlc::start("isolate", CONFIG);
    let bin = build(plc.dir.path());
    let mut peer = plc.module_map("peer");
    let (to_iso, from_iso) = (
        peer.handle("to_iso").unwrap(),
        peer.handle("from_iso").unwrap(),
    );
    peer.set_u32(&to_iso, 41).unwrap();
    peer.update(&plc.global);

    let out = run(&plc, &bin, &[]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("maps image: 0"), "{stdout}");
    peer.update(&plc.global);
    assert_eq!(
        peer.get_u32(&from_iso),
        42,
        "the module's value, through the proxy"
    );
    assert_eq!(
        peer.get_u32(&to_iso),
        41,
        "the module could not set the peer's point"
    );
}

#[test]
fn plc_init_refuses_isolation_once_the_process_has_threads() {
    let plc = TestPlc::start("isolate-threads", CONFIG);
    let bin = build(plc.dir.path());
    let out = run(&plc, &bin, &["threaded"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("isolate") && stdout.contains("2 threads"),
        "{stdout}"
    );
}
