//! Four [`Welford3`]s filled at once: [`Welford3::of_four`].
//!
//! ## Why
//! One accumulator's update is a chain: the new mean needs the old one through a subtraction,
//! a division and an addition, so a loop over one slice waits on that chain at every sample
//! (the latency of a division and two additions), while the processor could start several
//! such chains at once. Four independent slices (the survey's blocks, the detector's static
//! runs) updated in step keep four chains in flight, and with the state stored axis by axis
//! and lane by lane each operation of the update is one four-lane operation.
//!
//! ## Exactness
//! Each lane does the operations of [`Welford3::push`] on its own slice's samples, in order:
//! the same accumulator bit for bit. `push` refuses a sample whose update is not finite; here
//! the lanes run on, and a lane is refused at the end when its state is not finite, which
//! happens exactly when one of its updates was not: a NaN never leaves the state again, and an
//! infinite mean, sum or compensation turns into a NaN at the next update (`∞ − ∞`).

use super::{Welford, Welford3};
use crate::Error;

/// Slices measured together by [`Welford3::of_four`].
const LANES: usize = 4;

/// The state of four accumulators, `[axis][lane]`.
#[derive(Debug, Clone, Copy)]
struct Lanes {
    n: [u32; LANES],
    shift: [[f32; LANES]; 3],
    mean: [[f32; LANES]; 3],
    m2: [[f32; LANES]; 3],
    m2_c: [[f32; LANES]; 3],
}

impl Lanes {
    /// Empty accumulators whose shift is each lane's first sample (as the first push sets it).
    fn starting_at(first: [[f32; 3]; LANES]) -> Self {
        let mut shift = [[0.0; LANES]; 3];
        for (l, x) in first.iter().enumerate() {
            for a in 0..3 {
                shift[a][l] = x[a];
            }
        }
        let zeros = [[0.0; LANES]; 3];
        Self {
            n: [0; LANES],
            shift,
            mean: zeros,
            m2: zeros,
            m2_c: zeros,
        }
    }

    /// One sample per lane: [`Welford::next`]'s operations, lane by lane.
    #[allow(clippy::needless_range_loop)] // five arrays indexed by the same axis and lane
    #[inline(always)]
    fn push(&mut self, x: [[f32; 3]; LANES]) {
        let mut nf = [0.0f32; LANES];
        for l in 0..LANES {
            self.n[l] += 1;
            nf[l] = self.n[l] as f32;
        }
        for a in 0..3 {
            for l in 0..LANES {
                let d = x[l][a] - self.shift[a][l];
                let delta = d - self.mean[a][l];
                let mean = self.mean[a][l] + delta / nf[l];
                let inc = delta * (d - mean) - self.m2_c[a][l];
                let m2 = self.m2[a][l] + inc;
                self.m2_c[a][l] = (m2 - self.m2[a][l]) - inc;
                self.m2[a][l] = m2;
                self.mean[a][l] = mean;
            }
        }
    }

    /// Lane `l` as an accumulator, or the refusal its updates met.
    fn lane(&self, l: usize) -> Result<Welford3, Error> {
        let axis = |a: usize| Welford {
            n: self.n[l],
            shift: self.shift[a][l],
            mean: self.mean[a][l],
            m2: self.m2[a][l],
            m2_c: self.m2_c[a][l],
        };
        let axes = [axis(0), axis(1), axis(2)];
        let finite = axes
            .iter()
            .all(|w| w.mean.is_finite() && w.m2.is_finite() && w.m2_c.is_finite());
        if finite {
            Ok(Welford3 { axes })
        } else {
            Err(Error::NonFinite)
        }
    }
}

impl Welford3 {
    /// The accumulators of four slices, each as [`Welford3::push_slice`] into an empty one
    /// leaves it (bit for bit), or the error it stops with; the slices' common length
    /// measured in step (see the module docs), the rest of each slice one sample at a time.
    pub fn of_four(slices: [&[[f32; 3]]; LANES]) -> [Result<Self, Error>; LANES] {
        let common = slices.iter().map(|s| s.len()).min().unwrap_or(0);
        // Empty slices, or a count that would overflow the counter: one at a time.
        if common == 0 || common >= u32::MAX as usize {
            return slices.map(|s| {
                let mut w = Self::new();
                w.push_slice(s).map(|()| w).map_err(|(_, e)| e)
            });
        }
        let mut lanes = Lanes::starting_at(slices.map(|s| s[0]));
        // Cut to the common length, so that the loop indexes without a bounds check.
        let [s0, s1, s2, s3] = slices.map(|s| &s[..common]);
        for i in 0..common {
            lanes.push([s0[i], s1[i], s2[i], s3[i]]);
        }
        let mut l = 0;
        slices.map(|s| {
            let lane = lanes.lane(l);
            l += 1;
            let mut w = lane?;
            w.push_slice(&s[common..]).map_err(|(_, e)| e)?;
            Ok(w)
        })
    }
}
