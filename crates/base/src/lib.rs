//! The bottom layer of coapt: the error type every layer returns (errors
//! name the file, key and unit, and say how to fix it), quantities with
//! their unit, and the seeded random numbers of the phantoms and
//! benchmarks. It imports nothing of coapt.

pub mod error;
pub mod rng;
pub mod units;

pub use error::{Error, Result};
