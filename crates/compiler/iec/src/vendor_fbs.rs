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
//! RTC         VAR_INPUT IN : BOOL; PDT : DT   VAR_OUTPUT Q : BOOL; CDT : DT
//!             matiec's (Beremiz, OpenPLC) real-time clock, IEC 61131-3 1st edition: on
//!             a rising edge of IN the clock is set to PDT; while IN, CDT runs on from it;
//!             without IN, CDT is the PLC's clock. Q is IN. petriplc has no wall clock in
//!             a program: the PLC's clock is the scan clock counted from
//!             DT#1970-01-01-00:00:00 (deterministic in `petriplc sim`).
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
        if self.sig.name == "RTC" {
            // Slots: IN, PDT, Q, CDT, PREV_IN, OFFSET (nanoseconds, as DT and TIME are).
            let clock = ctx.now;
            let on = v.bool(0);
            if on && !v.bool(4) {
                v.set_int(5, v.int(1).wrapping_sub(clock));
            }
            let cdt = if on {
                clock.wrapping_add(v.int(5))
            } else {
                clock
            };
            v.set_int(3, cdt);
            v.set_bool(2, on);
            v.set_bool(4, on);
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

    #[test]
    fn rtc_is_set_on_the_rising_edge_and_runs_on() {
        let fbs = blocks(&["beremiz".into()]);
        let rtc = &*fbs[0];
        assert_eq!(rtc.signature().name, "RTC");
        let s = 1_000_000_000i64;
        let pdt = 1_700_000_000 * s;
        // IN, PDT, Q, CDT, PREV_IN, OFFSET.
        let mut v = [0, pdt as u64, 0, 0, 0, 0];
        let mut at = |inp: bool, now: i64| {
            v[0] = inp as u64;
            rtc.call(&mut v, &NativeCtx { now }).unwrap();
            (v[2], v[3] as i64)
        };
        assert_eq!(at(false, 5 * s), (0, 5 * s));
        assert_eq!(at(true, 6 * s), (1, pdt));
        assert_eq!(at(true, 8 * s), (1, pdt + 2 * s));
        assert_eq!(at(false, 9 * s), (0, 9 * s));
    }
}
