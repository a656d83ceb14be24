//! The leaflets as the mechanics sees them, their valve axis and what both
//! the suturing pre-stage and the closure read off them: lug corners, the
//! load's side per leaflet, seed 001's contact planes and the ideal root's
//! wall.

use super::contact::planes::Plane;
use super::element::V3;
use super::wall::Wall;
use coapt_geom::{Point3, TriMesh};

/// Leaflets as the mechanics sees them (all in mm, LPS).
#[derive(Debug, Clone)]
pub struct Leaflets {
    pub x: Vec<V3>,
    pub tris: Vec<[u32; 3]>,
    /// 0 interior, 1 sutured, 2 free edge.
    pub boundary: Vec<u8>,
    /// Leaflet (0, 1, 2) of each triangle.
    pub leaflet: Vec<u16>,
    /// Flat template coordinates (mm) of each node.
    pub ref_uv: Option<Vec<[f64; 2]>>,
    /// Fibre directions per triangle.
    pub fibers: Option<Vec<[V3; 2]>>,
    /// Sign of the load per leaflet, when the leaflets say which side is
    /// the aortic one (field data `pressure_sign` of `coapt leaflets`);
    /// else it is judged from the geometry, see [`pressure_signs`].
    pub pressure_side: Option<Vec<f64>>,
}

/// Valve axis (unit, LV → aorta) and a point on it.
#[derive(Debug, Clone, Copy)]
pub struct Axis {
    pub origin: V3,
    pub dir: V3,
}

/// The mechanics' view of a leaflets mesh, or what is missing from it.
pub fn leaflets_from_mesh(m: &TriMesh) -> std::result::Result<Leaflets, String> {
    let a = coapt_io::leaflet_mesh::arrays(m)?;
    let f = |d: [f64; 3]| V3::new(d[0], d[1], d[2]);
    Ok(Leaflets {
        pressure_side: a.pressure_sign,
        x: m.vertices.iter().map(|p| V3::new(p.x, p.y, p.z)).collect(),
        tris: m.triangles.clone(),
        boundary: a.boundary,
        leaflet: a.leaflet.iter().map(|&k| k as u16).collect(),
        ref_uv: a.ref_uv,
        fibers: a
            .fibres
            .map(|v| v.iter().map(|[p, q]| [f(*p), f(*q)]).collect()),
    })
}

/// The leaflet mesh artifact of `l` (the arrays [`leaflets_from_mesh`]
/// reads back), written as `coapt leaflets` writes it.
pub fn leaflets_to_mesh(l: &Leaflets) -> TriMesh {
    let mut m = TriMesh::new(
        l.x.iter().map(|p| Point3::new(p.x, p.y, p.z)).collect(),
        l.tris.clone(),
    );
    let a = coapt_io::leaflet_mesh::LeafletArrays {
        boundary: l.boundary.clone(),
        leaflet: l.leaflet.iter().map(|&k| k as u8).collect(),
        leaflets: l.leaflet.iter().map(|&k| k as usize + 1).max().unwrap_or(0),
        ref_uv: l.ref_uv.clone(),
        fibres: l
            .fibers
            .as_ref()
            .map(|f| f.iter().map(|d| d.map(|v| [v.x, v.y, v.z])).collect()),
        pressure_sign: l.pressure_side.clone(),
    };
    coapt_io::leaflet_mesh::insert_arrays(&mut m, &a);
    m
}

/// Fibre directions per triangle (for GOH): the flat template's u axis
/// (circumferential) and its mirror, pushed forward to the placed leaflet.
pub fn circumferential_fibres(l: &Leaflets) -> Option<Vec<[V3; 2]>> {
    let uv = l.ref_uv.as_ref()?;
    Some(
        l.tris
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| i as usize);
                let u1 = [uv[b][0] - uv[a][0], uv[b][1] - uv[a][1]];
                let u2 = [uv[c][0] - uv[a][0], uv[c][1] - uv[a][1]];
                let det = u1[0] * u2[1] - u1[1] * u2[0];
                let (x1, x2) = (l.x[b] - l.x[a], l.x[c] - l.x[a]);
                // F·e_u: solve [u1 u2]·(α, β) = (1, 0).
                let v = (x1 * (u2[1] / det) + x2 * (-u1[1] / det)).normalize();
                [v, v]
            })
            .collect(),
    )
}

/// [`super::closure::Closed::crossings`] and
/// [`super::closure::Closed::sewn_contacts`] of the leaflets at `x`.
pub fn leaflet_crossings(l: &Leaflets, x: &[V3]) -> (Vec<(u32, u32)>, Vec<(u32, u32)>) {
    let sutured: Vec<bool> = l.boundary.iter().map(|&b| b == 1).collect();
    coapt_geom::crossings::leaflet_pairs_at(x, &l.tris, &l.leaflet, &sutured)
}

/// Lug corners: sutured nodes that share a triangle edge with a free-edge node.
pub fn corners(l: &Leaflets) -> Vec<u32> {
    let mut c = Vec::new();
    for t in &l.tris {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            if l.boundary[a] == 1 && l.boundary[b] == 2 {
                c.push(a as u32);
            }
            if l.boundary[b] == 1 && l.boundary[a] == 2 {
                c.push(b as u32);
            }
        }
    }
    c.sort_unstable();
    c.dedup();
    c
}

/// The axis from the leaflets alone: normal of the plane through the lug
/// corners, pointing from the sutured nodes (the nadirs lie below the
/// commissures) towards the commissure plane; origin at the corners' mean.
pub fn axis_from_leaflets(l: &Leaflets) -> Result<Axis, String> {
    let c = corners(l);
    if c.len() < 5 {
        return Err(format!(
            "found {} lug corners (sutured nodes next to the free edge); the axis needs three leaflets, or a valve.json",
            c.len()
        ));
    }
    let pts: Vec<V3> = c.iter().map(|&i| l.x[i as usize]).collect();
    let mean = pts.iter().sum::<V3>() / pts.len() as f64;
    let mut cov = nalgebra::Matrix3::zeros();
    for p in &pts {
        let d = p - mean;
        cov += d * d.transpose();
    }
    let eig = cov.symmetric_eigen();
    let k = (0..3)
        .min_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]))
        .unwrap();
    let mut dir: V3 = eig.eigenvectors.column(k).into_owned();
    let sut: Vec<V3> = (0..l.x.len())
        .filter(|&i| l.boundary[i] == 1)
        .map(|i| l.x[i])
        .collect();
    let sm = sut.iter().sum::<V3>() / sut.len().max(1) as f64;
    if (mean - sm).dot(&dir) < 0.0 {
        dir = -dir;
    }
    Ok(Axis { origin: mean, dir })
}

pub fn tri_area_vec(x: &[V3], t: &[u32; 3]) -> V3 {
    (x[t[1] as usize] - x[t[0] as usize]).cross(&(x[t[2] as usize] - x[t[0] as usize])) * 0.5
}

/// Sign of the load per leaflet so that diastolic pressure pushes each
/// leaflet towards the axis (the aortic side is the outer one). The rule
/// reads a leaflet that leans from its suture line towards the axis; a
/// leaflet placed hanging (its belly bowed below the line, `leaflet::hang`)
/// turns its aortic side inwards, so the leaflets stage records the side
/// and that record wins.
pub fn pressure_signs(l: &Leaflets, axis: &Axis, n_leaflets: usize) -> Vec<f64> {
    if let Some(s) = l.pressure_side.as_ref().filter(|s| s.len() == n_leaflets) {
        return s.clone();
    }
    let mut s = vec![0.0; n_leaflets];
    for (t, tri) in l.tris.iter().enumerate() {
        let a = tri_area_vec(&l.x, tri);
        let c = (l.x[tri[0] as usize] + l.x[tri[1] as usize] + l.x[tri[2] as usize]) / 3.0;
        let d = c - axis.origin;
        let radial = d - axis.dir * d.dot(&axis.dir);
        s[l.leaflet[t] as usize] += a.dot(&radial);
    }
    s.iter()
        .map(|&v| if v > 0.0 { -1.0 } else { 1.0 })
        .collect()
}

/// Seed 001 contact planes for each leaflet: through the axis, between it
/// and each neighbour (a leaflet alone: the edges of its 120° sector),
/// facing the leaflet; two per leaflet, in leaflet order.
pub fn planes_for(
    l: &Leaflets,
    axis: &Axis,
    n_leaflets: usize,
    eta1: f64,
    offset: f64,
) -> Result<Vec<(Plane, Vec<u32>)>, String> {
    let c = corners(l);
    let mut node_leaf = vec![0u16; l.x.len()];
    for (t, tri) in l.tris.iter().enumerate() {
        for &i in tri {
            node_leaf[i as usize] = l.leaflet[t];
        }
    }
    let mut out = Vec::new();
    for k in 0..n_leaflets as u16 {
        let nodes: Vec<u32> = (0..l.x.len() as u32)
            .filter(|&i| node_leaf[i as usize] == k)
            .collect();
        let cand: Vec<V3> = c
            .iter()
            .filter(|&&i| node_leaf[i as usize] == k)
            .map(|&i| l.x[i as usize])
            .collect();
        if cand.len() < 2 {
            return Err(format!(
                "leaflet {} has {} lug corners, expected 2",
                k + 1,
                cand.len()
            ));
        }
        // Sutured nodes next to the free edge gather at the two ends:
        // split them about the farthest pair and average each end.
        let far = |p: &V3| {
            (0..cand.len())
                .max_by(|&a, &b| (cand[a] - p).norm().total_cmp(&(cand[b] - p).norm()))
                .unwrap()
        };
        let ia = far(&cand[0]);
        let ib = far(&cand[ia]);
        let (pa, pb) = (cand[ia], cand[ib]);
        let (mut ca, mut cb, mut na, mut nb) = (V3::zeros(), V3::zeros(), 0.0, 0.0);
        for p in &cand {
            if (p - pa).norm() <= (p - pb).norm() {
                ca += p;
                na += 1.0;
            } else {
                cb += p;
                nb += 1.0;
            }
        }
        let mine = [ca / na, cb / nb];
        let centroid = nodes.iter().map(|&i| l.x[i as usize]).sum::<V3>() / nodes.len() as f64;
        let rad = |p: V3| {
            let d = p - axis.origin;
            d - axis.dir * d.dot(&axis.dir)
        };
        let r = 0.5 * (rad(mine[0]).norm() + rad(mine[1]).norm());
        let middle = (rad(mine[0]).normalize() + rad(mine[1]).normalize()).normalize();
        for corner in &mine {
            // Between two leaflets the plane of symmetry runs mid-way between
            // the facing lug corners (leaflets are sewn with gaps); a leaflet
            // alone stands for one of three (seed 001 §3.1): its planes bound
            // its 120° sector, 60° either side of its middle.
            let neighbour = c
                .iter()
                .filter(|&&i| node_leaf[i as usize] != k)
                .map(|&i| l.x[i as usize])
                .min_by(|a, b| (a - corner).norm().total_cmp(&(b - corner).norm()));
            let dir = match neighbour {
                Some(q) => rad(*corner).normalize() + rad(q).normalize(),
                None => sector_edge(&axis.dir, &middle, &rad(*corner)),
            };
            let mut n = axis.dir.cross(&dir).normalize();
            if n.dot(&rad(centroid)) < 0.0 {
                n = -n;
            }
            // With an offset the plane stands for the neighbour's face: a
            // mid-surface stays `offset` off the plane of symmetry.
            let p = Plane::new(axis.origin + n * offset, n, eta1, 0.01 * r)
                .ok_or("degenerate contact plane")?;
            out.push((p, nodes.clone()));
        }
    }
    Ok(out)
}

/// The edge of a 120° sector about `axis` centred on `middle` (unit,
/// radial), on the side of `towards`.
pub fn sector_edge(axis: &V3, middle: &V3, towards: &V3) -> V3 {
    let side = axis.cross(middle);
    let s = if side.dot(towards) < 0.0 { -1.0 } else { 1.0 };
    let (sin, cos) = (std::f64::consts::FRAC_PI_3).sin_cos();
    middle * cos + side * (s * sin)
}

/// The cylinder about `axis` through the sutured nodes (their mean
/// distance from it): the wall of a leaflet placed on an ideal root.
pub fn sutured_wall(l: &Leaflets, axis: &Axis) -> Wall {
    let r: Vec<f64> = (0..l.x.len())
        .filter(|&i| l.boundary[i] == 1)
        .map(|i| {
            let d = l.x[i] - axis.origin;
            (d - axis.dir * d.dot(&axis.dir)).norm()
        })
        .collect();
    Wall::Cylinder {
        origin: axis.origin,
        dir: axis.dir,
        radius: r.iter().sum::<f64>() / r.len().max(1) as f64,
    }
}
