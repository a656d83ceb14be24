//! Contact for membranes (docs/close.md): the unsigned-distance barrier
//! between leaflets with its collision-free step (`barrier`,
//! `edge_barrier`, `leaflet_barrier`; what `contact = "leaflets"` uses),
//! the barrier that keeps leaflets off the aortic wall (`wall_barrier`) and
//! the seed's penalty planes (`planes`; a lone leaflet of a symmetric
//! valve). The broad phase (`geom::bvh`), closest points and the exact
//! triangle–triangle test live in `geom/`, shared with the leaflets and
//! report stages. (A signed node-to-triangle penalty came first; on a
//! valve its contact set grew without bound, free-edge nodes re-learning
//! their side, and the barrier replaced it.)

pub mod barrier;
pub mod edge_barrier;
pub mod edge_pairs;
pub mod jet;
pub mod leaflet_barrier;
pub mod planes;
pub mod wall_barrier;

#[cfg(test)]
mod barrier_tests;
#[cfg(test)]
mod edge_barrier_tests;
#[cfg(test)]
mod tests;
