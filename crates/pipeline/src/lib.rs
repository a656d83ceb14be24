//! Stages, run configs, manifests and the runner.
//!
//! A stage is declared once ([`StageSpec`]: inputs, outputs, parameters and a
//! run function). From that declaration follow its CLI subcommand
//! (`coapt <stage> …`, built in `cli.rs`), its section in a run config
//! ([`config`]) and its provenance record in `manifest.json` ([`manifest`]).
//! [`runner::run`] carries out the chain, skipping a stage whose recorded
//! inputs, parameters and coapt version match and whose outputs are intact.

pub mod config;
pub mod execute;
pub mod manifest;
pub mod no_overwrite;
pub mod params;
pub mod progress;
pub mod provenance;
pub mod runner;
pub mod spec;
pub mod validate;

pub use params::{Params, Value};
pub use progress::{LogMode, Progress};
pub use spec::{ArtifactKind, Param, ParamKind, Port, StageIo, StageSpec};
