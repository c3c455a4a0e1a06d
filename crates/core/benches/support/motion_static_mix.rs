//! The stream the detector's benchmark and `examples/detector_cycles.rs` both run: integer
//! counts at 100 Hz (Xsens-like magnitudes), 3 s holds with ±3-count noise between 1 s
//! motions, so the detector meets both static runs (a Welford push per sample) and motion
//! (recomputations as large values leave the window).

/// `n` samples of the stream (module docs).
pub fn motion_static_mix(n: usize) -> Vec<[f32; 3]> {
    let mut state = 0x2545_f491u32;
    let mut noise = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        (state % 7) as f32 - 3.0
    };
    let poses = [
        [33000.0f32, 33300.0, 36400.0],
        [29000.0, 33200.0, 32300.0],
        [33100.0, 29200.0, 32300.0],
    ];
    (0..n)
        .map(|k| {
            let (cycle, at) = (k / 400, k % 400);
            let p = poses[cycle % poses.len()];
            if at < 300 {
                p.map(|x| x + noise())
            } else {
                let ph = (at - 300) as f32 * 0.0628;
                [
                    (p[0] + 3000.0 * ph.sin()).round(),
                    (p[1] + 2000.0 * ph.cos()).round(),
                    p[2] + noise(),
                ]
            }
        })
        .collect()
}
