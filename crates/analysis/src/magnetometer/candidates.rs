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

/// The recording as the loop reads it.
#[derive(Debug, Clone, Copy)]
pub struct MagInput<'a> {
    /// Samples, file units.
    pub xyz: &'a [[f64; 3]],
    /// Times, s (`None`: the sample index is the time).
    pub t: Option<&'a [f64]>,
    /// Temperature, °C, one per sample.
    pub temp: Option<&'a [f64]>,
    /// Named columns the centre may follow (current, throttle, PWM), one value per sample.
    pub follow: &'a [(String, Vec<f64>)],
    /// The file's unit for the field (`gauss`, `uT`, or `raw`).
    pub unit: &'a str,
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

fn centred(v: impl Iterator<Item = f64>) -> Vec<f64> {
    let v: Vec<f64> = v.collect();
    let m = v.iter().sum::<f64>() / v.len().max(1) as f64;
    v.into_iter().map(|x| x - m).collect()
}

/// The scalars the centre may follow, with their candidates (columns still to be numbered).
fn scalars(inp: &MagInput, n: usize) -> Vec<(String, Vec<f64>, String, Option<f64>)> {
    let (times, tu) = match inp.t {
        Some(t) => (t.to_vec(), "s"),
        None => ((0..n).map(|i| i as f64).collect(), "sample"),
    };
    let u = inp.unit;
    let mut out = vec![(
        "centre-drift".to_string(),
        centred(times.iter().copied()),
        format!("{u}/{tu}"),
        None,
    )];
    for k in 2..=BLOCKS - 2 {
        let at = k * n / BLOCKS;
        let g = (0..n).map(|i| if i >= at { 1.0 } else { 0.0 }).collect();
        out.push((
            "centre-step".into(),
            g,
            u.to_string(),
            Some(times[at.min(n - 1)]),
        ));
    }
    if let Some(t) = inp.temp {
        if t.iter().any(|x| *x != t[0]) {
            out.push((
                "temperature".into(),
                centred(t.iter().copied()),
                format!("{u}/°C"),
                None,
            ));
        }
    }
    for (name, v) in inp.follow {
        if v.len() == n && v.iter().any(|x| *x != v[0]) {
            out.push((
                format!("interference:{name}"),
                centred(v.iter().copied()),
                format!("{u} per {name} unit"),
                None,
            ));
        }
    }
    out
}

/// Numbers every column and accumulates the blocks' normal equations in one pass.
pub fn layout(inp: &MagInput, geos: &[Geo], shape: Shape) -> Layout {
    let n = geos.len();
    let sc = scalars(inp, n);
    let mut row = Vec::new();
    design::base_row(&geos[0], shape, &mut row);
    let base = row.len();
    let mut cands: Vec<Cand> = Vec::new();
    let mut next = base;
    for (name, _, unit, at) in &sc {
        let cols: Vec<usize> = (next..next + 3).collect();
        next += 3;
        match cands.iter_mut().find(|c| &c.name == name) {
            Some(c) => c.alts.push((cols, *at)),
            None => cands.push(Cand {
                name: name.clone(),
                alts: vec![(cols, *at)],
                unit: unit.clone(),
                kind: Kind::Centre,
            }),
        }
    }
    cands.push(Cand {
        name: "shape".into(),
        alts: vec![((next..next + 10).collect(), None)],
        unit: inp.unit.to_string(),
        kind: Kind::Shape,
    });
    let p = next + 10;
    let mut blocks: Vec<Normal> = (0..BLOCKS).map(|_| Normal::zeros(p)).collect();
    for (i, g) in geos.iter().enumerate() {
        row.clear();
        design::base_row(g, shape, &mut row);
        for (_, v, _, _) in &sc {
            design::follow_row(g, v[i], &mut row);
        }
        design::shape_row(g, &mut row);
        blocks[i * BLOCKS / n].push(&row, g.res);
    }
    blocks.iter_mut().for_each(Normal::symmetrise);
    Layout {
        base,
        cands,
        blocks,
    }
}
