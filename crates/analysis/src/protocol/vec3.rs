//! The room's 3-vector arithmetic on `[f64; 3]` (window means, rates, integrals): one copy
//! for faces, turns and rates, so that "the nearest sensor axis" is measured one way.

/// Axis names in index order.
pub const AXES: [&str; 3] = ["x", "y", "z"];

/// `a − b`.
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Euclidean norm.
pub fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// `K·v` for a row-major 3×3 `K`.
pub fn mat_vec(k: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| k[r][0] * v[0] + k[r][1] * v[1] + k[r][2] * v[2])
}

/// Angle between two unit vectors, degrees.
pub fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    dot.clamp(-1.0, 1.0).acos().to_degrees()
}

/// The sensor axis `v` points nearest to: `(axis, sign, degrees off it)`; `None` for a zero
/// (or non-finite) vector.
pub fn nearest_axis(v: [f64; 3]) -> Option<(usize, f64, f64)> {
    let n = norm(v);
    // `n > 0` is false for a zero vector and for NaN: both point nowhere.
    if n.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let a = (0..3).max_by(|x, y| v[*x].abs().total_cmp(&v[*y].abs()))?;
    let off = (v[a].abs() / n).clamp(0.0, 1.0).acos().to_degrees();
    Some((a, v[a].signum(), off))
}

/// `+x`, `-z`…: an axis and its sign as printed.
pub fn axis_label((a, s): (usize, f64)) -> String {
    format!("{}{}", if s > 0.0 { "+" } else { "-" }, AXES[a])
}

/// `(axis, sign)` of `v` when it lies within `tolerance_deg` of a sensor axis.
pub fn along_axis(v: [f64; 3], tolerance_deg: f64) -> Option<(usize, f64)> {
    nearest_axis(v)
        .filter(|(_, _, off)| *off <= tolerance_deg)
        .map(|(a, s, _)| (a, s))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_axis_and_its_angle() {
        let (a, s, off) = nearest_axis([0.1, -2.0, 0.0]).unwrap();
        assert_eq!((a, s), (1, -1.0));
        assert!((off - 0.05f64.atan().to_degrees()).abs() < 1e-12);
        assert_eq!(nearest_axis([0.0; 3]), None);
        assert_eq!(nearest_axis([f64::NAN, 1.0, 0.0]), None);
        let tilt = |deg: f64| [deg.to_radians().sin(), 0.0, deg.to_radians().cos()];
        assert_eq!(along_axis(tilt(19.0), 20.0), Some((2, 1.0)));
        assert_eq!(along_axis(tilt(21.0), 20.0), None);
    }
}
