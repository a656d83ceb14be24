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
pub mod error;
pub mod geom;
pub mod inspect;
pub mod io;
pub mod landmarks;
pub mod leaflet;
pub mod mech;
pub mod phantom;
pub mod pipeline;
pub mod report;
pub mod rng;
pub mod segment;
pub mod stages;
pub mod surface;
pub mod template;
pub mod units;
pub mod valve;

pub use error::{Error, Result};
