//! The `leaflets` stage: the templates' advancing-front meshes and their
//! placement in the patient's root (the flat templates themselves are
//! [`coapt_template`]).

pub mod aft;
pub mod crossings;
pub mod hang;
pub mod place;
pub mod stage;
pub mod stage_params;

#[cfg(test)]
mod tests;
