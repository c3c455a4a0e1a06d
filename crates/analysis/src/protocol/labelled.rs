//! A recording whose still windows are the six faces, as the six-position analysis reads it:
//! each face's samples (all its windows, in time order) in one block labelled with the face
//! (`x+ … z-`), so that `analyze` runs the seed's residual contrasts
//! ([`crate::search::six_contrasts`]) on a recording nobody labelled.

use super::{recognise, AccelProtocol, AccelRecognition};
use crate::detect::windows::Windows;
use crate::error::fit::FitError;
use crate::input::recording::Recording;
use wiical_core::six_position::Pose;

/// Whether the residual analysis can take windows recognised as `r`: `Ok(false)` for free
/// poses (today's pipeline), `Ok(true)` for the six faces, and an error naming the protocol
/// for one pose or an incomplete set of faces.
pub fn six_faces_or_free(r: &AccelRecognition) -> Result<bool, FitError> {
    match r.protocol {
        AccelProtocol::None | AccelProtocol::FreePoses => Ok(false),
        AccelProtocol::Faces if r.set.missing.is_empty() => Ok(true),
        _ => Err(FitError::Protocol {
            summary: r.summary(),
            why: "the residual analysis needs free poses or all six faces; `wiical fit` (or \
                  `calibrate`) gives what these poses identify"
                .into(),
        }),
    }
}

/// The labelled recording of `rec`'s face windows `ws` when they are the six faces; `None`
/// for free poses (today's pipeline); an error naming the protocol when the windows are one
/// pose or an incomplete set of faces, which the residual analysis cannot take.
pub fn faces_recording(rec: &Recording, ws: &Windows) -> Result<Option<Recording>, FitError> {
    let r = recognise(ws);
    if !six_faces_or_free(&r)? {
        return Ok(None);
    }
    let mut out = Recording {
        axis_columns: rec.axis_columns.clone(),
        sample_rate_hz: rec.sample_rate_hz,
        ..Default::default()
    };
    let mut labels = Vec::new();
    let mut temp = rec.temp.as_ref().map(|_| Vec::new());
    for pose in Pose::ALL {
        for (w, f) in ws.stats.iter().zip(&r.faces) {
            if f.pose != Some(pose) {
                continue;
            }
            let span = w.start..w.end.min(rec.len());
            out.xyz.extend_from_slice(&rec.xyz[span.clone()]);
            labels.extend(std::iter::repeat_n(pose.label().to_string(), span.len()));
            if let (Some(t), Some(src)) = (temp.as_mut(), rec.temp.as_ref()) {
                t.extend_from_slice(&src[span]);
            }
        }
    }
    out.labels = Some(labels);
    out.temp = temp;
    Ok(Some(out))
}
