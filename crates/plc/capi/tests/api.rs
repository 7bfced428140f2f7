//! The C ABI called from Rust through the rlib: attaching, argv handling, point access by
//! kind, ownership and range errors, scans, stopping, stale handles, and the messages of
//! `plc_last_error`.

// These tests call the `extern "C"` functions as C would, with raw pointers.
#![allow(unsafe_code)]

mod common;

use std::ffi::{c_char, c_int, CStr, CString};
use std::sync::{Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

use common::TestPlc;
use petriplc::*;

/// The library holds one attachment per process: tests that attach take turns.
fn serial() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    let guard = LOCK.lock().unwrap_or_else(PoisonError::into_inner);
    // A test that failed while attached must not fail the next one too.
    plc_close();
    guard
}

fn last_error() -> String {
    // SAFETY: plc_last_error never returns NULL, and the string lives until this thread's
    // next failing call; it is copied at once.
    unsafe { CStr::from_ptr(plc_last_error()) }
        .to_string_lossy()
        .into_owned()
}

/// Calls plc_init with `args` as argv; returns the code and the argv left to the module.
fn init(module: Option<&str>, args: &[&str]) -> (c_int, Vec<String>) {
    let owned: Vec<CString> = args.iter().map(|a| CString::new(*a).unwrap()).collect();
    let mut argv: Vec<*mut c_char> = owned.iter().map(|a| a.as_ptr().cast_mut()).collect();
    argv.push(std::ptr::null_mut());
    let mut argc = args.len() as c_int;
    let module = module.map(|m| CString::new(m).unwrap());
    let module_ptr = module.as_ref().map_or(std::ptr::null(), |m| m.as_ptr());
    // SAFETY: argv holds argc valid strings and a NULL slot, all alive for the call.
    let rc = unsafe { plc_init(module_ptr, &mut argc, argv.as_mut_ptr()) };
    assert!(argv[argc as usize].is_null());
    let left = argv[..argc as usize]
        .iter()
        // SAFETY: plc_init only reorders the strings we passed.
        .map(|&p| unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned())
        .collect();
    (rc, left)
}

fn pt(name: &str) -> PlcPt {
    let name = CString::new(name).unwrap();
    // SAFETY: a valid NUL-terminated string.
    unsafe { plc_pt_by_name(name.as_ptr()) }
}

const CONFIG: &str = "\
[PLC]
module m test
module other test
point flag \"\" m
point count \"\" m u8
point level \"\" m i12
point temp \"\" m f
point theirs \"\" other u16 init 7
";

fn options(plc: &TestPlc, module: &str) -> [String; 3] {
    [
        format!("--PLCconfig={}", plc.config_path.display()),
        format!("--PLCmodule={module}"),
        format!("--PLCplc_id={}", plc.id),
    ]
}

#[test]
fn attach_get_set_update_and_close() {
    let _serial = serial();
    let plc = TestPlc::start("api", CONFIG);
    let [config, module, id] = options(&plc, "m");
    let (rc, left) = init(
        None,
        &[
            "prog",
            "-x",
            &config,
            "keep",
            &module,
            &id,
            "--",
            "--PLCnot-ours",
        ],
    );
    assert_eq!(rc, PLC_OK, "{}", last_error());
    assert_eq!(left, ["prog", "-x", "keep", "--", "--PLCnot-ours"]);
    assert_eq!(init(Some("m"), &[]).0, PLC_ERR_ALREADY_INIT);

    let (flag, count, level, temp, theirs) = (
        pt("flag"),
        pt("count"),
        pt("level"),
        pt("temp"),
        pt("theirs"),
    );
    for p in [flag, count, level, temp, theirs] {
        assert_eq!(plc_pt_valid(p), 1);
    }
    // Before the first update the map holds the init values, even of others' points;
    // plc_update brings in what their owners wrote since.
    let mut observer = plc.module_map("other");
    let h = |name| observer.handle(name).unwrap();
    let (o_theirs, o_count, o_level, o_temp) = (h("theirs"), h("count"), h("level"), h("temp"));
    observer.set_u32(&o_theirs, 9).unwrap();
    observer.update(&plc.global);
    assert_eq!(plc_get(theirs), 7);
    assert_eq!(plc_update(), PLC_OK);
    assert_eq!(plc_get(theirs), 9);

    assert_eq!(plc_set(flag, 1), PLC_OK);
    assert_eq!(plc_set(count, 200), PLC_OK);
    assert_eq!(plc_set_i32(level, -5), PLC_OK);
    assert_eq!(plc_get(level), 0xffb, "raw bits of -5 in 12 bits");
    assert_eq!(plc_get_i32(level), -5);
    assert_eq!(
        plc_set(level, 0x800),
        PLC_OK,
        "raw bits: the most negative i12"
    );
    assert_eq!(plc_get_i32(level), -2048);
    assert_eq!(plc_set_f32(temp, 21.5), PLC_OK);
    assert_eq!(plc_get(temp), 21.5f32.to_bits());
    assert_eq!(plc_get_f32(count), 200.0);

    // Nothing reaches the PLC before plc_update.
    observer.update(&plc.global);
    assert_eq!(observer.get_u32(&o_count), 0);
    assert_eq!(plc_update(), PLC_OK);
    observer.update(&plc.global);
    assert_eq!(observer.get_u32(&o_count), 200);
    assert_eq!(observer.get_i32(&o_level), -2048);
    assert_eq!(observer.get_f32(&o_temp), 21.5);

    // Errors: the code, and a message that names the problem.
    assert_eq!(plc_set(theirs, 1), PLC_ERR_NOT_OWNER);
    assert!(
        last_error().contains("owned by `other`"),
        "{}",
        last_error()
    );
    assert_eq!(plc_set(count, 256), PLC_ERR_VALUE);
    assert!(last_error().contains("cannot hold 256"), "{}", last_error());
    assert_eq!(plc_set(level, 0x1000), PLC_ERR_VALUE);
    assert_eq!(plc_set_f32(count, 1.0), PLC_ERR_VALUE);
    assert_eq!(plc_set_i32(temp, 1), PLC_ERR_VALUE);
    let bad = pt("flga");
    assert_eq!(plc_pt_valid(bad), 0);
    assert_eq!(bad, PlcPt::INVALID);
    assert!(
        last_error().contains("no point named `flga`"),
        "{}",
        last_error()
    );
    assert!(last_error().contains("`flag`"), "{}", last_error());
    assert_eq!(plc_get(bad), 0);
    assert_eq!(plc_set(bad, 1), PLC_ERR_POINT);
    // SAFETY: NULL is allowed and refused.
    let null = unsafe { plc_pt_by_name(std::ptr::null()) };
    assert_eq!(null, PlcPt::INVALID);
    assert!(last_error().contains("NULL"), "{}", last_error());
    let t = CString::new("nope").unwrap();
    // SAFETY: a valid NUL-terminated string.
    assert_eq!(unsafe { plc_synch(t.as_ptr()) }, PLC_ERR_POINT);

    // Without synch rules both scan transitions are NULL: scans run at once.
    assert_eq!(plc_stopping(), 0);
    for _ in 0..3 {
        assert_eq!(plc_scan_beg(), PLC_OK);
        assert_eq!(plc_scan_end(), PLC_OK);
    }
    plc.synch.stop();
    assert_eq!(plc_stopping(), 1);
    assert_eq!(plc_scan_beg(), PLC_STOPPING);
    assert_eq!(plc_scan_end(), PLC_STOPPING);

    assert_eq!(plc_close(), PLC_OK);
    assert_eq!(plc_close(), PLC_ERR_NOT_INIT);
    assert_eq!(plc_set(flag, 0), PLC_ERR_NOT_INIT);
    assert!(
        last_error().contains("call plc_init first"),
        "{}",
        last_error()
    );
    assert_eq!(plc_scan_beg(), PLC_ERR_NOT_INIT);

    // A handle from before a new plc_init is refused, not misread.
    let (rc, _) = init(Some("m"), &["prog", &config, &id]);
    assert_eq!(rc, PLC_OK, "{}", last_error());
    assert_eq!(plc_pt_valid(flag), 0);
    assert_eq!(plc_set(flag, 1), PLC_ERR_POINT);
    assert!(
        last_error().contains("stale point handle"),
        "{}",
        last_error()
    );
    assert_eq!(plc_pt_valid(pt("flag")), 1);
    assert_eq!(plc_close(), PLC_OK);
}

#[test]
fn init_without_a_running_plc_says_how_to_start_one() {
    let _serial = serial();
    let plc = TestPlc::start("absent", CONFIG);
    let config = format!("--PLCconfig={}", plc.config_path.display());
    let args = [
        "prog",
        config.as_str(),
        "--PLCplc_id=capi-no-such-plc",
        "mine",
    ];
    let (rc, left) = init(Some("m"), &args);
    assert_eq!(rc, PLC_ERR_NOT_RUNNING);
    assert_eq!(left, args, "a failed plc_init leaves argv alone");
    let message = last_error();
    assert!(
        message.contains("no PLC with id `capi-no-such-plc`"),
        "{message}"
    );
    assert!(message.contains("petriplc run"), "{message}");
    assert!(message.contains("--PLCplc_id=ID"), "{message}");
    assert_eq!(plc_update(), PLC_ERR_NOT_INIT);

    // A module the configuration does not declare.
    let [config, _, id] = options(&plc, "m");
    assert_eq!(init(Some("ghost"), &["p", &config, &id]).0, PLC_ERR_MODULE);
    assert!(
        last_error().contains("declared: m, other"),
        "{}",
        last_error()
    );
    // A configuration that does not match the running PLC's points.
    let changed = plc.dir.path().join("changed.conf");
    std::fs::write(&changed, CONFIG.replace("u8", "u9")).unwrap();
    let changed = format!("--PLCconfig={}", changed.display());
    assert_eq!(init(Some("m"), &["p", &changed, &id]).0, PLC_ERR_MISMATCH);
    // An unreadable configuration.
    assert_eq!(
        init(Some("m"), &["p", "--PLCconfig=/nonexistent.conf", &id]).0,
        PLC_ERR_CONFIG
    );
    assert!(
        last_error().contains("/nonexistent.conf"),
        "{}",
        last_error()
    );
}

#[test]
fn scans_keep_the_module_scan_period() {
    let _serial = serial();
    let plc = TestPlc::start("period", &format!("{CONFIG}[m]\nscan_period = 0.01\n"));
    let [config, module, id] = options(&plc, "m");
    assert_eq!(init(None, &["p", &config, &module, &id]).0, PLC_OK);
    let started = Instant::now();
    for _ in 0..6 {
        assert_eq!(plc_scan_beg(), PLC_OK);
        assert_eq!(plc_scan_end(), PLC_OK);
    }
    // Scan 0 starts at once (t0); scan 5 not before t0 + 5 periods.
    assert!(started.elapsed() >= Duration::from_millis(50));
    plc.synch.stop();
    assert_eq!(plc_scan_beg(), PLC_STOPPING);
    assert_eq!(plc_close(), PLC_OK);
}

#[test]
fn return_codes_have_descriptions() {
    for code in -12..=1 {
        // SAFETY: plc_strerror returns a static string.
        let text = unsafe { CStr::from_ptr(plc_strerror(code)) };
        assert!(!text.is_empty());
        assert_ne!(text.to_str().unwrap(), "unknown return code", "{code}");
    }
}
