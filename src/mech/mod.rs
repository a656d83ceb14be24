//! Closure mechanics: membrane materials, pressure, contact and the solvers
//! that close the valve under diastolic pressure (ALGORITHMS.md §5, §7).
//!
//! Everything is an element on a few nodes with an energy, a gradient and a
//! Hessian (`element`); the total potential is their sum, so forces are
//! exact gradients and Newton sees a symmetric tangent. Seed forces that are
//! not gradients (suturing, the seed's area-weighted contact planes) live in
//! the force-based relaxation path.

pub mod contact;
pub mod element;
pub mod material;
pub mod pressure;
pub mod shapes;
pub mod solve;
pub mod sparse;
pub mod system;
pub mod verify;

pub mod closure;
pub mod config;
pub mod stage;
pub mod terms;
#[cfg(test)]
mod tests;
