//! Closure mechanics: membrane materials, pressure, contact and the solvers
//! that close the valve under diastolic pressure (docs/close.md).
//!
//! Every piece is an element on a few nodes with an energy, a gradient and a
//! Hessian (`element`, `material`, `contact`); `system` sums them into a
//! residual (nodal force) and a tangent. The seed's follower pressure has no
//! potential on a leaflet (its free edge moves), so a valve is solved on the
//! residual (`closure`: continuation, then Newton on the non-symmetric tangent); where every load
//! has a potential (`verify`: closed or clamped membranes) Newton uses the
//! energy and Cholesky. `suture` sews the placed template to the wall
//! first (seed 001 Algorithm 1). `config` reads the close stage's
//! `close.toml` (the stage itself is the `coapt-close` crate); a failed closure names its cause (`closure`'s balloon or
//! collapse, else `stall`: converging, cycling, held back or rising).

pub mod bending;
pub mod contact;
pub mod element;
pub mod flat_bending;
pub mod gmres;
pub mod material;
pub mod model;
pub mod peer;
pub mod pressure;
pub mod reference_blend;
pub mod shapes;
pub mod solve;
pub mod sparse;
pub mod system;
pub mod verify;
pub mod wall;

pub mod closure;
pub mod config;
pub mod stall;
pub mod suture;
pub mod terms;
#[cfg(test)]
mod tests;
