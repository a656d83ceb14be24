//! The `segment` stage's parameters, typed: read once from the values its
//! [`SPEC`](super::stage::SPEC) declares, so the stage names none by string.
//! (The segmentation's own tuning, [`SegmentParams`](super::SegmentParams),
//! is not a stage parameter.)

use std::path::PathBuf;

use coapt_base::{Error, Result};
use coapt_pipeline::Params;

/// Meaning and default of each: `SPEC.params`.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentStageParams {
    /// Where to write PNG slices with the mask contour (none when unset).
    pub debug_dir: Option<PathBuf>,
}

impl TryFrom<&Params> for SegmentStageParams {
    type Error = Error;

    fn try_from(p: &Params) -> Result<Self> {
        Ok(SegmentStageParams {
            debug_dir: p.path("debug_dir")?.map(PathBuf::from),
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
        assert_reads_exactly(&SPEC, |p| SegmentStageParams::try_from(p));
    }
}
