//! The `leaflets` stage: flat templates, their advancing-front meshes and
//! their placement in the patient's root.

pub mod aft;
pub mod crossings;
pub mod hang;
pub mod outline;
pub mod place;
pub mod seed001;
pub mod stage;
pub mod stage_params;
pub mod template;

#[cfg(test)]
mod tests;
