//! coapt: from a contrast CT angiogram (ceCTA) to the predicted closure of an
//! Ozaki-reconstructed aortic valve.
//!
//! The crate is cut by pipeline stage (see the README's "Layout"):
//! each stage is a library function over in-memory types from [`geom`], plus a
//! declaration in [`pipeline`] from which its CLI subcommand, its run-config
//! section and its provenance record follow. [`io`] holds file formats and
//! nothing else. The `coapt` binary is a thin layer over [`cli`].

pub mod bench;
pub mod cli;
pub mod design;
pub mod inspect;
pub mod landmarks;
pub mod leaflet;
pub mod mech;
pub mod phantom;
pub mod report;
pub mod segment;
pub mod stages;
pub mod surface;
pub mod valve;

// The layers below the stages are crates of their own (`crates/`); their old
// paths stay, so `crate::geom::…` and `coapt::io::…` read as before.
pub use coapt_base::{Error, Result, error, rng, units};
pub use coapt_geom as geom;
pub use coapt_io as io;
pub use coapt_pipeline as pipeline;
pub use coapt_template as template;
