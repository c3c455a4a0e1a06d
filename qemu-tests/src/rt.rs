//! Target-side support shared by the `qemu-tests` and `qemu-bench` binaries.
//!
//! # Counting instructions
//! QEMU 7.2 does not emulate the DWT cycle counter of the Cortex-M33 (`DWT_CYCCNT` reads 0
//! whatever `DWT_CTRL` says), but it does emulate SysTick. With `-icount shift=0` virtual time
//! advances exactly 1 ns per executed instruction, and SysTick on `mps2-an505` counts the
//! 20 MHz system clock, so one SysTick tick is 50 instructions. [`instructions_per_tick`]
//! measures that ratio on a loop of known length instead of assuming it. Counts are
//! instructions, not cycles: QEMU charges every instruction (load, branch, `vdiv`, …) one.
//!
//! # Stack
//! [`peak_stack`] paints the free stack below the current stack pointer with a pattern,
//! runs the operation and finds the lowest word that no longer holds the pattern.

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_semihosting::{debug, hprintln};

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("panic: {}", info);
    exit(false)
}

/// Ends the QEMU run with exit status 0 (`ok`) or 1 (semihosting `SYS_EXIT`).
pub fn exit(ok: bool) -> ! {
    debug::exit(if ok {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    #[allow(clippy::empty_loop)]
    loop {}
}

/// SysTick reload: the full 24-bit range.
const RELOAD: u32 = 0x00FF_FFFF;

/// Number of SysTick wrap-arounds, counted by the SysTick exception (see the `qemu-bench`
/// binary's handler, which calls [`on_systick_wrap`]).
static WRAPS: AtomicU32 = AtomicU32::new(0);

/// To be called from the SysTick exception handler.
pub fn on_systick_wrap() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// Starts SysTick on the processor clock, free-running over 24 bits with its exception on
/// (to count wrap-arounds).
pub fn start_systick(mut syst: SYST) {
    syst.disable_counter();
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(RELOAD);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
    // Writing CVR clears it to 0; it takes the reload value at the next tick.
    while SYST::get_current() == 0 {}
}

/// Monotonic tick count since [`start_systick`]. SysTick counts down `…, 1, 0, RELOAD, …`
/// and raises its exception (counted in [`WRAPS`]) on the step to 0, so a reading of 0 is
/// already counted as a wrap and stands for the last tick of the period.
#[inline(always)]
pub fn ticks() -> u64 {
    const PERIOD: u64 = RELOAD as u64 + 1;
    loop {
        let w0 = WRAPS.load(Ordering::Relaxed);
        let cvr = SYST::get_current();
        let w1 = WRAPS.load(Ordering::Relaxed);
        if w0 == w1 {
            let base = u64::from(w0) * PERIOD;
            return if cvr == 0 {
                base.saturating_sub(1)
            } else {
                base + u64::from(RELOAD - cvr)
            };
        }
    }
}

/// Spins `n` iterations of a two-instruction loop (`subs`, `bne`): `2n` instructions.
#[inline(never)]
pub fn spin(n: u32) {
    // SAFETY: register-only loop, no memory or stack access.
    unsafe {
        core::arch::asm!(
            "1:",
            "subs {0}, #1",
            "bne 1b",
            inout(reg) n.max(1) => _,
            options(nomem, nostack)
        );
    }
}

/// Instructions per SysTick tick: `(instructions, ticks, ratio)` measured on 10,000,000
/// instructions of [`spin`]. The ratio is rounded to the nearest integer when the
/// measurement is within one tick of it (the reading is quantised to whole ticks, and the
/// call adds a few instructions), else returned as measured.
pub fn instructions_per_tick() -> (u64, u64, f64) {
    const ITER: u32 = 5_000_000;
    let t0 = ticks();
    spin(ITER);
    let t1 = ticks();
    let dt = (t1 - t0).max(1);
    let instr = 2 * u64::from(ITER);
    let raw = instr as f64 / dt as f64;
    let rounded = (raw + 0.5) as u64;
    let ratio = if rounded > 0 && (instr / rounded).abs_diff(dt) <= 1 {
        rounded as f64
    } else {
        raw
    };
    (instr, dt, ratio)
}

/// Runs `f` `reps` times and returns the elapsed SysTick ticks.
#[inline(never)]
pub fn time_reps<R>(reps: u32, mut f: impl FnMut(u32) -> R) -> u64 {
    let t0 = ticks();
    for i in 0..reps {
        core::hint::black_box(f(core::hint::black_box(i)));
    }
    ticks() - t0
}

/// Pattern for stack painting.
const PAINT: u32 = 0xA5C3_5A3C;
/// How far below the current stack pointer to paint (and so the largest measurable peak).
pub const PAINT_BYTES: usize = 64 * 1024;

extern "C" {
    /// Lowest address of the stack (cortex-m-rt's linker script).
    static _stack_end: u32;
}

#[inline(never)]
fn call<R>(f: impl FnOnce() -> R) -> R {
    core::hint::black_box(f())
}

/// Peak stack use of `f` in bytes, measured from the stack pointer of the caller of `f`
/// (so the call's own return address and saved registers count). `None` when the peak
/// reached the painted limit ([`PAINT_BYTES`]).
#[inline(never)]
pub fn peak_stack<R>(f: impl FnOnce() -> R) -> Option<usize> {
    let sp: usize;
    // SAFETY: reads the stack pointer.
    unsafe { core::arch::asm!("mov {}, sp", out(reg) sp, options(nomem, nostack)) };
    let floor = core::ptr::addr_of!(_stack_end) as usize;
    let bottom = sp.saturating_sub(PAINT_BYTES).max(floor) & !3;
    let top = sp & !3;
    // Paint [bottom, top): free stack below this frame. No call happens between here and
    // `call`, so nothing else uses that memory meanwhile (no interrupts but SysTick, which
    // is off here: the caller stops it).
    let mut p = bottom;
    while p < top {
        // SAFETY: word-aligned address inside the RAM region reserved for the stack.
        unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
    core::hint::black_box(call(f));
    let mut p = bottom;
    while p < top {
        // SAFETY: as above.
        if unsafe { core::ptr::read_volatile(p as *const u32) } != PAINT {
            break;
        }
        p += 4;
    }
    if p <= bottom {
        None
    } else {
        Some(top - p)
    }
}

/// Stops SysTick (and its exception), e.g. around [`peak_stack`].
pub fn systick_enabled(on: bool) {
    // SAFETY: single-threaded bare-metal program; only CSR's enable bits are changed.
    let syst = unsafe { &*SYST::PTR };
    // SAFETY: read-modify-write of SysTick CSR: ENABLE (bit 0) and TICKINT (bit 1).
    unsafe {
        syst.csr.modify(|v| if on { v | 0b11 } else { v & !0b11 });
    }
}
