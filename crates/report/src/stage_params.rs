//! The `report` stage's parameters, typed: read once from the values its
//! [`SPEC`](super::stage::SPEC) declares, so the stage names none by string.

use std::path::PathBuf;

use coapt_base::units::{self, Kind};
use coapt_base::{Error, Result};
use coapt_pipeline::Params;

/// Narrowest column across a coaptation strip (mm).
const MIN_COLUMN_MM: f64 = 0.01;

/// Meaning and default of each: `SPEC.params`.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportParams {
    /// Contact margin (mm); unset: from the closure's thickness or the
    /// commissures' radius.
    pub margin_mm: Option<f64>,
    /// Sub-triangles per edge where a triangle is partly in contact.
    pub refine: usize,
    /// Radial columns across a coaptation strip (mm).
    pub column_width_mm: f64,
    /// Distance from the axis at which h_C-C is read (mm).
    pub hcc_radius_mm: f64,
    /// Criterion: central coaptation height must exceed this (mm).
    pub min_central_coaptation_mm: f64,
    /// Criterion: effective height must exceed this (mm).
    pub min_effective_height_mm: f64,
    /// Criterion: largest uncovered lumen area (mm²).
    pub max_regurgitant_orifice_mm2: f64,
    /// Criterion: deepest leaflet point below the sutured plane (mm).
    pub max_billowing_mm: f64,
    /// Run directory for timings and the optional inputs not given; unset:
    /// the folder of closed.vtp.
    pub run_dir: Option<PathBuf>,
}

impl TryFrom<&Params> for ReportParams {
    type Error = Error;

    fn try_from(p: &Params) -> Result<Self> {
        Ok(ReportParams {
            margin_mm: p.quantity_opt("margin", Kind::Length)?,
            refine: p.int("refine")? as usize,
            column_width_mm: p.quantity("column_width", Kind::Length)?,
            hcc_radius_mm: p.quantity("hcc_radius", Kind::Length)?,
            min_central_coaptation_mm: p.quantity("min_central_coaptation", Kind::Length)?,
            min_effective_height_mm: p.quantity("min_effective_height", Kind::Length)?,
            max_regurgitant_orifice_mm2: p.quantity("max_regurgitant_orifice", Kind::Area)?,
            max_billowing_mm: p.quantity("max_billowing", Kind::Length)?,
            run_dir: p.path("run_dir")?.map(PathBuf::from),
        })
    }
}

impl ReportParams {
    /// A criterion or a measure outside what a valve can show means nothing
    /// (a 1 km margin made every point "coapting" with exit 0): judged
    /// before any stage runs.
    pub fn check(&self) -> Result<()> {
        // Names as declared: the message gives the flag and the config key.
        let ranges: [(&str, Option<f64>, f64, f64, &str); 7] = [
            (
                "column_width",
                Some(self.column_width_mm),
                MIN_COLUMN_MM,
                10.0,
                "mm",
            ),
            ("hcc_radius", Some(self.hcc_radius_mm), 0.1, 30.0, "mm"),
            (
                "min_central_coaptation",
                Some(self.min_central_coaptation_mm),
                0.0,
                30.0,
                "mm",
            ),
            (
                "min_effective_height",
                Some(self.min_effective_height_mm),
                0.0,
                40.0,
                "mm",
            ),
            (
                "max_regurgitant_orifice",
                Some(self.max_regurgitant_orifice_mm2),
                0.0,
                1000.0,
                "mm²",
            ),
            (
                "max_billowing",
                Some(self.max_billowing_mm),
                0.0,
                30.0,
                "mm",
            ),
            ("margin", self.margin_mm, 0.01, 5.0, "mm"),
        ];
        for (name, v, lo, hi, unit) in ranges {
            let Some(v) = v else { continue };
            if v >= lo && v <= hi {
                continue;
            }
            let flag = name.replace('_', "-");
            // The strip's columns cost time ∝ 1/width (1e-6 mm ran past 120 s);
            // narrower than the 0.05 mm raster of the orifice they resolve nothing.
            let cost = if name == "column_width" && v > 0.0 && v < lo {
                format!("about {:.0e} columns per strip; ", 30.0 / v)
            } else {
                String::new()
            };
            return Err(Error::value(format!(
                "--{flag} {} {unit} (report.{name}): {cost}it must lie within {} {unit} to {} {unit}",
                units::short(v),
                units::short(lo),
                units::short(hi)
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
        assert_reads_exactly(&SPEC, |p| ReportParams::try_from(p));
    }

    #[test]
    fn an_out_of_range_margin_names_its_flag_and_config_key() {
        let defaults = Params::resolve(&SPEC, Default::default()).unwrap();
        let mut rp = ReportParams::try_from(&defaults).unwrap();
        rp.margin_mm = Some(-1.0);
        let e = rp.check().unwrap_err().to_string();
        assert!(e.contains("--margin -1 mm (report.margin)"), "{e}");
    }
}
