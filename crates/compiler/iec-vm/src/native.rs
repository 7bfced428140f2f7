//! Function blocks implemented in Rust: the extension point for blocks that programs call
//! like any function block (the standard timers, edge detectors, counters and bistables here;
//! DSP blocks such as PID or filters from their own crate).
//!
//! A native block declares its variables ([`NativeSig`]: inputs, outputs and the state it
//! keeps, all elementary) and gets, at each call, the instance's slots in that order and the
//! scan time. Its state lives in those slots, so instances are copied, retained and
//! restored like any other variables.

use petriplc_iec_sema::ir::{NativeSig, NativeVarKind};
use petriplc_iec_sema::types::Elem;
use petriplc_iec_syntax::Dialect;

/// What a native block sees besides its variables.
#[derive(Clone, Copy, Debug)]
pub struct NativeCtx {
    /// The scan's time in nanoseconds (the same for every call in a scan).
    pub now: i64,
}

/// A function block implemented in Rust.
pub trait NativeFb: Send + Sync {
    /// The interface programs see; its name is the function block's type name.
    fn signature(&self) -> NativeSig;

    /// One call: `vars` holds the instance's variables in signature order (BOOL 0/1,
    /// integers sign- or zero-extended, reals as f64 bits, TIME as i64 nanoseconds). An
    /// error fails the program with its message.
    fn call(&self, vars: &mut [u64], ctx: &NativeCtx) -> Result<(), String>;
}

/// Typed access to a native block's slots.
pub struct Vars<'a>(pub &'a mut [u64]);

impl Vars<'_> {
    pub fn bool(&self, i: usize) -> bool {
        self.0[i] != 0
    }
    pub fn set_bool(&mut self, i: usize, v: bool) {
        self.0[i] = v as u64;
    }
    pub fn int(&self, i: usize) -> i64 {
        self.0[i] as i64
    }
    pub fn set_int(&mut self, i: usize, v: i64) {
        self.0[i] = v as u64;
    }
    pub fn real(&self, i: usize) -> f64 {
        f64::from_bits(self.0[i])
    }
    pub fn set_real(&mut self, i: usize, v: f64) {
        self.0[i] = v.to_bits();
    }
}

/// The standard function blocks, in the order of [`petriplc_iec_sema::standard_fbs`].
pub fn standard() -> Vec<Box<dyn NativeFb>> {
    standard_in(Dialect::Iec)
}

/// The standard function blocks with the input names of `dialect` (CODESYS's counters'
/// `RESET` and `LOAD`: [`petriplc_iec_sema::standard_fbs_in`]); they run the same.
pub fn standard_in(dialect: Dialect) -> Vec<Box<dyn NativeFb>> {
    petriplc_iec_sema::standard_fbs_in(dialect)
        .into_iter()
        .map(|sig| Box::new(Standard { sig }) as Box<dyn NativeFb>)
        .collect()
}

struct Standard {
    sig: NativeSig,
}

impl Standard {
    /// The range of the counter value (CV) of a counter block.
    fn cv_range(&self) -> (i128, i128) {
        self.sig
            .vars
            .iter()
            .find(|v| v.name == "CV")
            .map_or((0, 0), |v| v.ty.range())
    }
}

fn cv_get(v: &Vars, i: usize, ty: Elem) -> i128 {
    if matches!(ty, Elem::Ulint) {
        v.0[i] as i128
    } else {
        v.0[i] as i64 as i128
    }
}

impl NativeFb for Standard {
    fn signature(&self) -> NativeSig {
        self.sig.clone()
    }

    fn call(&self, slots: &mut [u64], ctx: &NativeCtx) -> Result<(), String> {
        let mut v = Vars(slots);
        let now = ctx.now;
        let name = self.sig.name.as_str();
        let base = name.split('_').next().unwrap_or(name);
        match (name, base) {
            ("TON", _) => {
                // IN, PT, Q, ET, running, start
                let pt = v.int(1).max(0);
                if v.bool(0) {
                    if !v.bool(4) {
                        v.set_bool(4, true);
                        v.set_int(5, now);
                    }
                    // Once elapsed, Q and ET hold until IN falls, whatever PT becomes,
                    // as matiec's and CODESYS's TON (corpus 430_fb_ton_pt_change.st).
                    if !v.bool(2) {
                        let et = now.saturating_sub(v.int(5));
                        if et >= pt {
                            v.set_bool(2, true);
                            v.set_int(3, pt);
                        } else {
                            v.set_int(3, et);
                        }
                    }
                } else {
                    v.set_bool(4, false);
                    v.set_bool(2, false);
                    v.set_int(3, 0);
                }
            }
            ("TOF", _) => {
                // IN, PT, Q, ET, running, start, prev
                let pt = v.int(1).max(0);
                let input = v.bool(0);
                if input {
                    v.set_bool(2, true);
                    v.set_int(3, 0);
                    v.set_bool(4, false);
                } else {
                    if v.bool(6) {
                        // Falling edge: start timing.
                        v.set_bool(4, true);
                        v.set_int(5, now);
                    }
                    if v.bool(4) {
                        let et = now.saturating_sub(v.int(5));
                        if et >= pt {
                            v.set_bool(2, false);
                            v.set_int(3, pt);
                            v.set_bool(4, false);
                        } else {
                            v.set_bool(2, true);
                            v.set_int(3, et);
                        }
                    }
                }
                v.set_bool(6, input);
            }
            ("TP", _) => {
                // IN, PT, Q, ET, running, start, prev
                let pt = v.int(1).max(0);
                let input = v.bool(0);
                if !v.bool(4) && input && !v.bool(6) && v.int(3) == 0 {
                    v.set_bool(4, true);
                    v.set_int(5, now);
                }
                if v.bool(4) {
                    let et = now.saturating_sub(v.int(5));
                    if et >= pt {
                        v.set_bool(4, false);
                        v.set_bool(2, false);
                        v.set_int(3, pt);
                    } else {
                        v.set_bool(2, true);
                        v.set_int(3, et);
                    }
                }
                if !v.bool(4) && !input {
                    v.set_int(3, 0);
                }
                v.set_bool(6, input);
            }
            ("R_TRIG", _) => {
                let clk = v.bool(0);
                v.set_bool(1, clk && !v.bool(2));
                v.set_bool(2, clk);
            }
            ("F_TRIG", _) => {
                // The standard's body: Q := NOT CLK AND NOT M; M := NOT CLK;
                let clk = v.bool(0);
                v.set_bool(1, !clk && !v.bool(2));
                v.set_bool(2, !clk);
            }
            (_, "CTU") => {
                // CU, R, PV, Q, CV, prev_cu
                let ty = self.sig.vars[4].ty;
                let (_, max) = self.cv_range();
                let edge = v.bool(0) && !v.bool(5);
                v.set_bool(5, v.bool(0));
                let mut cv = cv_get(&v, 4, ty);
                if v.bool(1) {
                    cv = 0;
                } else if edge && cv < max {
                    cv += 1;
                }
                v.0[4] = cv as i64 as u64;
                let pv = cv_get(&v, 2, ty);
                v.set_bool(3, cv >= pv);
            }
            (_, "CTD") => {
                // CD, LD, PV, Q, CV, prev_cd
                let ty = self.sig.vars[4].ty;
                let (min, _) = self.cv_range();
                let edge = v.bool(0) && !v.bool(5);
                v.set_bool(5, v.bool(0));
                let mut cv = cv_get(&v, 4, ty);
                if v.bool(1) {
                    cv = cv_get(&v, 2, ty);
                } else if edge && cv > min {
                    cv -= 1;
                }
                v.0[4] = cv as i64 as u64;
                v.set_bool(3, cv <= 0);
            }
            (_, "CTUD") => {
                // CU, CD, R, LD, PV, QU, QD, CV, prev_cu, prev_cd
                let ty = self.sig.vars[7].ty;
                let (min, max) = self.cv_range();
                let up = v.bool(0) && !v.bool(8);
                let down = v.bool(1) && !v.bool(9);
                v.set_bool(8, v.bool(0));
                v.set_bool(9, v.bool(1));
                let mut cv = cv_get(&v, 7, ty);
                if v.bool(2) {
                    cv = 0;
                } else if v.bool(3) {
                    cv = cv_get(&v, 4, ty);
                } else if !(up && down) {
                    if up && cv < max {
                        cv += 1;
                    } else if down && cv > min {
                        cv -= 1;
                    }
                }
                v.0[7] = cv as i64 as u64;
                let pv = cv_get(&v, 4, ty);
                v.set_bool(5, cv >= pv);
                v.set_bool(6, cv <= 0);
            }
            ("SR", _) => {
                let q = v.bool(0) || (!v.bool(1) && v.bool(2));
                v.set_bool(2, q);
            }
            ("RS", _) => {
                let q = !v.bool(1) && (v.bool(0) || v.bool(2));
                v.set_bool(2, q);
            }
            _ => return Err(format!("no implementation for function block {name}")),
        }
        Ok(())
    }
}

/// Checks that implementations match the signatures the checker was given.
pub fn matches(impls: &[Box<dyn NativeFb>], sigs: &[NativeSig]) -> bool {
    impls.len() == sigs.len() && impls.iter().zip(sigs).all(|(i, s)| i.signature() == *s)
}

/// Initial slots of a native instance.
pub fn initial_slots(sig: &NativeSig) -> Vec<u64> {
    sig.vars
        .iter()
        .map(|v| crate::ext::put_value(&v.init, v.ty))
        .collect()
}

/// Whether a native variable is visible to programs.
pub fn is_public(kind: NativeVarKind) -> bool {
    kind != NativeVarKind::State
}
