//! Every effect the accelerometer analysis names, one row each: the analysis's candidates
//! ([`crate::search::candidate::Candidate`]), the open basis's families
//! ([`crate::search::open_basis_screening`]) and the simulator's effects
//! (`wiical_sim::SimEffect`) are one enum, [`Effect`], whose names and properties
//! come from [`EFFECTS`]. A row that is a term of the core's calibration names its
//! [`TermId`], and what the core's table ([`wiical_core::terms::TERMS`]) says of that term
//! (what it needs besides the reading) is taken from there, not restated; the rows that are
//! not calibration terms (outliers, the curved drift, the time and temperature families the
//! core cannot hold, the simulator's `none`) say it themselves.
//!
//! A new effect is a variant of [`Effect`] and its row here; the model's parameter block
//! ([`crate::fit::model::Term`]) or open-basis family, and the simulator's draw, are code.

use crate::report::effect_names as names;
use wiical_core::terms::{self, Needs, TermId};

/// One effect of the analysis (a candidate, an open-basis family, or what the simulator
/// puts in). `Display` writes its name (the JSON contract's `effects[].name`, the CLI's
/// `--candidates` and `--effect`).
///
/// The candidates come first, in the order they are tried and listed, so that the derived
/// order and hash of a candidate are what they were when candidates had an enum of their own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Effect {
    /// Per-axis quadratic nonlinearity `k2·u²`.
    Quadratic,
    /// Per-axis cubic nonlinearity `k3·u³`.
    Cubic,
    /// Bias linear in time.
    BiasDrift,
    /// Bias linear in temperature.
    Temperature,
    /// Scale linear in temperature.
    TemperatureScale,
    /// Windows that were not still (rejected, not modelled); in a simulation, a few poses
    /// that were not still.
    Outliers,
    /// Bias linear + quadratic in time: a diagnostic only, the core cannot store it.
    BiasDriftCurved,
    /// One orientation-dependent degree-2 cross term `a_i += c·u_j·u_k` (open basis).
    CrossQuadratic,
    /// One orientation-dependent degree-3 cross term `a_i += c·u_j·u_k·u_l` (open basis).
    CrossCubic,
    /// Scale linear in time (open basis).
    ScaleDrift,
    /// Scale quadratic in time (open basis).
    ScaleDriftCurved,
    /// Bias quadratic in temperature (open basis).
    TemperatureSquared,
    /// Bias cubic in temperature (open basis).
    TemperatureCubed,
    /// Scale quadratic in temperature (open basis).
    TemperatureScaleSquared,
    /// Scale cubic in temperature (open basis).
    TemperatureScaleCubed,
    /// Bias linear in the temperature seen through a first-order lag (open basis).
    ThermalLag,
    /// Bias linear in the temperature rate dθ/dt (open basis).
    TemperatureRate,
    /// The simulator's "linear model only" (no effect put in; never a candidate).
    None,
}

/// How the analysis looks for an effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Search {
    /// A candidate of the greedy search, which may be added to the model.
    Candidate,
    /// A candidate that is tried and reported but never added: the core's calibration
    /// cannot hold it.
    Diagnostic,
    /// A family of the open basis, searched term by term after the candidates.
    OpenBasis,
    /// Not searched for (the simulator's `none`).
    NotSearched,
}

/// One row of [`EFFECTS`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffectRow {
    /// Which effect.
    pub effect: Effect,
    /// Its name ([`crate::report::effect_names`]).
    pub name: &'static str,
    /// The core calibration's term that holds it, if one does.
    pub core: Option<TermId>,
    /// What applying it needs besides the reading: the core's table's for a core term.
    pub needs: Needs,
    /// How the analysis looks for it.
    pub search: Search,
    /// True when the simulator can put it into a recording.
    pub simulated: bool,
    /// The simulator's default magnitude, mg: clearly detectable in a default recording.
    pub default_magnitude_mg: f64,
}

/// A row for an effect the core's calibration holds: what it needs is the core's.
const fn core_row(
    effect: Effect,
    name: &'static str,
    core: TermId,
    search: Search,
    default_magnitude_mg: f64,
) -> EffectRow {
    EffectRow {
        effect,
        name,
        core: Some(core),
        needs: terms::spec(core).needs,
        search,
        simulated: true,
        default_magnitude_mg,
    }
}

/// A row for an effect the core's calibration does not hold.
const fn own_row(
    effect: Effect,
    name: &'static str,
    needs: Needs,
    search: Search,
    simulated: bool,
    default_magnitude_mg: f64,
) -> EffectRow {
    EffectRow {
        effect,
        name,
        core: None,
        needs,
        search,
        simulated,
        default_magnitude_mg,
    }
}

/// Every effect, in the order the simulator lists them (`none` first, then the candidates'
/// kinds, then the open basis); the candidates keep their own order among them.
pub const EFFECTS: [EffectRow; 18] = {
    use Effect as E;
    use Search::{Candidate as C, Diagnostic as D, OpenBasis as O};
    [
        own_row(
            E::None,
            names::NONE,
            Needs::Reading,
            Search::NotSearched,
            true,
            0.0,
        ),
        core_row(E::Quadratic, names::QUADRATIC, TermId::Quadratic, C, 20.0),
        core_row(E::Cubic, names::CUBIC, TermId::Cubic, C, 30.0),
        core_row(E::BiasDrift, names::BIAS_DRIFT, TermId::BiasDrift, C, 10.0),
        core_row(
            E::Temperature,
            names::TEMPERATURE,
            TermId::BiasTemp,
            C,
            10.0,
        ),
        core_row(
            E::TemperatureScale,
            names::TEMPERATURE_SCALE,
            TermId::ScaleTemp,
            C,
            10.0,
        ),
        own_row(E::Outliers, names::OUTLIERS, Needs::Reading, C, true, 10.0),
        own_row(
            E::BiasDriftCurved,
            names::BIAS_DRIFT_CURVED,
            Needs::Time,
            D,
            false,
            0.0,
        ),
        core_row(
            E::CrossQuadratic,
            names::CROSS_QUADRATIC,
            TermId::CrossQuadratic,
            O,
            20.0,
        ),
        core_row(
            E::CrossCubic,
            names::CROSS_CUBIC,
            TermId::CrossCubic,
            O,
            30.0,
        ),
        own_row(
            E::ScaleDrift,
            names::SCALE_DRIFT,
            Needs::Time,
            O,
            true,
            10.0,
        ),
        own_row(
            E::ScaleDriftCurved,
            names::SCALE_DRIFT_CURVED,
            Needs::Time,
            O,
            true,
            10.0,
        ),
        own_row(
            E::TemperatureSquared,
            names::TEMPERATURE_SQUARED,
            Needs::Temperature,
            O,
            true,
            10.0,
        ),
        own_row(
            E::TemperatureCubed,
            names::TEMPERATURE_CUBED,
            Needs::Temperature,
            O,
            true,
            10.0,
        ),
        own_row(
            E::TemperatureScaleSquared,
            names::TEMPERATURE_SCALE_SQUARED,
            Needs::Temperature,
            O,
            true,
            10.0,
        ),
        own_row(
            E::TemperatureScaleCubed,
            names::TEMPERATURE_SCALE_CUBED,
            Needs::Temperature,
            O,
            true,
            10.0,
        ),
        own_row(
            E::ThermalLag,
            names::THERMAL_LAG,
            Needs::Temperature,
            O,
            true,
            10.0,
        ),
        own_row(
            E::TemperatureRate,
            names::TEMPERATURE_RATE,
            Needs::Temperature,
            O,
            true,
            10.0,
        ),
    ]
};

/// Which effects a list of [`Effect`] holds.
#[derive(Clone, Copy)]
enum Selection {
    /// The greedy search's candidates, diagnostics included.
    Candidates,
    /// The simulator's `none` and the candidates' kinds it can simulate.
    SimulatedCandidates,
    /// The open basis's families.
    OpenBasis,
}

/// True when `row` belongs to `which`.
const fn keeps(which: Selection, row: &EffectRow) -> bool {
    match which {
        Selection::Candidates => matches!(row.search, Search::Candidate | Search::Diagnostic),
        Selection::SimulatedCandidates => {
            row.simulated && matches!(row.search, Search::NotSearched | Search::Candidate)
        }
        Selection::OpenBasis => matches!(row.search, Search::OpenBasis),
    }
}

/// The effects of [`EFFECTS`] that `which` holds, in the table's order (`N` must be their
/// number: a wrong count fails to compile).
const fn select<const N: usize>(which: Selection) -> [Effect; N] {
    let mut out = [Effect::None; N];
    let (mut i, mut n) = (0, 0);
    while i < EFFECTS.len() {
        if keeps(which, &EFFECTS[i]) {
            assert!(n < N, "the count of a selection of EFFECTS");
            out[n] = EFFECTS[i].effect;
            n += 1;
        }
        i += 1;
    }
    assert!(n == N, "the count of a selection of EFFECTS");
    out
}

impl Effect {
    /// The candidates of the greedy search, in the order they are tried and listed.
    pub const CANDIDATES: [Effect; 7] = select(Selection::Candidates);

    /// What the simulator puts in besides the open basis: `none`, then the candidates' kinds
    /// it can simulate (see [`Self::OPEN_BASIS`] for the others and [`Self::simulated`] for
    /// both).
    pub const SIMULATED_CANDIDATES: [Effect; 7] = select(Selection::SimulatedCandidates);

    /// The open basis's families ([`crate::search::open_basis_screening`]; the simulator's
    /// `wiical_sim::open_basis_terms`).
    pub const OPEN_BASIS: [Effect; 10] = select(Selection::OpenBasis);

    /// This effect's row.
    pub const fn row(self) -> &'static EffectRow {
        let mut i = 0;
        while i < EFFECTS.len() {
            if EFFECTS[i].effect as u8 == self as u8 {
                return &EFFECTS[i];
            }
            i += 1;
        }
        panic!("every Effect has a row in EFFECTS")
    }

    /// Its name ([`crate::report::effect_names`]).
    pub fn name(self) -> &'static str {
        self.row().name
    }

    /// Every effect the simulator can put in: [`Self::SIMULATED_CANDIDATES`], then
    /// [`Self::OPEN_BASIS`].
    pub fn simulated() -> impl Iterator<Item = Effect> {
        EFFECTS.iter().filter(|r| r.simulated).map(|r| r.effect)
    }

    /// The simulated effect named `s` ([`Self::simulated`]).
    pub fn parse_simulated(s: &str) -> Option<Self> {
        Self::simulated().find(|e| e.name() == s)
    }

    /// The simulator's default magnitude, mg: clearly detectable in a default recording.
    pub fn default_magnitude_mg(self) -> f64 {
        self.row().default_magnitude_mg
    }

    /// True when the effect needs the temperature column (the simulator then always writes
    /// it).
    pub fn needs_temperature(self) -> bool {
        self.row().needs == Needs::Temperature
    }

    /// False for diagnostics the core's `Effects` cannot hold (never added).
    pub fn storable(self) -> bool {
        self.row().search != Search::Diagnostic
    }

    /// The comma-separated names of the candidates (for messages).
    pub fn candidate_names() -> String {
        Self::CANDIDATES.map(Effect::name).join(", ")
    }
}

impl std::fmt::Display for Effect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table against what the candidates, the open basis and the simulator listed when
    /// each had its own enum (written out by hand), and against the core's table.
    #[test]
    fn the_table_lists_what_the_enums_listed() {
        let names = |v: &[Effect]| v.iter().map(|e| e.name()).collect::<Vec<_>>().join(",");
        assert_eq!(
            names(&Effect::CANDIDATES),
            "quadratic,cubic,bias-drift,temperature,temperature-scale,outliers,bias-drift-curved"
        );
        assert_eq!(
            names(&Effect::SIMULATED_CANDIDATES),
            "none,quadratic,cubic,bias-drift,temperature,temperature-scale,outliers"
        );
        assert_eq!(
            names(&Effect::OPEN_BASIS),
            "cross-quadratic,cross-cubic,scale-drift,scale-drift-curved,temperature-squared,\
             temperature-cubed,temperature-scale-squared,temperature-scale-cubed,thermal-lag,\
             temperature-rate"
        );
        assert_eq!(Effect::simulated().count(), 17);
        let temperature: Vec<Effect> = Effect::simulated()
            .filter(|e| e.needs_temperature())
            .collect();
        assert_eq!(
            names(&temperature),
            "temperature,temperature-scale,temperature-squared,temperature-cubed,\
             temperature-scale-squared,temperature-scale-cubed,thermal-lag,temperature-rate"
        );
        for (i, r) in EFFECTS.iter().enumerate() {
            assert_eq!(r.effect.row(), r, "{i}");
            assert_eq!(
                Effect::parse_simulated(r.name),
                r.simulated.then_some(r.effect)
            );
            if let Some(id) = r.core {
                // A core term's name is the core's, with the contract's dashes, except the
                // two temperature candidates, which the contract names by what they move.
                let core = terms::spec(id).name.replace('_', "-");
                match r.effect {
                    Effect::Temperature => assert_eq!(core, "bias-temp"),
                    Effect::TemperatureScale => assert_eq!(core, "scale-temp"),
                    _ => assert_eq!(core, r.name),
                }
            }
        }
        // Every accelerometer effect term of the core has one row.
        for id in [
            TermId::Quadratic,
            TermId::Cubic,
            TermId::BiasDrift,
            TermId::BiasTemp,
            TermId::ScaleTemp,
            TermId::CrossQuadratic,
            TermId::CrossCubic,
        ] {
            let rows = EFFECTS.iter().filter(|r| r.core == Some(id)).count();
            assert_eq!(rows, 1, "{id:?}");
        }
        assert!(!Effect::BiasDriftCurved.storable() && Effect::Outliers.storable());
    }
}
