//! The `valve` stage's parameters, typed: read once from the values its
//! [`SPEC`](super::stage::SPEC) declares, so the stage names none by string.

use coapt_base::units::Kind;
use coapt_base::{Error, Result};
use coapt_pipeline::Params;

/// Longest straight part under a commissure (mm).
const HC_MAX_MM: f64 = 10.0;
/// The paths' point spacing that makes sense (mm).
const SPACING_MM: (f64, f64) = (0.01, 5.0);

/// Meaning and default of each: `SPEC.params`.
#[derive(Debug, Clone, PartialEq)]
pub struct ValveParams {
    /// Straight part of each path below its commissure (mm); a
    /// five-parameter template's own H_c wins.
    pub hc_mm: f64,
    /// Largest point spacing along the paths (mm).
    pub spacing_mm: f64,
}

impl TryFrom<&Params> for ValveParams {
    type Error = Error;

    fn try_from(p: &Params) -> Result<Self> {
        Ok(ValveParams {
            hc_mm: p.quantity("hc", Kind::Length)?,
            spacing_mm: p.quantity("spacing", Kind::Length)?,
        })
    }
}

impl ValveParams {
    /// The values a valve can be built with, judged before any stage runs.
    pub fn check(&self) -> Result<()> {
        // The straight part under a commissure is a few millimetres (seed
        // 001: 1.5); 1000 mm made 72–90 mm paths that nothing refused.
        let hc = self.hc_mm;
        if !(0.0..=HC_MAX_MM).contains(&hc) {
            return Err(Error::value(format!(
                "--hc {hc} mm: the straight part under each commissure must lie in 0–{HC_MAX_MM} mm (a commissure stands 15–25 mm above the annulus)"
            )));
        }
        // Points per path ∝ 1/spacing: below the wall's own resolution
        // (vertices ≈ 0.5 mm apart) a finer spacing adds nothing, and
        // 1e-9 mm asked for 568 GB.
        let sp = self.spacing_mm;
        if !(SPACING_MM.0..=SPACING_MM.1).contains(&sp) {
            return Err(Error::value(format!(
                "--spacing {sp} mm: the suture paths would hold about {:.0e} points each; it must lie in {}–{} mm",
                150.0 / sp.max(1e-300),
                SPACING_MM.0,
                SPACING_MM.1
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage::SPEC;
    use coapt_pipeline::params::assert_reads_exactly;

    #[test]
    fn reads_exactly_the_declared_parameters() {
        assert_reads_exactly(&SPEC, |p| ValveParams::try_from(p));
    }
}
