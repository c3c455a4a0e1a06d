//! Runs every test vector of `cases.rs` on the emulated Cortex-M33 and compares each result
//! with the host's (computed by the build script from the same code): a case passes when
//! every value is within its `max_ulps` of the host's. Prints one line per case and a final
//! `N passed, M failed`; the semihosting exit status is non-zero if any case failed.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use wiical_qemu_tests::cases::{ulp_distance, Out, CASES};
use wiical_qemu_tests::{expected, rt};

#[entry]
fn main() -> ! {
    hprintln!("running {} test vectors on the target", CASES.len());
    let (mut passed, mut failed) = (0u32, 0u32);
    for case in CASES {
        let mut out = Out::new();
        let ok = match ((case.run)(&mut out), expected(case.name)) {
            (Err(e), _) => {
                hprintln!("test {} ... FAILED: error on the target: {}", case.name, e);
                false
            }
            (Ok(()), None) => {
                hprintln!("test {} ... FAILED: no host values", case.name);
                false
            }
            (Ok(()), Some(want)) => check(case.name, case.max_ulps, out.as_slice(), want),
        };
        if ok {
            passed += 1;
        } else {
            failed += 1;
        }
    }
    hprintln!("{} passed, {} failed", passed, failed);
    rt::exit(failed == 0)
}

/// Compares the target's values with the host's; prints the case's line.
fn check(name: &str, max_ulps: u32, got: &[f32], want: &[u32]) -> bool {
    if got.len() != want.len() {
        hprintln!(
            "test {} ... FAILED: {} values on the target, {} on the host",
            name,
            got.len(),
            want.len()
        );
        return false;
    }
    let mut worst = 0u32;
    let mut worst_at = 0usize;
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        let d = ulp_distance(*g, f32::from_bits(*w));
        if d > worst {
            worst = d;
            worst_at = i;
        }
    }
    if worst <= max_ulps {
        let how = if worst == 0 { "bit-exact" } else { "within" };
        hprintln!(
            "test {} ... ok ({} values, {}, max {} ulp, limit {})",
            name,
            got.len(),
            how,
            worst,
            max_ulps
        );
        true
    } else {
        hprintln!(
            "test {} ... FAILED: value {} is {:e} on the target, {:e} on the host ({} ulp > {})",
            name,
            worst_at,
            got[worst_at],
            f32::from_bits(want[worst_at]),
            worst,
            max_ulps
        );
        false
    }
}
