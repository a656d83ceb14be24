//! coapt: from a contrast CT angiogram (ceCTA) to the predicted closure of an
//! Ozaki-reconstructed aortic valve.
//!
//! This is the binary's library: the CLI ([`cli`]), leaflet sizing
//! ([`design`]) and [`inspect`]. Everything below it is a crate of its own,
//! the stage list ([`stages`]) and the benchmarks ([`bench`]) too (see
//! ARCHITECTURE.md): each stage is a library function over in-memory types
//! from [`geom`], plus a declaration for [`pipeline`] from which its CLI
//! subcommand, its run-config section and its provenance record follow.
//! [`io`] holds file formats and nothing else. The `coapt` binary is a thin
//! layer over [`cli`].

pub mod cli;
pub mod design;
pub mod inspect;

// Every layer below the binary is a crate of its own (`crates/`, see
// ARCHITECTURE.md); their old paths stay, so `coapt::io::…` and
// `coapt::segment::…` read as before.
pub use coapt_base::{Error, Result, error, rng, units};
pub use coapt_bench as bench;
pub use coapt_close as close;
pub use coapt_geom as geom;
pub use coapt_io as io;
pub use coapt_landmarks as landmarks;
pub use coapt_leaflet as leaflet;
pub use coapt_mech as mech;
pub use coapt_phantom as phantom;
pub use coapt_pipeline as pipeline;
pub use coapt_report as report;
pub use coapt_segment as segment;
pub use coapt_stages as stages;
pub use coapt_surface as surface;
pub use coapt_template as template;
pub use coapt_valve as valve;
