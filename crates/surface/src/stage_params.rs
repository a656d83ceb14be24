//! The `surface` stage's parameters, typed: read once from the values its
//! [`SPEC`](super::stage::SPEC) declares into the [`SurfaceParams`] the
//! surface is built with, so the stage names none by string.

use super::{RemeshParams, SurfaceParams, Taubin};
use coapt_base::units::Kind;
use coapt_base::{Error, Result};
use coapt_pipeline::Params;

impl TryFrom<&Params> for SurfaceParams {
    type Error = Error;

    /// Also judges the ranges a surface can be built with, so `check`
    /// and `run` refuse the same values with the same words.
    fn try_from(p: &Params) -> Result<Self> {
        let blur = p.quantity("blur", Kind::Length)?;
        if !(0.0..=20.0).contains(&blur) {
            return Err(Error::value(format!("blur {blur} mm: expected 0 to 20 mm")));
        }
        let remesh = match p.quantity_opt("target_edge", Kind::Length)? {
            Some(l) if (0.05..=50.0).contains(&l) => Some(RemeshParams::new(l)),
            Some(l) => {
                return Err(Error::value(format!(
                    "target edge {l} mm: expected 0.05 to 50 mm"
                )));
            }
            None => None,
        };
        Ok(SurfaceParams {
            iso: p.float("iso")?,
            blur_sigma_mm: blur,
            taubin: Taubin {
                iterations: p.int("smooth")? as usize,
                ..Taubin::default()
            },
            largest_only: !p.flag("keep_all")?,
            remesh,
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
        assert_reads_exactly(&SPEC, |p| SurfaceParams::try_from(p));
    }
}
