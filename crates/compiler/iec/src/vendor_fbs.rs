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
//! GETCPUCOUNTER  VAR_OUTPUT cpuCntLoDW, cpuCntHiDW : DWORD
//!             Tc2_System: the CPU counter in 100 ns units, low and high 32 bits. Here the
//!             scan's clock (the one TON uses) in 100 ns: deterministic in `petriplc sim`,
//!             the same for every call in one scan.
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

    fn call(&self, vars: &mut [u64], ctx: &NativeCtx) -> Result<(), String> {
        let mut v = Vars(vars);
        if self.sig.name == "GETCPUCOUNTER" {
            let ticks = (ctx.now.max(0) / 100) as u64;
            v.set_int(0, (ticks & 0xFFFF_FFFF) as i64);
            v.set_int(1, (ticks >> 32) as i64);
            return Ok(());
        }
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

    #[test]
    fn cpu_counter_is_the_scan_clock_in_100_ns() {
        let fbs = blocks(&["twincat".into()]);
        let counter = fbs
            .iter()
            .find(|f| f.signature().name == "GETCPUCOUNTER")
            .unwrap();
        let mut v = [0u64; 2];
        // 500 s: 5e9 ticks of 100 ns, past 32 bits.
        counter
            .call(
                &mut v,
                &NativeCtx {
                    now: 500_000_000_000,
                },
            )
            .unwrap();
        assert_eq!((v[1] << 32) | v[0], 5_000_000_000);
        assert_eq!(v[1], 1);
    }
}
