//! The vendor libraries' function blocks as native blocks of the engine (their interfaces:
//! `petriplc_iec_sema::vendor::signature`), loaded with their library (`--lib codesys`).
//!
//! ```text
//! HYSTERESIS  VAR_INPUT IN, HIGH, LOW : INT   VAR_OUTPUT OUT : BOOL
//!             CODESYS Util: OUT becomes TRUE when IN falls below LOW and stays so until
//!             IN exceeds HIGH (then FALSE until IN falls below LOW again).
//! LIMITALARM  VAR_INPUT IN, HIGH, LOW : INT   VAR_OUTPUT O, U, IL : BOOL
//!             CODESYS Util: O when IN is above HIGH, else U when below LOW, else IL
//!             (exactly one of them is TRUE after a call).
//! ```

use petriplc_iec_sema::ir::NativeSig;
use petriplc_iec_sema::vendor;
use petriplc_iec_vm::native::{NativeCtx, NativeFb, Vars};

/// The native blocks of the function blocks `libs` load, in the order of
/// [`vendor::signatures`].
pub fn blocks(libs: &[String]) -> Vec<Box<dyn NativeFb>> {
    vendor::signatures(libs)
        .into_iter()
        .map(|sig| Box::new(Vendor { sig }) as Box<dyn NativeFb>)
        .collect()
}

struct Vendor {
    sig: NativeSig,
}

impl NativeFb for Vendor {
    fn signature(&self) -> NativeSig {
        self.sig.clone()
    }

    fn call(&self, vars: &mut [u64], _ctx: &NativeCtx) -> Result<(), String> {
        let mut v = Vars(vars);
        let (x, high, low) = (v.int(0), v.int(1), v.int(2));
        match self.sig.name.as_str() {
            "HYSTERESIS" => {
                if x < low {
                    v.set_bool(3, true);
                } else if x > high {
                    v.set_bool(3, false);
                }
            }
            "LIMITALARM" => {
                let over = x > high;
                let under = !over && x < low;
                v.set_bool(3, over);
                v.set_bool(4, under);
                v.set_bool(5, !over && !under);
            }
            other => return Err(format!("{other} is not a vendor function block")),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(fb: &dyn NativeFb, vars: &mut [u64], x: i64) -> Vec<u64> {
        vars[0] = x as u64;
        fb.call(vars, &NativeCtx { now: 0 }).unwrap();
        vars[3..].to_vec()
    }

    #[test]
    fn hysteresis_and_limit_alarm() {
        let fbs = blocks(&["codesys".into()]);
        let (hyst, alarm) = (&*fbs[0], &*fbs[1]);
        // HIGH 100, LOW 50.
        let mut h = [0, 100, 50, 0];
        let seen: Vec<u64> = [70, 40, 70, 101, 70, 49]
            .iter()
            .map(|&x| step(hyst, &mut h, x)[0])
            .collect();
        assert_eq!(seen, [0, 1, 1, 0, 0, 1]);
        let mut a = [0, 100, 50, 0, 0, 0];
        assert_eq!(step(alarm, &mut a, 101), [1, 0, 0]);
        assert_eq!(step(alarm, &mut a, 100), [0, 0, 1]);
        assert_eq!(step(alarm, &mut a, 50), [0, 0, 1]);
        assert_eq!(step(alarm, &mut a, -5), [0, 1, 0]);
    }
}
