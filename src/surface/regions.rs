//! Cell labels `region`: 0 wall, 1 a flat cap where the mask was cut by a
//! plane inside the grid (the VAJ plane), 2 a cap where the mask was cut by
//! the grid border (top of the ascending aorta). Same codes as the phantom's
//! `truth_surface.vtp`.

use crate::geom::{Point3, TriMesh, Vector3};

pub const WALL: u8 = 0;
pub const CUT_CAP: u8 = 1;
pub const BORDER_CAP: u8 = 2;

/// Largest curvature (1/mm) of a patch still taken as a flat cut. Aortic
/// radii stay below 25 mm (curvature ≥ 0.04/mm), so the flat-looking patches
/// a voxel staircase leaves on the wall (plateaus at the grid-aligned poles)
/// keep the wall's curvature after smoothing and are refused.
const MAX_CAP_CURVATURE: f64 = 0.02;

/// Label the triangles of a (smoothed) surface. `on_border` marks vertices
/// made on edges into the padding; `h` is the voxel size in mm.
///
/// Border caps are exact: every triangle whose corners all came from the
/// padding. A cut cap is found as a flat, round patch: regions grown from the
/// flattest triangles while normals stay within 12° of the seed's, kept when
/// their plane fit is tight (rms < 0.15 h), they are flat (fitted curvature
/// below [`MAX_CAP_CURVATURE`]) and disc-like (area over 2π·mean r² above
/// 0.5; a strip of tube wall is long and thin), then
/// regrown against the fitted plane (normal within 25°, within one voxel).
pub fn label(mesh: &TriMesh, on_border: &[bool], h: f64) -> Vec<u8> {
    let nt = mesh.triangles.len();
    let mut region = vec![WALL; nt];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if tri.iter().all(|&v| on_border[v as usize]) {
            region[t] = BORDER_CAP;
        }
    }
    if nt == 0 {
        return region;
    }
    let adj = mesh.adjacency();
    let normals: Vec<Vector3> = (0..nt)
        .map(|t| {
            mesh.area_vector(t)
                .try_normalize(0.0)
                .unwrap_or(Vector3::zeros())
        })
        .collect();
    let areas = mesh.areas();
    let centroid: Vec<Point3> = (0..nt)
        .map(|t| {
            let c = mesh.corners(t);
            Point3::from((c[0].coords + c[1].coords + c[2].coords) / 3.0)
        })
        .collect();
    // Across-edge neighbours of each triangle (u32::MAX on an open edge).
    let across: Vec<[u32; 3]> = (0..nt)
        .map(|t| {
            adj.tri_edges[t].map(|e| {
                adj.triangles_of_edge(e as usize)
                    .iter()
                    .copied()
                    .find(|&u| u as usize != t)
                    .unwrap_or(u32::MAX)
            })
        })
        .collect();
    let neighbours = |t: usize| {
        across[t]
            .into_iter()
            .filter(|&u| u != u32::MAX)
            .map(|u| u as usize)
    };
    let total: f64 = areas.iter().sum();

    // Flattest first: smallest largest normal change to a neighbour.
    let mut order: Vec<(f64, usize)> = (0..nt)
        .map(|t| {
            let dev = neighbours(t)
                .map(|u| 1.0 - normals[t].dot(&normals[u]))
                .fold(0.0, f64::max);
            (dev, t)
        })
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));

    let cos12 = 12f64.to_radians().cos();
    let cos25 = 25f64.to_radians().cos();
    let mut seen: Vec<bool> = region.iter().map(|&r| r != WALL).collect();
    let mut stack = Vec::new();
    let mut members = Vec::new();
    for &(_, seed) in &order {
        if seen[seed] {
            continue;
        }
        members.clear();
        seen[seed] = true;
        stack.push(seed);
        while let Some(t) = stack.pop() {
            members.push(t);
            for u in neighbours(t) {
                if !seen[u] && normals[u].dot(&normals[seed]) > cos12 {
                    seen[u] = true;
                    stack.push(u);
                }
            }
        }
        let area: f64 = members.iter().map(|&t| areas[t]).sum();
        if area < (40.0 * h * h).max(0.002 * total) {
            continue;
        }
        let Some((c, n)) = plane_fit(&members, &areas, &centroid, &normals) else {
            continue;
        };
        // Height z over the plane against squared radius ρ²: the slope of
        // the weighted least-squares line z = α ρ² + β is half the curvature.
        let (mut sw, mut sz, mut sr, mut szr, mut srr, mut szz) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for &t in &members {
            let v = centroid[t] - c;
            let z = v.dot(&n);
            let r2 = v.norm_squared() - z * z;
            let w = areas[t];
            sw += w;
            sz += w * z;
            sr += w * r2;
            szr += w * z * r2;
            srr += w * r2 * r2;
            szz += w * z * z;
        }
        let mean_r2 = sr / sw;
        let var_r2 = srr / sw - mean_r2 * mean_r2;
        let alpha = if var_r2 > 0.0 {
            (szr / sw - sz / sw * mean_r2) / var_r2
        } else {
            0.0
        };
        let rms = (szz / sw - (sz / sw).powi(2)).max(0.0).sqrt();
        let roundness = area / (2.0 * std::f64::consts::PI * mean_r2);
        if rms > 0.15 * h || roundness < 0.5 || 2.0 * alpha.abs() > MAX_CAP_CURVATURE {
            continue;
        }
        // Regrow against the plane, across the seeds' 12° limit, so the
        // whole cap up to its rounded rim is labelled.
        let mut stack: Vec<usize> = members.clone();
        for &t in &members {
            region[t] = CUT_CAP;
        }
        while let Some(t) = stack.pop() {
            for u in neighbours(t) {
                if region[u] == WALL
                    && normals[u].dot(&n) > cos25
                    && (centroid[u] - c).dot(&n).abs() < h
                {
                    region[u] = CUT_CAP;
                    seen[u] = true;
                    stack.push(u);
                }
            }
        }
    }
    region
}

/// Area-weighted centroid and mean normal of a patch.
fn plane_fit(
    members: &[usize],
    areas: &[f64],
    centroid: &[Point3],
    normals: &[Vector3],
) -> Option<(Point3, Vector3)> {
    let mut c = Vector3::zeros();
    let mut n = Vector3::zeros();
    let mut a = 0.0;
    for &t in members {
        c += areas[t] * centroid[t].coords;
        n += areas[t] * normals[t];
        a += areas[t];
    }
    (a > 0.0).then_some(())?;
    Some((Point3::from(c / a), n.try_normalize(1e-12)?))
}
