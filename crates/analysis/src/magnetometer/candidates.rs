//! The magnetometer loop's candidate effects and the columns they add to the linearised model
//! ([`super::design`]).
//!
//! - `centre-drift`: the centre moves linearly in time (file unit per second, or per sample
//!   without a time column);
//! - `centre-step`: the centre jumps once (a current switching on, a part moved), scanned at
//!   the block boundaries from 20 % to 80 % of the recording (each side keeps two held-out
//!   blocks), its p-value multiplied by the positions scanned;
//! - `temperature`: the centre follows the temperature column (file unit per °C);
//! - `interference:<column>`: the centre follows a named column (current, throttle, PWM):
//!   ArduPilot COMPASS_MOT's model, offset = k × that column (file unit per column unit);
//! - `shape`: the surface departs from the ellipsoid (cubic terms of the direction), measured
//!   as the RMS it adds to the residual (file unit).

use super::design::{self, Geo, Normal, Shape, BLOCKS};

/// What a candidate's coefficients are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Three per-axis centre offsets per unit of a scalar.
    Centre,
    /// Shape coefficients: reported as the RMS they add.
    Shape,
}

/// One candidate effect: its name, the column sets it may take (several for a scanned step),
/// and its unit.
#[derive(Debug, Clone)]
pub struct Cand {
    /// JSON / text name.
    pub name: String,
    /// Alternatives: the columns of each, and when it happens (a step's time).
    pub alts: Vec<(Vec<usize>, Option<f64>)>,
    /// Unit of its coefficients and of its detection limit.
    pub unit: String,
    /// Centre-following or shape.
    pub kind: Kind,
}

/// The columns of one recording: the base model's, then each candidate's.
pub struct Layout {
    /// Base columns `0..base`.
    pub base: usize,
    /// The candidates.
    pub cands: Vec<Cand>,
    /// Per-block normal equations over every column.
    pub blocks: Vec<Normal>,
}

/// One column's sums in file order (from `-0.0`, as `Iterator::sum`): its mean, removed
/// from the column so a centre effect does not take the constant the centre already has, and
/// whether it varies at all (a constant column is not a candidate).
#[derive(Debug, Clone)]
pub struct ColumnFold {
    first: Option<f64>,
    varies: bool,
    sum: f64,
    n: usize,
}

impl Default for ColumnFold {
    fn default() -> Self {
        Self::new()
    }
}

impl ColumnFold {
    /// Nothing seen.
    pub fn new() -> Self {
        Self {
            first: None,
            varies: false,
            sum: -0.0,
            n: 0,
        }
    }

    /// The next value.
    pub fn push(&mut self, x: f64) {
        let first = *self.first.get_or_insert(x);
        self.varies |= x != first;
        self.sum += x;
        self.n += 1;
    }

    /// The mean (`sum / max(n, 1)`).
    pub fn mean(&self) -> f64 {
        self.sum / self.n.max(1) as f64
    }

    /// Values seen.
    pub fn len(&self) -> usize {
        self.n
    }
}

/// The field pass's share of the scalars: the times (the time column, `i / Fs`, or the
/// sample index), the times at the scanned steps, the temperature.
#[derive(Debug, Clone)]
pub struct ScalarFold {
    n: usize,
    i: usize,
    time: ColumnFold,
    step_times: [f64; BLOCKS - 3],
    temp: Option<ColumnFold>,
}

impl ScalarFold {
    /// For `n` samples, with a temperature column or not.
    pub fn new(n: usize, has_temp: bool) -> Self {
        Self {
            n,
            i: 0,
            time: ColumnFold::new(),
            step_times: [f64::NAN; BLOCKS - 3],
            temp: has_temp.then(ColumnFold::new),
        }
    }

    /// The next sample's time and temperature (`NaN` without a column: not read then).
    pub fn push(&mut self, t: f64, temp: f64) {
        self.time.push(t);
        for (slot, k) in self.step_times.iter_mut().zip(2..=BLOCKS - 2) {
            if self.i == (k * self.n / BLOCKS).min(self.n.saturating_sub(1)) {
                *slot = t;
            }
        }
        if let Some(f) = &mut self.temp {
            f.push(temp);
        }
        self.i += 1;
    }

    /// The scalars the centre may follow, with `follow` (each named column's sums) and the
    /// field's `unit`; `time_unit` is `s` or `sample`.
    pub fn scalars(
        &self,
        follow: &[(String, ColumnFold)],
        unit: &str,
        time_unit: &str,
    ) -> Vec<Scalar> {
        let n = self.n;
        let u = unit;
        let mut out = vec![Scalar {
            name: "centre-drift".into(),
            unit: format!("{u}/{time_unit}"),
            at: None,
            value: Value::Centred(Column::Time, self.time.mean()),
        }];
        for (k, at_t) in (2..=BLOCKS - 2).zip(self.step_times) {
            out.push(Scalar {
                name: "centre-step".into(),
                unit: u.to_string(),
                at: Some(at_t),
                value: Value::Step(k * n / BLOCKS),
            });
        }
        if let Some(t) = self.temp.as_ref().filter(|t| t.varies) {
            out.push(Scalar {
                name: "temperature".into(),
                unit: format!("{u}/°C"),
                at: None,
                value: Value::Centred(Column::Temp, t.mean()),
            });
        }
        for (j, (name, f)) in follow.iter().enumerate() {
            if f.len() == n && f.varies {
                out.push(Scalar {
                    name: format!("interference:{name}"),
                    unit: format!("{u} per {name} unit"),
                    at: None,
                    value: Value::Centred(Column::Follow(j), f.mean()),
                });
            }
        }
        out
    }
}

/// Which column a scalar reads.
#[derive(Debug, Clone, Copy)]
enum Column {
    Time,
    Temp,
    Follow(usize),
}

/// How a scalar's value is read per sample.
#[derive(Debug, Clone, Copy)]
enum Value {
    /// A column less its mean.
    Centred(Column, f64),
    /// 0 before the sample index, 1 from it.
    Step(usize),
}

/// A scalar the centre may follow: its candidate, unit, when (a step), and its value.
#[derive(Debug, Clone)]
pub struct Scalar {
    name: String,
    unit: String,
    at: Option<f64>,
    value: Value,
}

impl Scalar {
    /// The candidate's name (`interference:current`, `temperature`, …).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// For a named column's scalar (`interference:<column>`): the column's index among the
    /// followed columns and the mean taken from it.
    pub fn follow_column(&self) -> Option<(usize, f64)> {
        match self.value {
            Value::Centred(Column::Follow(j), mean) => Some((j, mean)),
            _ => None,
        }
    }
}

/// The blocks' normal equations fed one sample's geometry at a time, in file order.
pub struct LayoutFold {
    scalars: Vec<Scalar>,
    shape: Shape,
    n: usize,
    i: usize,
    row: Vec<f64>,
    lay: Layout,
}

impl LayoutFold {
    /// Numbers every column: the base model's, then each scalar's three, then shape's ten.
    pub fn new(scalars: Vec<Scalar>, shape: Shape, unit: &str, n: usize) -> Self {
        let mut row = Vec::new();
        let zero = Geo {
            res: 0.0,
            grad: [0.0; 3],
            d: [0.0; 3],
            u: [0.0; 3],
        };
        design::base_row(&zero, shape, &mut row);
        let base = row.len();
        let mut cands: Vec<Cand> = Vec::new();
        let mut next = base;
        for s in &scalars {
            let cols: Vec<usize> = (next..next + 3).collect();
            next += 3;
            match cands.iter_mut().find(|c| c.name == s.name) {
                Some(c) => c.alts.push((cols, s.at)),
                None => cands.push(Cand {
                    name: s.name.clone(),
                    alts: vec![(cols, s.at)],
                    unit: s.unit.clone(),
                    kind: Kind::Centre,
                }),
            }
        }
        cands.push(Cand {
            name: "shape".into(),
            alts: vec![((next..next + 10).collect(), None)],
            unit: unit.to_string(),
            kind: Kind::Shape,
        });
        let p = next + 10;
        let blocks = (0..BLOCKS).map(|_| Normal::zeros(p)).collect();
        Self {
            scalars,
            shape,
            n,
            i: 0,
            row,
            lay: Layout {
                base,
                cands,
                blocks,
            },
        }
    }

    /// The next sample: its geometry, time (or index), temperature and followed columns.
    pub fn push(&mut self, g: &Geo, t: f64, temp: f64, follow: &[f64]) {
        let i = self.i;
        self.row.clear();
        design::base_row(g, self.shape, &mut self.row);
        for s in &self.scalars {
            let x = match s.value {
                Value::Centred(Column::Time, m) => t - m,
                Value::Centred(Column::Temp, m) => temp - m,
                Value::Centred(Column::Follow(j), m) => follow[j] - m,
                Value::Step(at) => {
                    if i >= at {
                        1.0
                    } else {
                        0.0
                    }
                }
            };
            design::follow_row(g, x, &mut self.row);
        }
        design::shape_row(g, &mut self.row);
        self.lay.blocks[i * BLOCKS / self.n].push(&self.row, g.res);
        self.i += 1;
    }

    /// The layout, once every sample is in.
    pub fn finish(mut self) -> Layout {
        self.lay.blocks.iter_mut().for_each(Normal::symmetrise);
        self.lay
    }
}
