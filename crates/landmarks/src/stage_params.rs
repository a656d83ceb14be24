//! The `landmarks` stage's parameters, typed: read once from the values its
//! [`SPEC`](super::stage::SPEC) declares, so the stage names none by string.

use coapt_base::{Error, Result};
use coapt_pipeline::Params;

/// Meaning, default and range of each: `SPEC.params`.
#[derive(Debug, Clone, PartialEq)]
pub struct LandmarksParams {
    /// A detected point with less confidence (0–1) is listed as a finding.
    pub min_confidence: f64,
}

impl TryFrom<&Params> for LandmarksParams {
    type Error = Error;

    fn try_from(p: &Params) -> Result<Self> {
        Ok(LandmarksParams {
            min_confidence: p.float("min_confidence")?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage::SPEC;
    use coapt_pipeline::params::assert_reads_exactly;

    #[test]
    fn reads_exactly_the_declared_parameters() {
        assert_reads_exactly(&SPEC, |p| LandmarksParams::try_from(p));
    }
}
