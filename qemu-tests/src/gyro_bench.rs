//! Instruction counts of the gyro's per-sample correction (`wiical_core::gyro_correct`) on
//! the emulated Cortex-M33: linear, and with the g-sensitivity (the accelerometer's reading
//! as a second input). Same method as the other rows (a loop with the operation minus the
//! loop without it, SysTick ticks times instructions per tick).

use crate::cases::gyro_cases::{gyro_calibration, gyro_sample};
use crate::rt;
use core::hint::black_box;
use cortex_m_semihosting::hprintln;

/// Repetitions per row.
const R: u32 = 10_000;

fn print_row(name: &str, instr: f64, stack: Option<usize>) {
    match stack {
        Some(s) => hprintln!(
            "| {:<58} | {:<10} | {:>12.1} | {:>10} |  |",
            name,
            "sample",
            instr,
            s
        ),
        None => hprintln!(
            "| {:<58} | {:<10} | {:>12.1} | {:>10} |  |",
            name,
            "sample",
            instr,
            "> 64 KiB"
        ),
    }
}

/// The rows; `per_tick`: instructions per SysTick tick. Always true (no target is set).
pub fn rows(per_tick: f64) -> bool {
    let cal = gyro_calibration();
    let samples: [([f32; 3], [f32; 3]); 8] = core::array::from_fn(|i| gyro_sample(i as u32));
    let base = rt::time_reps(R, |i| {
        let c = black_box(&cal);
        (c as *const _, samples[i as usize & 7])
    });
    let per = |op: u64| op.saturating_sub(base) as f64 * per_tick / f64::from(R);
    let op = rt::time_reps(R, |i| {
        black_box(&cal).correct_linear(samples[i as usize & 7].0)
    });
    rt::systick_enabled(false);
    let st = rt::peak_stack(|| black_box(&cal).correct_linear(black_box(samples[0].0)));
    rt::systick_enabled(true);
    print_row("GyroCorrection::correct_linear", per(op), st);
    let op = rt::time_reps(R, |i| {
        let (m, a) = samples[i as usize & 7];
        black_box(&cal).correct(m, a)
    });
    rt::systick_enabled(false);
    let st = rt::peak_stack(|| black_box(&cal).correct(black_box(samples[0].0), samples[0].1));
    rt::systick_enabled(true);
    print_row("GyroCorrection::correct (g-sensitivity)", per(op), st);
    true
}
