//! Membrane materials as [`Membrane`](crate::element::Membrane)
//! elements: energy, gradient (∂U/∂x, force = −grad) and the consistent
//! symmetric Hessian per triangle (docs/close.md).
//!
//! Units: mm, N, MPa (1 kPa = 1e-3 MPa); energies in N·mm.
//!
//! * [`NeoHookean`] — incompressible neo-Hookean, HNF (§5.2).
//! * [`StVenantKirchhoff`] — St Venant–Kirchhoff via Delingette's
//!   biquadratic springs ("TBS", §5.4).
//! * [`Gent`] — incompressible Gent with lock-up J_m (§5.2).
//! * [`Goh`] — incompressible Gasser–Ogden–Holzapfel with two fibre families
//!   from `RefTri::fiber` and dispersion κ (seed 001 eq. 17–19).
//! * [`WrinklingNeoHookean`] — the neo-Hookean membrane relaxed to carry no
//!   compression (tension field: taut, wrinkled or slack).
//! * [`MassSpring`] — mass–spring model, three edge springs per triangle with
//!   a linear, three-step or anisotropic three-step [`Law`] (§5.5).

pub mod gent;
pub mod goh;
pub mod invariants;
pub mod msm;
pub mod neo_hookean;
pub mod svk;
pub mod wrinkling;

pub use gent::Gent;
pub use goh::{GOH_EXP_MAX, Goh};
pub use msm::{
    Law, MassSpring, SEED000_EPS, seed000_anisotropic, seed000_isotropic, seed000_longitudinal,
    seed000_transverse,
};
pub use neo_hookean::NeoHookean;
pub use svk::StVenantKirchhoff;
pub use wrinkling::{TensionState, WrinklingNeoHookean};

#[cfg(test)]
mod tests;
