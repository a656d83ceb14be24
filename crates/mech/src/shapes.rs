//! Closed-form test shapes for the mechanics: an icosphere and an open
//! cylinder, in mm, outward-oriented.

use super::element::V3;

/// Subdivided icosahedron of radius `r` (vertices on the sphere), level ≥ 0;
/// the mean edge is about 1.05·r / 2^level.
pub fn icosphere(r: f64, level: u32) -> (Vec<V3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<V3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| V3::new(p[0], p[1], p[2]).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        // Midpoints keyed by the sorted edge, found by sorting (no hashing).
        let mut edges: Vec<([u32; 2], usize)> = Vec::with_capacity(3 * f.len());
        for (k, t) in f.iter().enumerate() {
            for s in 0..3 {
                let (a, b) = (t[s], t[(s + 1) % 3]);
                edges.push(([a.min(b), a.max(b)], 3 * k + s));
            }
        }
        edges.sort_unstable();
        let mut mid = vec![0u32; 3 * f.len()];
        let mut i = 0;
        while i < edges.len() {
            let e = edges[i].0;
            let id = v.len() as u32;
            v.push(((v[e[0] as usize] + v[e[1] as usize]) * 0.5).normalize());
            while i < edges.len() && edges[i].0 == e {
                mid[edges[i].1] = id;
                i += 1;
            }
        }
        let mut g = Vec::with_capacity(4 * f.len());
        for (k, t) in f.iter().enumerate() {
            let (a, b, c) = (mid[3 * k], mid[3 * k + 1], mid[3 * k + 2]);
            g.push([t[0], a, c]);
            g.push([t[1], b, a]);
            g.push([t[2], c, b]);
            g.push([a, b, c]);
        }
        f = g;
    }
    (v.into_iter().map(|p| p * r).collect(), f)
}

/// Open cylinder of radius `r` and length `len` along z (centred at z = 0),
/// `nt` nodes around and `nz` rings, outward normals.
pub fn cylinder(r: f64, len: f64, nt: usize, nz: usize) -> (Vec<V3>, Vec<[u32; 3]>) {
    let mut v = Vec::with_capacity(nt * nz);
    for j in 0..nz {
        let z = -len / 2.0 + len * j as f64 / (nz - 1) as f64;
        // Alternate rings are rotated by half a step: near-equilateral cells.
        let off = if j % 2 == 1 { 0.5 } else { 0.0 };
        for i in 0..nt {
            let a = std::f64::consts::TAU * (i as f64 + off) / nt as f64;
            v.push(V3::new(r * a.cos(), r * a.sin(), z));
        }
    }
    let id = |i: usize, j: usize| (j * nt + i % nt) as u32;
    let mut f = Vec::new();
    for j in 0..nz - 1 {
        for i in 0..nt {
            if j % 2 == 0 {
                f.push([id(i, j), id(i + 1, j), id(i, j + 1)]);
                f.push([id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            } else {
                f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    (v, f)
}

/// Signed enclosed volume of a closed, oriented triangle surface.
pub fn enclosed_volume(x: &[V3], tris: &[[u32; 3]]) -> f64 {
    tris.iter()
        .map(|t| x[t[0] as usize].dot(&x[t[1] as usize].cross(&x[t[2] as usize])) / 6.0)
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn icosphere_is_closed_and_outward() {
        let (v, f) = icosphere(10.0, 3);
        assert_eq!(v.len(), 642);
        assert_eq!(f.len(), 1280);
        let vol = enclosed_volume(&v, &f);
        let exact = 4.0 / 3.0 * std::f64::consts::PI * 1000.0;
        assert!(vol > 0.98 * exact && vol < exact, "{vol}");
        let m = coapt_geom::TriMesh::new(v.iter().map(|p| (*p).into()).collect(), f);
        m.sanity_check().unwrap();
        assert!(m.adjacency().boundary_edges().is_empty());
    }

    #[test]
    fn cylinder_is_outward() {
        let (v, f) = cylinder(10.0, 5.0, 60, 6);
        for t in &f {
            let (a, b, c) = (v[t[0] as usize], v[t[1] as usize], v[t[2] as usize]);
            let n = (b - a).cross(&(c - a));
            let m = (a + b + c) / 3.0;
            assert!(n.dot(&V3::new(m.x, m.y, 0.0)) > 0.0);
        }
    }
}

/// Flat disc of radius `r` in the z = 0 plane, rings about `h` apart
/// (ring k has 6k nodes), normals +z. Returns (positions, triangles, rim).
pub fn disc(r: f64, h: f64) -> (Vec<V3>, Vec<[u32; 3]>, Vec<bool>) {
    let n = (r / h).round().max(1.0) as usize;
    let mut v = vec![V3::zeros()];
    let mut start = vec![0usize];
    for k in 1..=n {
        start.push(v.len());
        let rk = r * k as f64 / n as f64;
        for j in 0..6 * k {
            let a = std::f64::consts::TAU * j as f64 / (6 * k) as f64;
            v.push(V3::new(rk * a.cos(), rk * a.sin(), 0.0));
        }
    }
    let ring = |k: usize, j: usize| -> u32 {
        if k == 0 {
            0
        } else {
            (start[k] + j % (6 * k)) as u32
        }
    };
    let mut f = Vec::new();
    for k in 0..n {
        // Walk both rings by angle, always advancing the one behind.
        let (na, nb) = (if k == 0 { 1 } else { 6 * k }, 6 * (k + 1));
        let (mut i, mut j) = (0usize, 0usize);
        while i < na || j < nb {
            let ai = (i as f64 + 0.0) / na as f64;
            let bj = j as f64 / nb as f64;
            let adv_outer = if k == 0 {
                true
            } else {
                i >= na || (j < nb && (bj + 1.0 / nb as f64) <= (ai + 1.0 / na as f64) + 1e-12)
            };
            if adv_outer {
                f.push([ring(k, i), ring(k + 1, j), ring(k + 1, j + 1)]);
                j += 1;
            } else {
                f.push([ring(k, i), ring(k + 1, j), ring(k, i + 1)]);
                i += 1;
            }
            if k == 0 && j >= nb {
                break;
            }
        }
    }
    let rim = (0..v.len()).map(|i| i >= start[n]).collect();
    (v, f, rim)
}
