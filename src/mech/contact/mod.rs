//! Contact for membranes (ALGORITHMS.md §7): the BVH broad phase, closest
//! points, node-to-triangle penalty contact between bodies, the seed's
//! penalty planes and an exact triangle–triangle intersection test.

pub mod bvh;
pub mod closest_point;
pub mod penalty;
pub mod planes;
pub mod tri_tri;

#[cfg(test)]
mod tests;
