//! Node displacement error of one closure against a reference closure on
//! another mesh of the same leaflets. Meshes of different h share no nodes,
//! but every node carries its flat template coordinates (`ref_uv`), the
//! material point it stands for: each node is located in the reference
//! leaflet's flat mesh and the reference displacement interpolated there
//! barycentrically, so a field linear in uv is carried over exactly.

use coapt_mech::element::V3;

/// One closed mesh as the comparison sees it.
#[derive(Debug, Clone, Copy)]
pub struct Field<'a> {
    /// Flat template coordinates per node (mm); leaflets may overlap in uv.
    pub uv: &'a [[f64; 2]],
    pub tris: &'a [[u32; 3]],
    /// Leaflet of each triangle: nodes are only compared within a leaflet.
    pub tri_leaflet: &'a [u16],
    /// Closed minus placed position per node (mm).
    pub displacement: &'a [V3],
}

/// |u − u_ref| over the nodes of the compared mesh (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DisplacementError {
    pub rms_mm: f64,
    pub max_mm: f64,
    pub nodes: usize,
    /// Nodes outside every reference triangle of their leaflet (a coarse
    /// outline bulges past a finer one by its sagitta): extrapolated
    /// linearly from the nearest reference triangle.
    pub outside: usize,
}

/// Triangles of one leaflet binned on a uniform grid over its uv box.
struct Grid {
    lo: [f64; 2],
    cell: f64,
    nx: usize,
    ny: usize,
    bins: Vec<Vec<u32>>,
    tris: Vec<u32>,
}

impl Grid {
    fn new(uv: &[[f64; 2]], tris: &[[u32; 3]], ids: Vec<u32>) -> Grid {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let mut area = 0.0;
        for &t in &ids {
            let p = tris[t as usize].map(|k| uv[k as usize]);
            for q in &p {
                for d in 0..2 {
                    lo[d] = lo[d].min(q[d]);
                    hi[d] = hi[d].max(q[d]);
                }
            }
            area += 0.5 * cross(sub(p[1], p[0]), sub(p[2], p[0])).abs();
        }
        // About two triangles per cell.
        let cell = (2.0 * area / ids.len().max(1) as f64).sqrt().max(1e-9);
        let count = |d: usize| {
            if hi[d] >= lo[d] {
                (((hi[d] - lo[d]) / cell).floor() as usize + 1).min(4096)
            } else {
                1
            }
        };
        let (nx, ny) = (count(0), count(1));
        let mut g = Grid {
            lo,
            cell,
            nx,
            ny,
            bins: vec![Vec::new(); nx * ny],
            tris: ids,
        };
        for &t in &g.tris {
            let p = tris[t as usize].map(|k| uv[k as usize]);
            let (i0, j0) = g.cell_of([
                p[0][0].min(p[1][0]).min(p[2][0]),
                p[0][1].min(p[1][1]).min(p[2][1]),
            ]);
            let (i1, j1) = g.cell_of([
                p[0][0].max(p[1][0]).max(p[2][0]),
                p[0][1].max(p[1][1]).max(p[2][1]),
            ]);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    g.bins[j * g.nx + i].push(t);
                }
            }
        }
        g
    }

    fn cell_of(&self, p: [f64; 2]) -> (usize, usize) {
        let c = |d: usize, n: usize| {
            let v = ((p[d] - self.lo[d]) / self.cell).floor();
            if v.is_nan() || v < 0.0 {
                0
            } else {
                (v as usize).min(n - 1)
            }
        };
        (c(0, self.nx), c(1, self.ny))
    }
}

/// Rounding slack of the inside test: a point on a shared edge belongs to
/// either triangle, and interpolation there is continuous.
const INSIDE_TOL: f64 = 1e-12;

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Barycentric coordinates of `q` in the triangle `p`, written so that a
/// corner gets exactly (1, 0, 0) in its own slot: a mesh compared with
/// itself has exactly zero error.
fn barycentric(p: [[f64; 2]; 3], q: [f64; 2]) -> Option<[f64; 3]> {
    let (e1, e2, d) = (sub(p[1], p[0]), sub(p[2], p[0]), sub(q, p[0]));
    let det = cross(e1, e2);
    if det == 0.0 || det.is_nan() {
        return None;
    }
    let b = cross(d, e2) / det;
    let c = cross(e1, d) / det;
    Some([1.0 - b - c, b, c])
}

/// Distance in uv from `q` to the triangle `p` (0 inside).
fn distance(p: [[f64; 2]; 3], q: [f64; 2]) -> f64 {
    let seg = |a: [f64; 2], b: [f64; 2]| {
        let ab = sub(b, a);
        let l2 = ab[0] * ab[0] + ab[1] * ab[1];
        let t = if l2 > 0.0 {
            ((q[0] - a[0]) * ab[0] + (q[1] - a[1]) * ab[1]) / l2
        } else {
            0.0
        };
        let t = t.clamp(0.0, 1.0);
        let c = [a[0] + ab[0] * t, a[1] + ab[1] * t];
        (q[0] - c[0]).hypot(q[1] - c[1])
    };
    match barycentric(p, q) {
        Some(l) if l.iter().all(|&v| v >= -INSIDE_TOL) => 0.0,
        _ => seg(p[0], p[1]).min(seg(p[1], p[2])).min(seg(p[2], p[0])),
    }
}

/// Leaflet of each node (the leaflet of any triangle using it).
fn node_leaflets(nodes: usize, tris: &[[u32; 3]], tri_leaflet: &[u16]) -> Vec<Option<u16>> {
    let mut out = vec![None; nodes];
    for (t, tri) in tris.iter().enumerate() {
        for &k in tri {
            out[k as usize] = Some(tri_leaflet[t]);
        }
    }
    out
}

fn check(f: &Field, what: &str) -> Result<(), String> {
    let n = f.uv.len();
    if f.displacement.len() != n {
        return Err(format!(
            "{what}: {} displacements for {n} nodes",
            f.displacement.len()
        ));
    }
    if f.tri_leaflet.len() != f.tris.len() {
        return Err(format!(
            "{what}: leaflet of {} triangles, {} triangles",
            f.tri_leaflet.len(),
            f.tris.len()
        ));
    }
    if f.tris.iter().flatten().any(|&k| k as usize >= n) {
        return Err(format!("{what}: a triangle refers to a node past {n}"));
    }
    if f.uv.iter().flatten().any(|v| !v.is_finite()) {
        return Err(format!("{what}: non-finite ref_uv"));
    }
    Ok(())
}

/// Interpolates a reference field at uv points of one leaflet.
pub struct Locator<'a> {
    reference: Field<'a>,
    grids: Vec<(u16, Grid)>,
}

impl<'a> Locator<'a> {
    pub fn new(reference: Field<'a>) -> Result<Locator<'a>, String> {
        check(&reference, "reference")?;
        let mut leaflets: Vec<u16> = reference.tri_leaflet.to_vec();
        leaflets.sort_unstable();
        leaflets.dedup();
        let grids = leaflets
            .into_iter()
            .map(|l| {
                let ids: Vec<u32> = (0..reference.tris.len() as u32)
                    .filter(|&t| reference.tri_leaflet[t as usize] == l)
                    .collect();
                (l, Grid::new(reference.uv, reference.tris, ids))
            })
            .collect();
        Ok(Locator { reference, grids })
    }

    /// The reference displacement at `q` on leaflet `leaflet`, and whether
    /// `q` lay outside the leaflet's reference mesh (then extrapolated from
    /// the nearest triangle). `None`: the reference has no such leaflet.
    pub fn displacement_at(&self, leaflet: u16, q: [f64; 2]) -> Option<(V3, bool)> {
        let (_, g) = self.grids.iter().find(|(l, _)| *l == leaflet)?;
        let r = &self.reference;
        let corners = |t: u32| r.tris[t as usize].map(|k| r.uv[k as usize]);
        let interpolate = |t: u32, l: [f64; 3]| {
            let [a, b, c] = r.tris[t as usize].map(|k| r.displacement[k as usize]);
            a * l[0] + b * l[1] + c * l[2]
        };
        let (i, j) = g.cell_of(q);
        // Containing triangle: the first in bin order, so the answer does not
        // depend on anything but the two meshes.
        for &t in &g.bins[j * g.nx + i] {
            if let Some(l) = barycentric(corners(t), q) {
                if l.iter().all(|&v| v >= -INSIDE_TOL) {
                    return Some((interpolate(t, l), false));
                }
            }
        }
        let mut best: Option<(f64, u32)> = None;
        for &t in &g.tris {
            let d = distance(corners(t), q);
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, t));
            }
        }
        let (_, t) = best?;
        let l = barycentric(corners(t), q)?;
        Some((interpolate(t, l), true))
    }
}

/// Displacement error of `field` against `reference`, node by node.
pub fn displacement_error(field: &Field, reference: &Field) -> Result<DisplacementError, String> {
    check(field, "compared mesh")?;
    let loc = Locator::new(*reference)?;
    let leaf = node_leaflets(field.uv.len(), field.tris, field.tri_leaflet);
    let (mut sum2, mut max, mut nodes, mut outside) = (0.0, 0.0f64, 0usize, 0usize);
    for (k, l) in leaf.iter().enumerate() {
        let Some(l) = *l else { continue };
        let (u, out) = loc
            .displacement_at(l, field.uv[k])
            .ok_or_else(|| format!("the reference has no leaflet {}", l + 1))?;
        let e = (field.displacement[k] - u).norm();
        sum2 += e * e;
        max = max.max(e);
        nodes += 1;
        outside += out as usize;
    }
    if nodes == 0 {
        return Err("the compared mesh has no triangles".into());
    }
    Ok(DisplacementError {
        rms_mm: (sum2 / nodes as f64).sqrt(),
        max_mm: max,
        nodes,
        outside,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An n×n square [0, s]² triangulated with diagonals alternating by
    /// `flip`, as leaflet `leaflet`; nodes offset by `shift` in uv.
    fn square(n: usize, s: f64, flip: bool) -> (Vec<[f64; 2]>, Vec<[u32; 3]>) {
        let mut uv = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                uv.push([s * i as f64 / n as f64, s * j as f64 / n as f64]);
            }
        }
        let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let mut tris = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                if flip ^ ((i + j) % 2 == 0) {
                    tris.push([a, b, c]);
                    tris.push([a, c, d]);
                } else {
                    tris.push([a, b, d]);
                    tris.push([b, c, d]);
                }
            }
        }
        (uv, tris)
    }

    /// Two leaflets on the same uv square (as the three sample leaflets
    /// share their template), each with its own linear field.
    fn two_leaflets(n: usize, flip: bool, jitter: f64) -> (Vec<[f64; 2]>, Vec<[u32; 3]>, Vec<u16>) {
        let (mut uv, tris) = square(n, 10.0, flip);
        // Move interior nodes off the grid so the meshes are not nested.
        let m = uv.len();
        for (k, p) in uv.iter_mut().enumerate() {
            if p[0] > 0.0 && p[0] < 10.0 && p[1] > 0.0 && p[1] < 10.0 {
                p[0] += jitter * ((k as f64 * 0.7).sin());
                p[1] += jitter * ((k as f64 * 1.3).cos());
            }
        }
        let mut all_uv = uv.clone();
        all_uv.extend(uv.iter().copied());
        let mut all_tris = tris.clone();
        all_tris.extend(tris.iter().map(|t| t.map(|k| k + m as u32)));
        let mut leaf = vec![0u16; tris.len()];
        leaf.extend(vec![1u16; tris.len()]);
        (all_uv, all_tris, leaf)
    }

    fn linear(l: u16, p: [f64; 2]) -> V3 {
        if l == 0 {
            V3::new(
                0.3 * p[0] - 0.1 * p[1] + 1.0,
                0.05 * p[1],
                -0.2 * p[0] + 2.0,
            )
        } else {
            V3::new(-p[1], 0.4 * p[0] + 0.1 * p[1], 0.7)
        }
    }

    fn field_of(uv: &[[f64; 2]], tris: &[[u32; 3]], leaf: &[u16]) -> Vec<V3> {
        let nl = node_leaflets(uv.len(), tris, leaf);
        uv.iter()
            .zip(&nl)
            .map(|(p, l)| linear(l.unwrap(), *p))
            .collect()
    }

    #[test]
    fn a_field_linear_in_uv_is_carried_over_exactly_between_two_meshes() {
        let (ruv, rtris, rleaf) = two_leaflets(13, false, 0.1);
        let rdisp = field_of(&ruv, &rtris, &rleaf);
        let reference = Field {
            uv: &ruv,
            tris: &rtris,
            tri_leaflet: &rleaf,
            displacement: &rdisp,
        };
        let (uv, tris, leaf) = two_leaflets(5, true, 0.3);
        let disp = field_of(&uv, &tris, &leaf);
        let f = Field {
            uv: &uv,
            tris: &tris,
            tri_leaflet: &leaf,
            displacement: &disp,
        };
        let e = displacement_error(&f, &reference).unwrap();
        assert_eq!(e.nodes, uv.len());
        assert!(e.max_mm < 1e-12, "linear field not exact: {e:?}");
        // And the other way round.
        let e = displacement_error(&reference, &f).unwrap();
        assert!(e.max_mm < 1e-12, "{e:?}");
        // Each node compares with its own leaflet: swapping the leaflets'
        // fields on one mesh shows up as an error.
        let swapped: Vec<u16> = leaf.iter().map(|&l| 1 - l).collect();
        let g = Field {
            tri_leaflet: &swapped,
            ..f
        };
        assert!(displacement_error(&g, &reference).unwrap().rms_mm > 1.0);
    }

    #[test]
    fn a_mesh_against_itself_has_exactly_zero_error_and_known_errors_are_measured() {
        let (uv, tris, leaf) = two_leaflets(7, false, 0.25);
        let disp = field_of(&uv, &tris, &leaf);
        let f = Field {
            uv: &uv,
            tris: &tris,
            tri_leaflet: &leaf,
            displacement: &disp,
        };
        let e = displacement_error(&f, &f).unwrap();
        assert_eq!((e.rms_mm, e.max_mm, e.outside), (0.0, 0.0, 0));
        // A rigid shift of 0.3 mm on every node: RMS and max are 0.3.
        let moved: Vec<V3> = disp.iter().map(|u| u + V3::new(0.0, 0.3, 0.0)).collect();
        let g = Field {
            displacement: &moved,
            ..f
        };
        let e = displacement_error(&g, &f).unwrap();
        assert!(
            (e.rms_mm - 0.3).abs() < 1e-12 && (e.max_mm - 0.3).abs() < 1e-12,
            "{e:?}"
        );
    }

    #[test]
    fn nodes_past_the_reference_outline_are_extrapolated_linearly() {
        let (ruv, rtris) = square(4, 10.0, false);
        let rleaf = vec![0u16; rtris.len()];
        let rdisp: Vec<V3> = ruv.iter().map(|p| linear(0, *p)).collect();
        let reference = Field {
            uv: &ruv,
            tris: &rtris,
            tri_leaflet: &rleaf,
            displacement: &rdisp,
        };
        // A slightly larger square: its outline lies 0.05 mm outside.
        let (mut uv, tris) = square(3, 10.1, true);
        for p in uv.iter_mut() {
            p[0] -= 0.05;
            p[1] -= 0.05;
        }
        let leaf = vec![0u16; tris.len()];
        let disp: Vec<V3> = uv.iter().map(|p| linear(0, *p)).collect();
        let f = Field {
            uv: &uv,
            tris: &tris,
            tri_leaflet: &leaf,
            displacement: &disp,
        };
        let e = displacement_error(&f, &reference).unwrap();
        assert_eq!(e.outside, 12, "{e:?}");
        assert!(e.max_mm < 1e-12, "{e:?}");
    }

    #[test]
    fn inconsistent_fields_are_refused() {
        let (uv, tris) = square(2, 1.0, false);
        let leaf = vec![0u16; tris.len()];
        let disp = vec![V3::zeros(); uv.len() - 1];
        let f = Field {
            uv: &uv,
            tris: &tris,
            tri_leaflet: &leaf,
            displacement: &disp,
        };
        assert!(displacement_error(&f, &f).is_err());
        let disp = vec![V3::zeros(); uv.len()];
        let other = vec![3u16; tris.len()];
        let f = Field {
            displacement: &disp,
            ..f
        };
        let g = Field {
            tri_leaflet: &other,
            ..f
        };
        let e = displacement_error(&g, &f).unwrap_err();
        assert!(e.contains("leaflet 4"), "{e}");
    }
}
