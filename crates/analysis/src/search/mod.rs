//! The search: a base fit and its windows in → the effects the residual asks for, one per
//! greedy step, with the evidence, out ([`analyze::analyze`], `wiical analyze`).
//!
//! [`floor`] gives the noise floor the residual is compared with; [`candidate`] lists the
//! effects, [`trial`] and [`outliers`] fit and test each one, [`select`] holds the rule that
//! picks one, [`evidence`] says why, [`limits`] how large what was not found could be; [`six_contrasts`] is the residual analysis of a
//! six-position file; `options` the settings; `bias_step` the knock searched before the
//! candidates.

pub(crate) mod analyze;
pub(crate) mod bias_step;
pub mod candidate;
pub mod correlates;
pub mod evidence;
pub mod floor;
pub mod limits;
pub mod open_basis_screening;
pub(crate) mod options;
pub mod outliers;
pub mod select;
pub mod six_contrasts;
pub mod thermal;
pub mod trial;

pub use crate::error::search::SearchError;
