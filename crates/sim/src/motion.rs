//! The sensor's motion: the poses' directions, the timeline of holds and moves (the
//! profile's durations, hand wobble and bumps) and the specific force at any time.

use crate::config::Profile;
use crate::geometry::{random_unit, slerp, tilt};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

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

/// The specific force of the motion alone in sensor axes at time `ti` in segment `seg`, g:
/// gravity's direction of the pose held, or, while moving, the turn between two poses with
/// the hand's wobble and bumps (the push of a pose that was not still is added on top, by
/// the sensor).
pub(super) fn specific_force(dirs: &[[f64; 3]], seg: &Seg, ti: f64) -> [f64; 3] {
    match seg.kind {
        SegKind::Hold(k) => dirs[k],
        SegKind::Move {
            from,
            to,
            amp,
            freq,
            bumps,
        } => {
            let tau = (ti - seg.t0) / (seg.t1 - seg.t0);
            let prof = 0.5 * (1.0 - (std::f64::consts::PI * tau).cos());
            let g = slerp(dirs[from], dirs[to], prof);
            let env = (std::f64::consts::PI * tau).sin();
            let w = (std::f64::consts::TAU * freq * (ti - seg.t0)).sin() * env;
            let bump = |j: usize| {
                bumps
                    .iter()
                    .map(|(at, width, peak)| peak[j] * (-0.5 * ((ti - at) / width).powi(2)).exp())
                    .sum::<f64>()
            };
            std::array::from_fn(|j| g[j] + amp[j] * w + bump(j))
        }
    }
}
