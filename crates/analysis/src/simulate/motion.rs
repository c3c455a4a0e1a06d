//! The sensor's motion: the poses' directions, the timeline of holds and moves (the
//! profile's durations, hand wobble and bumps) and the specific force at any time.

use super::config::Profile;
use super::sensor::Scene;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

pub(super) fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

pub(super) fn random_unit(rng: &mut ChaCha8Rng) -> [f64; 3] {
    loop {
        let v: [f64; 3] = [
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
        ];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > 1e-6 {
            return [v[0] / n, v[1] / n, v[2] / n];
        }
    }
}

/// `d` tilted by a random angle up to `max_rad`.
pub(super) fn tilt(rng: &mut ChaCha8Rng, d: [f64; 3], max_rad: f64) -> [f64; 3] {
    let r = random_unit(rng);
    let ang = rng.random_range(0.0..max_rad);
    unit([d[0] + ang * r[0], d[1] + ang * r[1], d[2] + ang * r[2]])
}

/// Spherical interpolation between unit vectors.
pub(super) fn slerp(a: [f64; 3], b: [f64; 3], s: f64) -> [f64; 3] {
    let dot = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0);
    let om = dot.acos();
    if om < 1e-6 {
        return a;
    }
    if (std::f64::consts::PI - om).abs() < 1e-3 {
        // Antipodal: go through any perpendicular direction.
        let p = if a[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let d = a[0] * p[0] + a[1] * p[1] + a[2] * p[2];
        let q = unit([p[0] - d * a[0], p[1] - d * a[1], p[2] - d * a[2]]);
        let th = s * std::f64::consts::PI;
        return unit([
            a[0] * th.cos() + q[0] * th.sin(),
            a[1] * th.cos() + q[1] * th.sin(),
            a[2] * th.cos() + q[2] * th.sin(),
        ]);
    }
    let (wa, wb) = (((1.0 - s) * om).sin() / om.sin(), (s * om).sin() / om.sin());
    unit([
        wa * a[0] + wb * b[0],
        wa * a[1] + wb * b[1],
        wa * a[2] + wb * b[2],
    ])
}

/// One stretch of the timeline.
pub(super) struct Seg {
    pub(super) t0: f64,
    pub(super) t1: f64,
    pub(super) kind: SegKind,
}

pub(super) enum SegKind {
    /// Still at pose `k`.
    Hold(usize),
    /// Turning from one pose to the next with a hand wobble.
    Move {
        from: usize,
        to: usize,
        amp: [f64; 3],
        freq: f64,
        /// Hand bumps (brisk profile): centre time (s), width (s, Gaussian σ) and
        /// peak specific force (g, vector).
        bumps: [(f64, f64, [f64; 3]); 2],
    },
}

/// The rest direction (near +z) and `poses` directions: the six near-axis ones shuffled,
/// then uniform.
pub(super) fn pose_directions(rng: &mut ChaCha8Rng, poses: usize) -> Vec<[f64; 3]> {
    let mut dirs = vec![tilt(rng, [0.0, 0.0, 1.0], 0.03)];
    let mut axes: Vec<[f64; 3]> = (0..6)
        .map(|k| {
            let mut v = [0.0; 3];
            v[k / 2] = if k % 2 == 0 { 1.0 } else { -1.0 };
            v
        })
        .collect();
    // Shuffle the six near-axis poses (Fisher–Yates).
    for i in (1..axes.len()).rev() {
        let j = rng.random_range(0..=i);
        axes.swap(i, j);
    }
    for k in 0..poses {
        let d = match axes.get(k) {
            Some(a) => tilt(rng, *a, 0.17),
            None => random_unit(rng),
        };
        dirs.push(d);
    }
    dirs
}

/// Rest, then motion + hold for each pose; returns the segments and the duration, s.
pub(super) fn timeline(
    rng: &mut ChaCha8Rng,
    init_s: f64,
    n_dirs: usize,
    profile: Profile,
) -> (Vec<Seg>, f64) {
    let ((hold_lo, hold_hi), (move_lo, move_hi)) = profile.durations();
    let mut segs = vec![Seg {
        t0: 0.0,
        t1: init_s,
        kind: SegKind::Hold(0),
    }];
    let mut t = init_s;
    for k in 1..n_dirs {
        let mv = rng.random_range(move_lo..move_hi);
        let amp = random_unit(rng).map(|x| x * rng.random_range(0.15..0.4));
        let freq = rng.random_range(0.8..2.0);
        let bumps = if profile == Profile::Brisk {
            // Lifting (early in the move) and knocking the sensor down (late): 20–40 ms
            // pulses of 0.3–1 g.
            [(0.1, 0.25), (0.75, 0.9)].map(|(a, b)| {
                let at = t + mv * rng.random_range(a..b);
                let width = rng.random_range(0.02..0.04);
                let peak = rng.random_range(0.3..1.0);
                (at, width, random_unit(rng).map(|x| x * peak))
            })
        } else {
            [(0.0, 1.0, [0.0; 3]); 2]
        };
        segs.push(Seg {
            t0: t,
            t1: t + mv,
            kind: SegKind::Move {
                from: k - 1,
                to: k,
                amp,
                freq,
                bumps,
            },
        });
        t += mv;
        let hold = rng.random_range(hold_lo..hold_hi);
        segs.push(Seg {
            t0: t,
            t1: t + hold,
            kind: SegKind::Hold(k),
        });
        t += hold;
    }
    (segs, t)
}

impl Scene {
    /// Specific force in sensor axes at time `ti` in segment `seg`, g.
    pub(super) fn specific_force(&self, seg: &Seg, ti: f64) -> [f64; 3] {
        match seg.kind {
            SegKind::Hold(k) => {
                let mut f = self.dirs[k];
                if let Some(o) = self.outliers.iter().find(|o| o.pose == k) {
                    // A 2 s half-sine push along gravity in the middle of the hold whose
                    // average over the hold is the outlier's shift.
                    let len = seg.t1 - seg.t0;
                    let tb = 2.0f64.min(len * 0.5);
                    let start = seg.t0 + 0.5 * (len - tb);
                    if ti >= start && ti < start + tb {
                        let amp = o.shift_mg / 1000.0 * std::f64::consts::PI * len / (2.0 * tb);
                        let bump = amp * (std::f64::consts::PI * (ti - start) / tb).sin();
                        for (fj, dj) in f.iter_mut().zip(self.dirs[k]) {
                            *fj += bump * dj;
                        }
                    }
                }
                f
            }
            SegKind::Move {
                from,
                to,
                amp,
                freq,
                bumps,
            } => {
                let tau = (ti - seg.t0) / (seg.t1 - seg.t0);
                let prof = 0.5 * (1.0 - (std::f64::consts::PI * tau).cos());
                let g = slerp(self.dirs[from], self.dirs[to], prof);
                let env = (std::f64::consts::PI * tau).sin();
                let w = (std::f64::consts::TAU * freq * (ti - seg.t0)).sin() * env;
                let bump = |j: usize| {
                    bumps
                        .iter()
                        .map(|(at, width, peak)| {
                            peak[j] * (-0.5 * ((ti - at) / width).powi(2)).exp()
                        })
                        .sum::<f64>()
                };
                std::array::from_fn(|j| g[j] + amp[j] * w + bump(j))
            }
        }
    }
}
