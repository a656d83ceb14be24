//! Membrane materials as [`Membrane`](crate::mech::element::Membrane)
//! elements: energy, gradient (∂U/∂x, force = −grad) and the consistent
//! symmetric Hessian per triangle (ALGORITHMS.md §5).
//!
//! Units: mm, N, MPa (1 kPa = 1e-3 MPa); energies in N·mm.
//!
//! * [`NeoHookean`] — incompressible neo-Hookean, HNF (§5.2).
//! * [`StVenantKirchhoff`] — St Venant–Kirchhoff via Delingette's
//!   biquadratic springs ("TBS", §5.4).

pub mod invariants;
pub mod neo_hookean;
pub mod svk;

pub use neo_hookean::NeoHookean;
pub use svk::StVenantKirchhoff;

#[cfg(test)]
mod tests;
