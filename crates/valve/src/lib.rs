//! The `valve` stage: valve frame, radii and suture paths on the wall.

pub mod cylinder;
pub mod frame;
pub mod stage;
pub mod stage_params;
pub mod suture;

#[cfg(test)]
mod tests;
