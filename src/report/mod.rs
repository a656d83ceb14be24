//! The coaptation report (`report` stage): measure the closed valve in both
//! conventions of VERIFICATION.md §5, judge the surgical criteria, and write
//! `report.json` and one self-contained `report.html` with its figures.
//!
//! - `valve.rs`: the closed leaflets as the report sees them (positions,
//!   placed positions, triangles, leaflet of each triangle, boundary codes,
//!   flat-template coordinates) in the valve frame.
//! - `coaptation.rs`: which leaflets each point touches (distance below a
//!   margin), with partially touching triangles refined.
//! - `metrics.rs`: heights, areas, effective height, orifice, billowing…
//! - `figures/`: the software rasteriser and the figures; `html.rs`: the page.

pub mod figure;
pub mod figures;
pub mod raster;
pub mod valve;

pub use figure::Figure;
pub use valve::ClosedValve;
