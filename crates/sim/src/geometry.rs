//! Directions on the unit sphere: normalising, a random direction, a small random tilt and
//! spherical interpolation (the poses, the turns between them, the drawn bias directions).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// `v` scaled to unit length.
fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

/// A direction uniform on the sphere (a normalised Gaussian draw; a near-zero draw is
/// drawn again).
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
