//! The coaptation report (`report` stage): measure the closed valve in both
//! conventions (the seeds' group's and SlicerHeart's; docs/report.md), judge
//! the surgical criteria, and write `report.json` and one self-contained
//! `report.html` with its figures.
//!
//! - `valve.rs`: the closed leaflets as the report sees them (positions,
//!   placed positions, triangles, leaflet of each triangle, boundary codes,
//!   flat-template coordinates) in the valve frame; `load.rs` reads them.
//! - `coaptation.rs`: which leaflets each point touches (distance below a
//!   margin), partially touching triangles refined and cut at the margin
//!   (`clip.rs`); `symmetry.rs` completes a one-leaflet closure.
//! - `metrics.rs`: heights, areas, effective height, billowing; `orifice.rs`
//!   the uncovered lumen; `criteria.rs` the surgical criteria;
//!   `verdict.rs` the answer (met, fails, not assessable and why);
//!   `document.rs` report.json; `reach.rs` whether each free edge can
//!   reach the centre, and Ozaki's rule for the root.
//! - `raster.rs` and `figures/`: the software rasteriser and the figures;
//!   `html/`: the page (`mod.rs`), its sections (`header`, `verdict`,
//!   `metrics`, `figures`, `record`), their formatting and `style.css`;
//!   `view3d/`: its interactive 3-D view (WebGL);
//!   `stage.rs`: the stage.

pub mod case;
pub mod clip;
pub mod coaptation;
pub mod cohort_summary;
pub mod criteria;
pub mod document;
pub mod figure;
pub mod figures;
pub mod html;
pub mod load;
pub mod metrics;
pub mod orifice;
pub mod raster;
pub mod reach;
pub mod references;
pub mod stage;
pub mod stage_params;
pub mod symmetry;
pub mod terminal;
pub mod valve;
pub mod verdict;
pub mod view3d;

pub use figure::Figure;
pub use valve::ClosedValve;

#[cfg(test)]
mod tests;
