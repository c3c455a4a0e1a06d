//! What the pipelines give: the report types of the JSON contract ([`contract`], with the
//! residual's correlates in [`correlate`] and the time and temperature terms in `host_term`),
//! the effect names that contract uses
//! ([`effect_names`]), the quality verdict `device put` checks ([`verdict`]) and the progress
//! hook a long analysis calls ([`progress`]).

pub mod contract;
pub mod correlate;
pub mod effect_names;
pub mod effect_table;
pub(crate) mod host_term;
pub mod progress;
pub mod verdict;
