//! (Protocol 5.) The numbering of the background recalibration's orientation grid: which
//! direction bin `i` of [`BackgroundReport::bin_moments`](crate::BackgroundReport::bin_moments)
//! and bit `i` of [`BackgroundReport::fresh_bins`](crate::BackgroundReport::fresh_bins) stand
//! for. The adapter bins its still moments by [`bin_of`]; a host draws the grid at
//! [`bin_centre`]. Both sides read it here, so a client needs no adapter crate for it.
//!
//! A direction falls on one face of a cube around the sensor (the axis of its largest
//! component, and that component's sign: faces `+x, −x, +y, −y, +z, −z`); the face is cut into
//! [`CELLS`] × [`CELLS`] cells of equal angle (the face coordinates go through `atan`, so cells
//! near the face's edges are not smaller than central ones): [`BACKGROUND_BINS`] bins of ≈ 30°.

use crate::messages::BACKGROUND_BINS;

/// Cells per cube-face edge.
pub const CELLS: usize = 3;

const _: () = assert!(6 * CELLS * CELLS == BACKGROUND_BINS);

/// The unit direction at the centre of bin `i` (the inverse of [`bin_of`] at cell centres),
/// for drawing the grid; `None` past the last bin.
pub fn bin_centre(i: usize) -> Option<[f32; 3]> {
    if i >= BACKGROUND_BINS {
        return None;
    }
    let (face, cell) = (i / (CELLS * CELLS), i % (CELLS * CELLS));
    let axis = face / 2;
    let major = if face % 2 == 0 { 1.0 } else { -1.0 };
    // The cell's centre in the equal-angle coordinate, back through `tan`.
    let coord = |k: usize| -> f32 {
        let x = (k as f32 + 0.5) / CELLS as f32 * 2.0 - 1.0;
        libm::tanf(x * core::f32::consts::FRAC_PI_4)
    };
    let mut d = [0.0f32; 3];
    d[axis] = major;
    d[(axis + 1) % 3] = coord(cell / CELLS);
    d[(axis + 2) % 3] = coord(cell % CELLS);
    let n = libm::sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    Some(d.map(|x| x / n))
}

/// The bin of a direction (any length), or `None` when it is zero or not finite.
pub fn bin_of(direction: [f32; 3]) -> Option<usize> {
    if !direction.iter().all(|x| x.is_finite()) {
        return None;
    }
    let abs = direction.map(libm::fabsf);
    let axis = if abs[0] >= abs[1] && abs[0] >= abs[2] {
        0
    } else if abs[1] >= abs[2] {
        1
    } else {
        2
    };
    let major = direction[axis];
    if major == 0.0 {
        return None;
    }
    let face = 2 * axis + usize::from(major < 0.0);
    let (s, t) = ((axis + 1) % 3, (axis + 2) % 3);
    let cell = |c: f32| -> usize {
        // Equal-angle coordinate in −1..=1, then the cell.
        let x = libm::atanf(c / libm::fabsf(major)) * (4.0 / core::f32::consts::PI);
        let k = ((x + 1.0) * 0.5 * CELLS as f32) as usize;
        k.min(CELLS - 1)
    };
    Some(face * CELLS * CELLS + cell(direction[s]) * CELLS + cell(direction[t]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The centres the live view draws the bins at fall in their own bins, and are unit
    /// vectors.
    #[test]
    fn bin_centres_fall_in_their_bins() {
        for i in 0..BACKGROUND_BINS {
            let c = bin_centre(i).expect("a centre");
            let n = libm::sqrtf(c.iter().map(|x| x * x).sum::<f32>());
            assert!((n - 1.0).abs() < 1e-6, "bin {i}: |c| = {n}");
            assert_eq!(bin_of(c), Some(i), "bin {i}: centre {c:?}");
        }
        assert_eq!(bin_centre(BACKGROUND_BINS), None);
    }

    /// Independent of the cube arithmetic: the six axis directions are the centre cells
    /// (cell 4 of 9) of faces +x, −x, +y, −y, +z, −z in that order; zero and non-finite
    /// directions have no bin.
    #[test]
    fn axes_fall_in_the_centre_cell_of_their_face() {
        let axes = [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        for (face, a) in axes.into_iter().enumerate() {
            assert_eq!(bin_of(a), Some(face * 9 + 4));
            assert_eq!(bin_centre(face * 9 + 4), Some(a));
        }
        assert_eq!(bin_of([0.0; 3]), None);
        assert_eq!(bin_of([f32::NAN, 1.0, 0.0]), None);
    }
}
