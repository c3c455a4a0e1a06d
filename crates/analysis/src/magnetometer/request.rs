//! What a caller of `magfit` asks for, as one typed value (issue 48): the samples, the model,
//! the columns and the columns the hard iron may follow, which the command line
//! (`wiical magfit`) and the Python package (`wiical.magfit`) both take, with the fit and the
//! residual loop run by one function. Argument errors name no flag: the column list is
//! [`crate::Error::ColumnsNotThree`], a followed column with empty rows
//! [`MagnetometerError::FollowRows`].

use super::{analyze_source, fit_source, pass, Follow, MagAnalysis, MagFitReport, MagModel};
use crate::error::magnetometer::MagnetometerError;
use crate::input::columns::Sensor;
use crate::input::read_options::ReadOptions;
use crate::input::text::LoadOptions;
use crate::request::SampleInput;
use crate::source::RowSource;

/// A `magfit` request. [`MagfitRequest::new`] has the defaults: the ellipsoid, the triplet the
/// header names as the magnetometer, nothing followed, the loader's reading.
#[derive(Debug, Clone)]
pub struct MagfitRequest {
    /// The field's samples.
    pub input: SampleInput,
    /// Sphere, axis-aligned or full ellipsoid.
    pub model: MagModel,
    /// Header names of the x,y,z columns (three; `None`: the magnetometer's triplet).
    pub columns: Option<Vec<String>>,
    /// Header names of columns the hard iron may follow (current, throttle, PWM), each tested
    /// as an interference `offset = k × column`; read from the file, in step with its rows.
    pub follow: Vec<String>,
    /// How the file is read.
    pub read: ReadOptions,
}

/// What `magfit` reports: the fit's keys, then the residual loop's (one JSON object, the
/// command's `--json`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct MagfitOutput {
    /// The hard/soft-iron fit.
    #[serde(flatten)]
    pub fit: MagFitReport,
    /// The residual loop: noise floor, effects, detection limits, verdict.
    #[serde(flatten)]
    pub analysis: MagAnalysis,
    /// The field's unit as its columns name it (`raw` when the header does not say).
    #[serde(skip)]
    pub unit: &'static str,
}

impl MagfitRequest {
    /// The request for `input` with every setting at its default.
    pub fn new(input: impl Into<SampleInput>) -> Self {
        Self {
            input: input.into(),
            model: MagModel::Ellipsoid,
            columns: None,
            follow: Vec::new(),
            read: ReadOptions::default(),
        }
    }

    /// The loader's options for the field: the columns given (checked: three), else the
    /// triplet the header names as the magnetometer.
    pub fn load_options(&self) -> crate::Result<LoadOptions> {
        Ok(LoadOptions {
            sensor: Some(Sensor::Magnetometer),
            ..crate::request::load_options(self.columns.as_deref(), self.read)?
        })
    }

    /// How the followed column `name` is read beside a field whose axes are `field_axes`, so
    /// that its rows are the field's ([`pass::follow_options`]).
    pub fn follow_options(&self, name: &str, field_axes: &[String; 3]) -> LoadOptions {
        pass::follow_options(name, field_axes, &self.read)
    }

    /// The fit of `field` (held or read in passes: the same code), then its followed
    /// columns, each opened by `open` (held or in passes, as the field is) and refused unless
    /// it has the field's rows, then the residual loop at the selection's level
    /// ([`crate::search::select::ALPHA`]). `E`: the error of `open`, which holds the engine's.
    pub fn run<R: RowSource, E: From<crate::Error>>(
        &self,
        field: &R,
        open: impl Fn(&str, &LoadOptions) -> Result<R, E>,
    ) -> Result<MagfitOutput, E> {
        let prep = fit_source(field, self.model)?;
        let follow = self.follow_columns(field, open)?;
        let alpha = crate::search::select::ALPHA;
        let analysis = analyze_source(field, &prep, &follow, self.model, alpha)?;
        Ok(MagfitOutput {
            fit: prep.report,
            analysis,
            unit: pass::unit_of(field),
        })
    }

    /// The followed columns of `field`, each opened by `open` and checked against its rows.
    fn follow_columns<R: RowSource, E: From<crate::Error>>(
        &self,
        field: &R,
        open: impl Fn(&str, &LoadOptions) -> Result<R, E>,
    ) -> Result<Vec<Follow<R>>, E> {
        let mut out = Vec::new();
        for name in &self.follow {
            let col = open(name, &self.follow_options(name, field.axis_columns()))?;
            if col.len() != field.len() {
                let e = MagnetometerError::FollowRows {
                    column: name.clone(),
                    got: col.len(),
                    rows: field.len(),
                };
                return Err(crate::Error::from(e).into());
            }
            out.push((name.clone(), col));
        }
        Ok(out)
    }
}

/// Runs `magfit` as the library call: the field read whole (or the samples held), its
/// followed columns from the same file, the fit and the residual loop. The command line reads
/// a large plain text file in passes instead and runs the same [`MagfitRequest::run`].
pub fn magfit(req: &MagfitRequest) -> crate::Result<MagfitOutput> {
    let field = crate::request::held(&req.input, &req.load_options()?)?;
    match &req.input {
        SampleInput::Held(_) if !req.follow.is_empty() => {
            Err(MagnetometerError::FollowNeedsFile.into())
        }
        SampleInput::Held(_) => req.run(field.as_ref(), |_, _| {
            Err(MagnetometerError::FollowNeedsFile.into())
        }),
        SampleInput::File(path) => req.run(field.as_ref(), |_, o| crate::load(path, o)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on a sphere of radius 2 about (1, −1, 0.5), turned through every orientation.
    fn sphere() -> crate::input::recording::Recording {
        let mut xyz = Vec::new();
        for i in 0..40 {
            for j in 0..20 {
                let (az, el) = (i as f64 * 0.157, (j as f64 - 9.5) * 0.15);
                let noise = ((i * 7 + j * 13) % 5) as f64 * 1e-3;
                let r = 2.0 + noise;
                xyz.push([
                    1.0 + r * el.cos() * az.cos(),
                    -1.0 + r * el.cos() * az.sin(),
                    0.5 + r * el.sin(),
                ]);
            }
        }
        crate::arrays::recording(xyz, None, None).unwrap()
    }

    #[test]
    fn held_samples_fit_about_their_centre() {
        let mut req = MagfitRequest::new(sphere());
        req.model = MagModel::Sphere;
        let out = magfit(&req).unwrap();
        for (c, want) in out.fit.center.iter().zip([1.0, -1.0, 0.5]) {
            assert!((c - want).abs() < 0.01, "{:?}", out.fit.center);
        }
        assert!((out.fit.radius - 2.0).abs() < 0.01, "{}", out.fit.radius);
        assert_eq!(out.unit, "raw");
    }

    #[test]
    fn arguments_are_checked_before_the_fit() {
        let mut req = MagfitRequest::new(sphere());
        req.follow = vec!["current".into()];
        assert!(matches!(
            magfit(&req),
            Err(crate::Error::Magnetometer(
                MagnetometerError::FollowNeedsFile
            ))
        ));
        let mut req = MagfitRequest::new("no-such-file.csv");
        req.columns = Some(vec!["a".into()]);
        assert!(matches!(
            magfit(&req),
            Err(crate::Error::ColumnsNotThree(_))
        ));
    }
}
