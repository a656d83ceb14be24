//! Contact for membranes (ALGORITHMS.md §7): the unsigned-distance barrier
//! between leaflets with its collision-free step (`barrier`,
//! `leaflet_barrier`; what `contact = "leaflets"` uses), the signed
//! node-to-triangle penalty (`penalty`) and the seed's penalty planes. The broad phase
//! (`geom::bvh`), closest points and the exact triangle–triangle test live in
//! `geom/`, shared with the leaflets and report stages.
//!
//! Typical use in a solver iteration (positions `x`, mm):
//!
//! ```text
//! bvh.refit(&x);                                   // rebuild when bvh.cost() has grown ~1.5×
//! let pairs = penalty::find_pairs(&x, &tris, &node_body, &tri_body, &area, &bvh, &params, &sides, reach);
//! for p in &pairs { let (e, g, h) = penalty::pair_eval(&x, &tris, p, &params, true); /* assemble at p.dofs(&tris) */ }
//! // after a converged load step:
//! sides.commit(&x, &tris, &pairs);
//! let mask = penalty::contact_mask(x.len(), &pairs);   // `contact` point data
//! ```

pub mod barrier;
pub mod edge_barrier;
pub mod edge_pairs;
pub mod jet;
pub mod leaflet_barrier;
pub mod penalty;
pub mod planes;
pub mod wall_barrier;

#[cfg(test)]
mod barrier_tests;
#[cfg(test)]
mod edge_barrier_tests;
#[cfg(test)]
mod tests;
