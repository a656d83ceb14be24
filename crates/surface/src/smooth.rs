//! Taubin λ|μ smoothing (Taubin 1995): a shrinking Laplacian step λ > 0
//! followed by an inflating step μ < −λ. The pair passes low frequencies
//! (the anatomy) and damps high ones (the voxel staircase) without the
//! shrinkage of plain Laplacian smoothing.

use rayon::prelude::*;

use coapt_geom::{Point3, TriMesh};

/// Vertex neighbours in CSR form, from the mesh's unique edges.
pub struct Neighbours {
    pub offsets: Vec<u32>,
    pub ids: Vec<u32>,
}

impl Neighbours {
    pub fn of(mesh: &TriMesh) -> Neighbours {
        let adj = mesh.adjacency();
        let n = mesh.vertices.len();
        let mut deg = vec![0u32; n + 1];
        for e in &adj.edges {
            deg[e[0] as usize + 1] += 1;
            deg[e[1] as usize + 1] += 1;
        }
        for i in 0..n {
            deg[i + 1] += deg[i];
        }
        let mut fill = deg.clone();
        let mut ids = vec![0u32; deg[n] as usize];
        for e in &adj.edges {
            for (a, b) in [(e[0], e[1]), (e[1], e[0])] {
                ids[fill[a as usize] as usize] = b;
                fill[a as usize] += 1;
            }
        }
        Neighbours { offsets: deg, ids }
    }

    #[inline]
    pub fn of_vertex(&self, v: usize) -> &[u32] {
        &self.ids[self.offsets[v] as usize..self.offsets[v + 1] as usize]
    }
}

/// Taubin smoothing parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Taubin {
    pub iterations: usize,
    pub lambda: f64,
    pub mu: f64,
}

impl Default for Taubin {
    fn default() -> Self {
        // Pass-band k = 1/λ + 1/μ ≈ 0.11: features wider than ~3 edges survive.
        Taubin {
            iterations: 20,
            lambda: 0.5,
            mu: -0.53,
        }
    }
}

/// Smooth the vertices in place (umbrella operator, uniform weights). Each
/// step reads the previous positions only, so the result does not depend on
/// the thread count.
pub fn taubin(mesh: &mut TriMesh, params: &Taubin) {
    if params.iterations == 0 || mesh.vertices.is_empty() {
        return;
    }
    let nb = Neighbours::of(mesh);
    let mut cur = std::mem::take(&mut mesh.vertices);
    let mut next = cur.clone();
    for _ in 0..params.iterations {
        for f in [params.lambda, params.mu] {
            next.par_iter_mut().enumerate().for_each(|(v, out)| {
                let ns = nb.of_vertex(v);
                let p = cur[v];
                if ns.is_empty() {
                    *out = p;
                    return;
                }
                let mut s = [0.0; 3];
                for &u in ns {
                    let q = cur[u as usize];
                    s[0] += q.x;
                    s[1] += q.y;
                    s[2] += q.z;
                }
                let k = 1.0 / ns.len() as f64;
                *out = Point3::new(
                    p.x + f * (s[0] * k - p.x),
                    p.y + f * (s[1] * k - p.y),
                    p.z + f * (s[2] * k - p.z),
                );
            });
            std::mem::swap(&mut cur, &mut next);
        }
    }
    mesh.vertices = cur;
}
