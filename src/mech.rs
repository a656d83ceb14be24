//! The mechanics library (`crates/mech`, re-exported here under its old
//! name) and the `close` stage that runs it.

pub use coapt_mech::*;

pub mod stage;
