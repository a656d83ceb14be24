//! The `leaflets` stage's parameters, typed: read once from the values its
//! [`SPEC`](super::stage::SPEC) declares, so the stage names none by string.

use super::place::Gathering;
use coapt_base::units::Kind;
use coapt_base::{Error, Result};
use coapt_pipeline::Params;

/// How a flat template is put into the root (`placement`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Placement {
    /// Free edge a taut V from commissure to centre to commissure, columns
    /// bowed between it and the suture line (see `leaflet::hang`).
    Hanging,
    /// Columns along ω from the suture line.
    Extruded,
}

/// Meaning and default of each: `SPEC.params`.
#[derive(Debug, Clone, PartialEq)]
pub struct LeafletParams {
    /// Mesh size (mm).
    pub h_mm: f64,
    /// Extrusion lean (rad; negative leans towards the axis); a
    /// five-parameter template's own ω wins.
    pub omega_rad: f64,
    /// Flat templates only: five-parameter ones are always extruded.
    pub placement: Placement,
    /// Hanging placement: each free edge's apex this far off the axis (mm).
    pub clearance_mm: f64,
    /// How a flat template's longer attachment edge is gathered onto its path.
    pub gathering: Gathering,
    /// Fibre angle θ on the flat template (rad).
    pub fiber_angle_rad: f64,
}

impl TryFrom<&Params> for LeafletParams {
    type Error = Error;

    fn try_from(p: &Params) -> Result<Self> {
        let placement = match p.choice("placement")? {
            "hanging" => Placement::Hanging,
            "extruded" => Placement::Extruded,
            other => return Err(p.unknown_choice("placement", other)),
        };
        let gathering = match p.choice("gathering")? {
            "ozaki" => Gathering::Ozaki,
            "uniform" => Gathering::Uniform,
            other => return Err(p.unknown_choice("gathering", other)),
        };
        Ok(LeafletParams {
            h_mm: p.quantity("h", Kind::Length)?,
            omega_rad: p.quantity("omega", Kind::Angle)?,
            placement,
            clearance_mm: p.quantity("clearance", Kind::Length)?,
            gathering,
            fiber_angle_rad: p.quantity("fiber_angle", Kind::Angle)?,
        })
    }
}

impl LeafletParams {
    /// The values leaflets can be meshed and placed with, judged before any
    /// stage runs.
    pub fn check(&self) -> Result<()> {
        if self.h_mm.is_nan() || self.h_mm <= 0.0 {
            return Err(Error::value(format!(
                "leaflets h (--h) must be positive, got {} mm",
                self.h_mm
            )));
        }
        if !(self.clearance_mm >= 0.0 && self.clearance_mm <= 5.0) {
            return Err(Error::value("clearance must lie in 0–5 mm"));
        }
        if self.omega_rad.is_nan() || self.omega_rad.abs() >= 1.5 {
            return Err(Error::value("omega must lie in (−86°, 86°)"));
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
        assert_reads_exactly(&SPEC, |p| LeafletParams::try_from(p));
    }
}
