//! The seed 001 penalty planes (eq. 37) as a [`Term`], for the symmetric
//! one-leaflet case and the suturing pre-stage. `contact = "leaflets"`
//! closes with the barrier of `contact::leaflet_barrier`.

use super::contact::planes::Plane;
use super::element::V3;
use super::sparse::{Dofs, Pattern};
use super::system::Term;

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
