//! The rows of a window-mean table ([`crate::input::table::WindowTable`]: GGIR's sphere data,
//! the still epochs of a raw file) as the analysis's windows: such a table skips the detection,
//! and this is what it gives the fit and the search in its place.

use crate::detect::windows::{WindowStats, Windows};
use crate::input::recording::infer_units;
use crate::input::table::WindowTable;
use crate::stats as st;

impl Windows {
    /// The rows as the analysis's windows: mean; variance = SD² (NaN without SD columns);
    /// the count when given (else unknown); temperature; time = the file's time column (s),
    /// else the row index (rows taken as equally spaced, 1 s apart). Units are inferred from
    /// the median norm of the means, as for detected windows.
    pub fn of_table(table: &WindowTable) -> Windows {
        let rec = &table.recording;
        let times: Vec<f64> = rec
            .t
            .clone()
            .unwrap_or_else(|| (0..rec.len()).map(|i| i as f64).collect());
        let t0 = times.first().copied().unwrap_or(0.0);
        let stats: Vec<WindowStats> = (0..rec.len())
            .map(|i| WindowStats {
                start: i,
                end: i + 1,
                mean: rec.xyz[i],
                var: table
                    .sd
                    .as_ref()
                    .map_or([f64::NAN; 3], |sd| sd[i].map(|s| s * s)),
                batch_var_of_mean: None,
                t_centre: times[i] - t0,
                t_first: times[i],
                t_last: times[i],
                temp: rec.temp.as_ref().map(|t| t[i]),
                count: table.count.as_ref().map(|c| c[i]),
                runs: None,
                distinct: None,
            })
            .collect();
        let norms: Vec<f64> = rec
            .xyz
            .iter()
            .map(|m| (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt())
            .collect();
        // The "reference" noise of a table: the median within-window variance per axis.
        let reference_variance = std::array::from_fn(|a| match &table.sd {
            Some(sd) => st::median(&sd.iter().map(|s| s[a] * s[a]).collect::<Vec<_>>()) as f32,
            None => f32::NAN,
        });
        Windows {
            units: infer_units(rec.is_integer(), st::median(&norms)),
            stats,
            clock: times.first().zip(times.last()).map(|(a, b)| (*a, *b)),
            reference_variance,
            polling: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::window_means::{parse_window_table, WindowInputOptions};

    fn windows(text: &str, force: bool) -> Windows {
        let opts = WindowInputOptions {
            force,
            ..Default::default()
        };
        Windows::of_table(&parse_window_table(text, &opts).unwrap().unwrap())
    }

    #[test]
    fn rows_become_windows_with_variance_count_time_and_units() {
        // SD columns: variance = SD²; no count column: unknown count; means near 1: g.
        let ws = windows("t,x,y,z,sdx,sdy,sdz\n0,0.01,0,1,0.01,0.02,0.03\n", false);
        assert_eq!(ws.stats.len(), 1);
        assert!((ws.stats[0].var[2] - 9e-4).abs() < 1e-15);
        assert_eq!(ws.stats[0].n(), None);
        assert_eq!(ws.units, "g");
        // A count column gives each window its sample count; times from the time column.
        let ws = windows(
            "t,x,y,z,n\n0,0.1,0.2,0.97,5\n10,0.1,0.2,0.97,5\n20,0.1,0.2,0.97,5\n",
            false,
        );
        assert_eq!(ws.stats.len(), 3);
        assert_eq!(ws.stats[2].t_centre, 20.0);
        assert_eq!(ws.stats[1].n(), Some(5));
        assert!(ws.stats[0].var[0].is_nan());
    }

    #[test]
    fn rows_without_time_are_one_second_apart() {
        // Header-less numbers, forced: rows 1 s apart, no SD (variance NaN).
        let ws = windows("0 0 1\n0 1 0\n", true);
        assert_eq!(ws.stats[1].t_centre, 1.0);
        assert!(ws.stats[0].var[0].is_nan());
    }
}
