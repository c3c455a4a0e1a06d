//! A recording whose still windows are the six faces, as the six-position analysis reads it:
//! each face's samples (all its windows, in time order) in one block labelled with the face
//! (`x+ … z-`), so that `analyze` runs the seed's residual contrasts
//! ([`crate::search::six_contrasts`]) on a recording nobody labelled.

use super::{recognise, AccelProtocol, AccelRecognition};
use crate::detect::windows::Windows;
use crate::error::fit::FitError;
use crate::input::recording::Recording;
use crate::source::{RowBuf, RowSource};
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

/// The labelled recording of the face windows `ws` of the rows of `src` (held, or a large
/// file whose windows' rows are read from where it keeps them) when they are the six faces;
/// `None` for free poses (today's pipeline); an error naming the protocol when the windows are
/// one pose or an incomplete set of faces, which the residual analysis cannot take. A failed
/// read ends the rows early, which [`RowSource::check`] then says.
pub fn faces_recording<R: RowSource + ?Sized>(
    src: &R,
    ws: &Windows,
) -> Result<Option<Recording>, FitError> {
    let r = recognise(ws);
    if !six_faces_or_free(&r)? {
        return Ok(None);
    }
    let mut out = Recording {
        axis_columns: src.axis_columns().clone(),
        sample_rate_hz: src.metadata_rate_hz(),
        temp: src.has_temp().then(Vec::new),
        ..Default::default()
    };
    let mut labels = Vec::new();
    let mut buf = RowBuf::default();
    for pose in Pose::ALL {
        let faces = ws.stats.iter().zip(&r.faces);
        for (w, _) in faces.filter(|(_, f)| f.pose == Some(pose)) {
            let (mut at, end) = (w.start, w.end.min(src.len()));
            while let Some(rows) = (at < end).then(|| src.span((at, end), &mut buf)).flatten() {
                out.xyz.extend_from_slice(rows.xyz);
                if let (Some(t), Some(read)) = (out.temp.as_mut(), rows.temp) {
                    t.extend_from_slice(read);
                }
                labels.extend(std::iter::repeat_n(
                    pose.label().to_string(),
                    rows.xyz.len(),
                ));
                at = if rows.xyz.is_empty() {
                    end
                } else {
                    at + rows.xyz.len()
                };
            }
        }
    }
    out.labels = Some(labels);
    Ok(Some(out))
}
