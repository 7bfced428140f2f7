//! The `extern "C"` functions of `petriplc.h`: they check and convert C's pointers, run the
//! safe code of `session` under `catch_unwind` (a panic must never unwind into C), and turn
//! every failure into a return code plus a thread-local message for `plc_last_error`.

// C hands us raw pointers and the symbols must keep their C names: this module is the only
// place in the crate where `unsafe` is allowed, and each use carries a SAFETY comment.
#![allow(unsafe_code)]

use std::any::Any;
use std::cell::RefCell;
use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_int};
use std::panic::{catch_unwind, AssertUnwindSafe};

use crate::session::{self, PlcPt};
use crate::{args, Error, PLC_ERR_ARGS, PLC_ERR_INTERNAL, PLC_OK};

thread_local! {
    /// Owned here so the pointer `plc_last_error` returns stays valid until this thread's
    /// next failing call.
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_last_error(message: &str) {
    // A NUL would cut the message short in C; no message of ours has one, but a point or
    // file name from C could.
    let text = CString::new(message.replace('\0', "\u{FFFD}")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = text);
}

fn panic_message(payload: &(dyn Any + Send)) -> String {
    let what = payload
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("a panic without a message");
    format!("internal error in libpetriplc (please report it): {what}")
}

/// Runs `f`, returning its value, or `on_error(code)` after recording the message.
fn guarded<T>(on_error: impl FnOnce(c_int) -> T, f: impl FnOnce() -> Result<T, Error>) -> T {
    let e = match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(v)) => return v,
        Ok(Err(e)) => e,
        Err(payload) => Error::new(PLC_ERR_INTERNAL, panic_message(&*payload)),
    };
    set_last_error(&e.message);
    on_error(e.code)
}

/// For functions returning a status code.
fn status(f: impl FnOnce() -> Result<c_int, Error>) -> c_int {
    guarded(|code| code, f)
}

fn c_str<'a>(p: *const c_char, what: &str) -> Result<&'a str, Error> {
    if p.is_null() {
        return Err(Error::new(PLC_ERR_ARGS, format!("{what} is NULL")));
    }
    // SAFETY: the header requires a NUL-terminated string that stays valid for the call;
    // the borrow does not outlive the call (callers copy what they keep).
    let s = unsafe { CStr::from_ptr(p) };
    s.to_str()
        .map_err(|_| Error::new(PLC_ERR_ARGS, format!("{what} is not valid UTF-8")))
}

/// Attaches the process to a running PLC; see `petriplc.h`.
///
/// # Safety
/// `module` is NULL or a NUL-terminated string; `argc` is NULL or points to the count of
/// `argv`, which then holds that many NUL-terminated strings followed by a NULL slot
/// (`main`'s arguments are).
#[no_mangle]
pub unsafe extern "C" fn plc_init(
    module: *const c_char,
    argc: *mut c_int,
    argv: *mut *mut c_char,
) -> c_int {
    status(|| {
        session::check_detached()?;
        let default_module = if module.is_null() {
            None
        } else {
            Some(c_str(module, "the module name")?)
        };
        let count = if argc.is_null() {
            0
        } else {
            // SAFETY: a non-NULL `argc` points to a valid int (contract above).
            usize::try_from(unsafe { *argc }).unwrap_or(0)
        };
        if count > 0 && argv.is_null() {
            return Err(Error::new(PLC_ERR_ARGS, "argc is not 0 but argv is NULL"));
        }
        let mut list: Vec<&[u8]> = Vec::with_capacity(count);
        for i in 0..count {
            // SAFETY: `argv` has `count` entries (contract above).
            let p = unsafe { *argv.add(i) };
            if p.is_null() {
                return Err(Error::new(PLC_ERR_ARGS, format!("argv[{i}] is NULL")));
            }
            // SAFETY: each entry is a NUL-terminated string valid for the call.
            list.push(unsafe { CStr::from_ptr(p) }.to_bytes());
        }
        let parsed = args::parse(&list)?;
        let target = args::resolve(&parsed, |name: &str| std::env::var_os(name), default_module)?;
        session::init(target)?;
        if count > 0 {
            // Only once attached: a failed plc_init leaves argv as it was.
            for (to, &from) in parsed.keep.iter().enumerate() {
                // SAFETY: `to <= from < count`, both in bounds; the strings are only
                // moved between slots, never freed.
                unsafe { *argv.add(to) = *argv.add(from) };
            }
            let kept = parsed.keep.len();
            // SAFETY: `kept <= count`, and argv has count + 1 slots (argv[argc] is NULL).
            unsafe {
                *argv.add(kept) = std::ptr::null_mut();
                *argc = kept as c_int;
            }
        }
        Ok(PLC_OK)
    })
}

/// Detaches from the PLC; see `petriplc.h`.
#[no_mangle]
pub extern "C" fn plc_close() -> c_int {
    status(|| session::close().map(|()| PLC_OK))
}

/// The handle of point `name`, or an invalid handle; see `petriplc.h`.
///
/// # Safety
/// `name` is NULL or a NUL-terminated string.
#[no_mangle]
pub unsafe extern "C" fn plc_pt_by_name(name: *const c_char) -> PlcPt {
    guarded(
        |_| PlcPt::INVALID,
        || session::pt_by_name(c_str(name, "the point name")?),
    )
}

/// 1 if `pt` is a handle of the current `plc_init`, else 0.
#[no_mangle]
pub extern "C" fn plc_pt_valid(pt: PlcPt) -> c_int {
    guarded(|_| 0, || Ok(c_int::from(session::pt_valid(pt))))
}

/// The point's raw bits (0 on error); see `petriplc.h`.
#[no_mangle]
pub extern "C" fn plc_get(pt: PlcPt) -> u32 {
    guarded(|_| 0, || session::get(pt))
}

#[no_mangle]
pub extern "C" fn plc_set(pt: PlcPt, bits: u32) -> c_int {
    status(|| session::set(pt, bits).map(|()| PLC_OK))
}

#[no_mangle]
pub extern "C" fn plc_get_i32(pt: PlcPt) -> i32 {
    guarded(|_| 0, || session::get_i32(pt))
}

#[no_mangle]
pub extern "C" fn plc_set_i32(pt: PlcPt, value: i32) -> c_int {
    status(|| session::set_i32(pt, value).map(|()| PLC_OK))
}

#[no_mangle]
pub extern "C" fn plc_get_f32(pt: PlcPt) -> f32 {
    guarded(|_| 0.0, || session::get_f32(pt))
}

#[no_mangle]
pub extern "C" fn plc_set_f32(pt: PlcPt, value: f32) -> c_int {
    status(|| session::set_f32(pt, value).map(|()| PLC_OK))
}

#[no_mangle]
pub extern "C" fn plc_update() -> c_int {
    status(|| session::update().map(|()| PLC_OK))
}

#[no_mangle]
pub extern "C" fn plc_scan_beg() -> c_int {
    status(session::scan_beg)
}

#[no_mangle]
pub extern "C" fn plc_scan_end() -> c_int {
    status(session::scan_end)
}

/// Synchronises on a named transition; see `petriplc.h`.
///
/// # Safety
/// `transition` is NULL or a NUL-terminated string.
#[no_mangle]
pub unsafe extern "C" fn plc_synch(transition: *const c_char) -> c_int {
    status(|| session::synch(c_str(transition, "the transition name")?))
}

/// 1 if the PLC is stopping, 0 if not, a negative code on error.
#[no_mangle]
pub extern "C" fn plc_stopping() -> c_int {
    status(|| session::stopping().map(c_int::from))
}

/// The message of this thread's last failed call ("" if none failed).
#[no_mangle]
pub extern "C" fn plc_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// A static description of a return code.
#[no_mangle]
pub extern "C" fn plc_strerror(code: c_int) -> *const c_char {
    let text: &'static CStr = match code {
        crate::PLC_OK => c"success",
        crate::PLC_STOPPING => c"the PLC is stopping",
        crate::PLC_ERR_NOT_INIT => c"not attached to a PLC (plc_init not called)",
        crate::PLC_ERR_ALREADY_INIT => c"plc_init was already called",
        crate::PLC_ERR_ARGS => c"bad argument",
        crate::PLC_ERR_CONFIG => c"bad configuration",
        crate::PLC_ERR_MODULE => c"module not declared in the configuration",
        crate::PLC_ERR_NOT_RUNNING => c"no such PLC is running",
        crate::PLC_ERR_MISMATCH => c"the running PLC has another configuration",
        crate::PLC_ERR_POINT => c"invalid point handle or unknown name",
        crate::PLC_ERR_NOT_OWNER => c"the point belongs to another module",
        crate::PLC_ERR_VALUE => c"value out of range or of the wrong kind",
        crate::PLC_ERR_OS => c"operating system error",
        crate::PLC_ERR_INTERNAL => c"internal error",
        _ => c"unknown return code",
    };
    text.as_ptr()
}
