//! Membrane materials as [`Membrane`](crate::mech::element::Membrane)
//! elements: energy, gradient (∂U/∂x, force = −grad) and the consistent
//! symmetric Hessian per triangle (ALGORITHMS.md §5).
//!
//! Units: mm, N, MPa (1 kPa = 1e-3 MPa); energies in N·mm.
//!
//! * [`NeoHookean`] — incompressible neo-Hookean, HNF (§5.2).

pub mod invariants;
pub mod neo_hookean;

pub use neo_hookean::NeoHookean;

#[cfg(test)]
mod tests;
