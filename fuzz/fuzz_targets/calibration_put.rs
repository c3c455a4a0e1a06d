//! Calibration JSON → `device put` → adapter: arbitrary text (or a file written by `calfile`
//! from a calibration built from the input: near the Nunchuk's nominal one, or arbitrary
//! floats) through the strict calibration file parser; whatever parses is sent to the adapter's protocol as `device put --force`
//! would, then committed. The adapter must never panic, must accept exactly what the core's
//! acceptance predicate accepts (`Acceptance::nunchuk`), must keep its old calibration when
//! it refuses, and once it accepts, every raw input must correct to within the ±16 g bound.
#![no_main]

use embassy_futures::block_on;
use libfuzzer_sys::fuzz_target;

#[path = "ram_flash.rs"]
mod ram_flash;
use ram_flash::{RamFlash, PAGE, PAGES};
use wiical_adapter::{CalibrationStore, DeviceInfo, IdealScale, Protocol};
use wiical_analysis::output::calfile;
use wiical_core::acceptance::Acceptance;
use wiical_core::Calibration;
use wiical_wire::{Hello, Request, Response, WireCalibration};

/// A calibration near the Nunchuk's nominal one, each term perturbed by one input byte (so
/// that accepted and refused calibrations both occur, many near the limits).
fn near_nominal(bytes: &[u8]) -> Calibration {
    let mut b = bytes
        .iter()
        .map(|&x| f32::from(x as i8))
        .chain(core::iter::repeat(0.0));
    let mut next = || b.next().unwrap_or(0.0);
    let mut cal = Calibration {
        bias: [0.0; 3],
        ..Default::default()
    };
    for (i, bias) in cal.bias.iter_mut().enumerate() {
        *bias = 512.0 + next();
        for j in 0..3 {
            cal.matrix[i][j] = if i == j {
                (1.0 + next() / 256.0) / 200.0
            } else {
                next() * 1e-5
            };
        }
    }
    let e = &mut cal.effects;
    for i in 0..3 {
        e.quadratic[i] = next() * 1e-3;
        e.cubic[i] = next() * 1e-4;
        e.bias_drift[i] = next() * 1e-3;
        e.bias_temp[i] = next() * 1e-2;
        e.scale_temp[i] = next() * 1e-5;
        for c in e.cross_quadratic[i].iter_mut() {
            *c = next() * 1e-4;
        }
        for c in e.cross_cubic[i].iter_mut() {
            *c = next() * 1e-5;
        }
    }
    e.temp_ref_c = 25.0 + next();
    cal
}

/// Arbitrary f32 bit patterns for every term.
fn raw_floats(bytes: &[u8]) -> Calibration {
    let mut words = bytes
        .chunks(4)
        .map(|c| {
            let mut w = [0u8; 4];
            w[..c.len()].copy_from_slice(c);
            f32::from_le_bytes(w)
        })
        .chain(core::iter::repeat(0.0));
    let mut next = || words.next().unwrap_or(0.0);
    let mut cal = Calibration::default();
    for i in 0..3 {
        cal.bias[i] = next();
        for j in 0..3 {
            cal.matrix[i][j] = next();
        }
    }
    let e = &mut cal.effects;
    for i in 0..3 {
        e.quadratic[i] = next();
        e.cubic[i] = next();
        e.bias_drift[i] = next();
        e.bias_temp[i] = next();
        e.scale_temp[i] = next();
        for c in e.cross_quadratic[i].iter_mut() {
            *c = next();
        }
        for c in e.cross_cubic[i].iter_mut() {
            *c = next();
        }
    }
    e.temp_ref_c = next();
    cal
}

/// The calibration file text to try: the input itself, or one written by `calfile` from a
/// calibration built from the input (which must then read back bit for bit).
fn file_text(data: &[u8]) -> Option<String> {
    let (&mode, rest) = data.split_first()?;
    let cal = match mode % 3 {
        0 => return std::str::from_utf8(rest).ok().map(String::from),
        1 => near_nominal(rest),
        _ => raw_floats(rest),
    };
    let text = calfile::to_json(&cal).ok()?;
    // A file that reads back (every value finite) must give the same bits.
    if let Ok(back) = calfile::parse(&text) {
        let bits = |c: &Calibration| {
            let mut v: Vec<u32> = c.bias.iter().map(|x| x.to_bits()).collect();
            v.extend(c.matrix.iter().flatten().map(|x| x.to_bits()));
            v
        };
        assert_eq!(bits(&back.calibration), bits(&cal), "file round trip");
        assert_eq!(back.calibration.effects, cal.effects, "file round trip");
    }
    Some(text)
}

fuzz_target!(|data: &[u8]| {
    let Some(text) = file_text(data) else {
        return;
    };
    let Ok(file) = calfile::parse(&text) else {
        return;
    };
    let cal = file.calibration;
    let acceptance = Acceptance::nunchuk();
    let plausible = acceptance.check(&cal, None).is_ok();
    block_on(async {
        let store =
            CalibrationStore::new(RamFlash(vec![0xFF; PAGE * PAGES]), 0..(PAGE * PAGES) as u32)
                .expect("store configuration");
        let info = DeviceInfo::new("fuzz", [0; 8], 200_000);
        let mut p = Protocol::boot(store, info, IdealScale::default()).await;
        assert!(matches!(
            p.handle(Request::Hello(Hello::CURRENT)).await,
            Response::Hello(_)
        ));
        let before = p.corrector().live_calibration();
        let put = p
            .handle(Request::PutCalibration(WireCalibration::from(cal)))
            .await;
        let commit = p.handle(Request::CommitCalibration).await;
        let accepted = put == Response::Ack && commit == Response::Ack;
        assert_eq!(
            accepted, plausible,
            "adapter and core disagree: put {put:?}, commit {commit:?}"
        );
        if !accepted {
            assert_eq!(
                p.corrector().live_calibration(),
                before,
                "a refused calibration changed the live one"
            );
            return;
        }
        // Corners and centre of the 10-bit input box stay within the output bound.
        for raw in [
            [0u16, 0, 0],
            [1023, 1023, 1023],
            [0, 1023, 512],
            [512, 512, 512],
        ] {
            let g = p.corrector().correct(raw).g;
            assert!(
                g.iter().all(|v| v.abs() <= acceptance.output_bound * 1.001),
                "{raw:?} -> {g:?}"
            );
        }
    });
});
