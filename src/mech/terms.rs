//! The contact terms of the model, as [`Term`]s: the signed
//! node-to-triangle penalty (ALGORITHMS.md §7.2) and the seed 001 penalty
//! planes (eq. 37) for the symmetric one-leaflet case. `contact =
//! "leaflets"` closes with the barrier of `contact::leaflet_barrier`
//! instead: on a valve the penalty's contact set grew without bound (free-
//! edge nodes re-learning their side); [`LeafletContact`] stays for
//! comparison and for its own tests.

use super::contact::penalty::{self, ContactParams, Pair, Sides};
use super::contact::planes::Plane;
use super::element::V3;
use super::sparse::{Dofs, Pattern};
use super::system::Term;
use crate::geom::bvh::Bvh;

/// Contact between different leaflets (bodies). The broad phase (BVH over
/// all leaflet triangles) is refitted at every outer iteration and rebuilt
/// when refitting has loosened it; only pairs within `margin + reach` are
/// ever formed. Node areas are the reference lumped areas, so the penalty is
/// an exact potential between updates.
pub struct LeafletContact {
    tris: Vec<[u32; 3]>,
    node_body: Vec<u16>,
    tri_body: Vec<u16>,
    node_area: Vec<f64>,
    pub params: ContactParams,
    pub reach: f64,
    bvh: Bvh,
    build_cost: f64,
    sides: Sides,
    pub pairs: Vec<Pair>,
}

impl LeafletContact {
    pub fn new(
        x_ref: &[V3],
        tris: &[[u32; 3]],
        tri_body: &[u16],
        params: ContactParams,
        reach: f64,
    ) -> LeafletContact {
        let mut node_body = vec![0u16; x_ref.len()];
        for (t, b) in tris.iter().zip(tri_body) {
            for &i in t {
                node_body[i as usize] = *b;
            }
        }
        let bvh = Bvh::build(x_ref, tris);
        let build_cost = bvh.cost();
        LeafletContact {
            tris: tris.to_vec(),
            node_body,
            tri_body: tri_body.to_vec(),
            node_area: penalty::node_areas(x_ref, tris),
            params,
            reach,
            bvh,
            build_cost,
            sides: Sides::new(),
            pairs: Vec::new(),
        }
    }

    /// Which other leaflets each node touches (bit b = leaflet b).
    fn mask(&self, x: &[V3]) -> Vec<u8> {
        let mut p = self.pairs.clone();
        penalty::update_gaps(x, &self.tris, &mut p, &self.params);
        penalty::contact_mask(x.len(), &p)
    }
}

impl Term for LeafletContact {
    fn name(&self) -> &'static str {
        "leaflet-contact"
    }

    fn update(&mut self, x: &[V3]) {
        self.sides.commit(x, &self.tris, &self.pairs);
        self.bvh.refit(x);
        if self.bvh.cost() > 2.0 * self.build_cost {
            self.bvh = Bvh::build(x, &self.tris);
            self.build_cost = self.bvh.cost();
        }
        self.pairs = penalty::find_pairs(
            x,
            &self.tris,
            &self.node_body,
            &self.tri_body,
            &self.node_area,
            &self.bvh,
            &self.params,
            &self.sides,
            self.reach,
        );
    }

    fn energy(&self, x: &[V3]) -> Option<f64> {
        Some(
            self.pairs
                .iter()
                .map(|p| penalty::pair_eval(x, &self.tris, p, &self.params, false).0)
                .sum(),
        )
    }

    fn add_force(&self, x: &[V3], f: &mut [V3]) {
        for p in &self.pairs {
            let (_, g, _) = penalty::pair_eval(x, &self.tris, p, &self.params, false);
            for (k, n) in p.dofs(&self.tris).into_iter().enumerate() {
                f[n as usize] -= g[k];
            }
        }
    }

    fn couplings(&self, out: &mut Vec<[u32; 2]>) {
        for p in &self.pairs {
            let d = p.dofs(&self.tris);
            for a in 0..4 {
                for b in a + 1..4 {
                    out.push([d[a], d[b]]);
                }
            }
        }
    }

    fn add_tangent(&self, x: &[V3], dofs: &Dofs, pat: &Pattern, vals: &mut [f64]) {
        for p in &self.pairs {
            let (_, _, h) = penalty::pair_eval(x, &self.tris, p, &self.params, true);
            if let Some(h) = h {
                pat.add_block(dofs, vals, &p.dofs(&self.tris), &h);
            }
        }
    }

    fn stats(&self) -> Option<(&'static str, usize)> {
        Some((
            "contact_pairs",
            self.pairs.iter().filter(|p| p.gap < 0.0).count(),
        ))
    }

    fn contact_mask(&self, x: &[V3]) -> Option<Vec<u8>> {
        Some(self.mask(x))
    }
}

/// Seed 001 penalty planes acting on a set of nodes, each plane on its own
/// nodes. The seed's force scales with the current incident area; here the
/// area is lagged (refreshed at each outer iteration), which makes the term
/// a potential between refreshes and the seed's force at convergence.
pub struct PlaneContact {
    pub planes: Vec<(Plane, Vec<u32>)>,
    tris: Vec<[u32; 3]>,
    area: Vec<f64>,
}

impl PlaneContact {
    pub fn new(planes: Vec<(Plane, Vec<u32>)>, x: &[V3], tris: &[[u32; 3]]) -> PlaneContact {
        PlaneContact {
            planes,
            tris: tris.to_vec(),
            area: incident_area(x, tris),
        }
    }

    /// Nodes within the plane's threshold distance η₂ (the seed's
    /// coaptation test, d ≤ 0.01 R), as a per-node mask bit per plane.
    fn mask(&self, x: &[V3]) -> Vec<u8> {
        let mut m = vec![0u8; x.len()];
        for (k, (p, nodes)) in self.planes.iter().enumerate() {
            for &n in nodes {
                if p.distance(&x[n as usize]) <= p.eta2 {
                    m[n as usize] |= 1 << k.min(7);
                }
            }
        }
        m
    }
}

/// Σ of the current areas of the triangles around each node (seed's ΣA_i).
fn incident_area(x: &[V3], tris: &[[u32; 3]]) -> Vec<f64> {
    let mut a = vec![0.0; x.len()];
    for t in tris {
        let ar = 0.5
            * (x[t[1] as usize] - x[t[0] as usize])
                .cross(&(x[t[2] as usize] - x[t[0] as usize]))
                .norm();
        for &i in t {
            a[i as usize] += ar;
        }
    }
    a
}

impl Term for PlaneContact {
    fn name(&self) -> &'static str {
        "contact-planes"
    }

    fn update(&mut self, x: &[V3]) {
        self.area = incident_area(x, &self.tris);
    }

    fn energy(&self, x: &[V3]) -> Option<f64> {
        let mut e = 0.0;
        for (p, nodes) in &self.planes {
            for &n in nodes {
                e += p.eval(&x[n as usize], self.area[n as usize], false).0;
            }
        }
        Some(e)
    }

    fn add_force(&self, x: &[V3], f: &mut [V3]) {
        for (p, nodes) in &self.planes {
            for &n in nodes {
                f[n as usize] -= p.eval(&x[n as usize], self.area[n as usize], false).1;
            }
        }
    }

    fn add_tangent(&self, x: &[V3], dofs: &Dofs, pat: &Pattern, vals: &mut [f64]) {
        for (p, nodes) in &self.planes {
            for &n in nodes {
                if let (_, _, Some(h)) = p.eval(&x[n as usize], self.area[n as usize], true) {
                    pat.add_block(dofs, vals, &[n], &h);
                }
            }
        }
    }

    fn contact_mask(&self, x: &[V3]) -> Option<Vec<u8>> {
        Some(self.mask(x))
    }
}
