//! The `phantom` stage's parameters, typed: read once from the values its
//! [`SPEC`](super::stage::SPEC) declares into the [`PhantomParams`] the
//! generator takes, so the stage names none by string.

use super::{PhantomParams, Preset};
use coapt_base::units::Kind;
use coapt_base::{Error, Result};
use coapt_pipeline::Params;

impl TryFrom<&Params> for PhantomParams {
    type Error = Error;

    /// Unset quantities keep the preset's default ([`PhantomParams::new`]);
    /// the result is validated, so `check` and `run` refuse the same values.
    fn try_from(p: &Params) -> Result<Self> {
        let preset: Preset = p.choice("preset")?.parse()?;
        let mut pp = PhantomParams::new(preset, p.int("seed")? as u64);
        if let Some(noise) = p.quantity_opt("noise", Kind::Intensity)? {
            pp.noise_hu = noise;
        }
        if let Some(tilt) = p.quantity_opt("tilt", Kind::Angle)? {
            pp.tilt_rad = tilt;
        }
        pp.spacing_mm = p.lengths3("spacing")?;
        pp.contrast = p.flag("contrast")?;
        if let Some(blood) = p.quantity_opt("blood", Kind::Intensity)? {
            pp.blood_hu = blood;
        }
        pp.calcium = p.flag("calcium")?;
        pp.coronaries = p.flag("coronaries")?;
        // The clinical preset has them on whatever is asked.
        pp.arch |= p.flag("arch")?;
        pp.native_cusps |= p.flag("native_cusps")?;
        if let Some(tilt) = p.quantity_opt("annulus_tilt", Kind::Angle)? {
            pp.annulus_tilt_rad = tilt;
        }
        pp.root_rotation_rad = p.quantity("root_rotation", Kind::Angle)?;
        pp.validate()?;
        Ok(pp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage::SPEC;
    use coapt_pipeline::params::assert_reads_exactly;

    #[test]
    fn reads_exactly_the_declared_parameters() {
        assert_reads_exactly(&SPEC, |p| PhantomParams::try_from(p));
    }
}
