//! Cell labels `region`: 0 wall, 1 a flat cap where the mask was cut by a
//! plane inside the grid (the VAJ plane), 2 a cap where the mask was cut by
//! the grid border (top of the ascending aorta). Same codes as the phantom's
//! `truth_surface.vtp`.

use coapt_geom::basis::orthonormal_pair;
use coapt_geom::{Point3, TriMesh, Vector3};

pub const WALL: u8 = 0;
pub const CUT_CAP: u8 = 1;
pub const BORDER_CAP: u8 = 2;

/// Largest curvature (1/mm) of a patch still taken as a flat cut. Aortic
/// radii stay below 25 mm (curvature ≥ 0.04/mm), so the flat-looking patches
/// a voxel staircase leaves on the wall (plateaus at the grid-aligned poles)
/// keep the wall's curvature after smoothing and are refused.
const MAX_CAP_CURVATURE: f64 = 0.02;
/// A cut meets the wall at an edge; a flat facet of the wall blends into
/// it. [`RIM_STEPS`] triangles out from a candidate cap, the wall's normals
/// lie within about 60–70° of a cut's normal (|cos| 0.33–0.47 on the
/// real CT's arch cut and the phantoms' VAJ planes, the cut rounded by
/// smoothing), and within 30° of a facet's (|cos| 0.85–0.90: the flattened
/// sinus of the phantom of `pipelines/phantom.toml` at seed 7, which ran
/// from 2 mm above its annulus to its commissures, and two patches of the
/// real CT's ascending aorta). A facet taken for a cut is not wall: suture
/// paths crossing it fell back to the nearest wall point and wandered 23°
/// past a commissure.
const RIM_STEPS: usize = 3;
const FACET_RIM_COS: f64 = 0.7;

/// Label the triangles of a (smoothed) surface. `on_border` marks vertices
/// made on edges into the padding; `h` is the voxel size in mm.
///
/// Border caps are exact: every triangle whose corners all came from the
/// padding. A cut cap is found as a flat, round patch: regions grown from the
/// flattest triangles while normals stay within 20° of the seed's (the
/// smoothed staircase of an oblique cut keeps ~±10° of normal noise), kept
/// when their plane fit is tight (rms < 0.15 h), they are flat in every
/// direction (both principal curvatures of a fitted quadric below
/// [`MAX_CAP_CURVATURE`]: a strip of tube wall is flat along the tube only)
/// and disc-like (area over 2π·mean r² above 0.5), then
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

    let cos_seed = 20f64.to_radians().cos();
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
                if !seen[u] && normals[u].dot(&normals[seed]) > cos_seed {
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
        let Some(shape) = patch_shape(&members, &areas, &centroid, c, n) else {
            continue;
        };
        if shape.rms > 0.15 * h || shape.roundness < 0.5 || shape.max_curvature > MAX_CAP_CURVATURE
        {
            continue;
        }
        // Regrow against the plane, across the seeds' 12° limit, so the
        // whole cap up to its rounded rim is labelled.
        let mut stack: Vec<usize> = members.clone();
        let mut cap = members.clone();
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
                    cap.push(u);
                }
            }
        }
        if rim_cos(&cap, &region, &normals, &n, neighbours) > FACET_RIM_COS {
            for &t in &cap {
                region[t] = WALL;
            }
        }
    }
    region
}

/// Mean |n_u · n| over the wall triangles u [`RIM_STEPS`] steps across
/// edges from the patch `cap` (0 when there are none): near 1 where the
/// wall carries on in the patch's plane.
fn rim_cos<I: Iterator<Item = usize>>(
    cap: &[usize],
    region: &[u8],
    normals: &[Vector3],
    n: &Vector3,
    neighbours: impl Fn(usize) -> I,
) -> f64 {
    let mut step = vec![usize::MAX; region.len()];
    for &t in cap {
        step[t] = 0;
    }
    let mut front = cap.to_vec();
    for k in 1..=RIM_STEPS {
        let mut next = Vec::new();
        for &t in &front {
            for u in neighbours(t) {
                if step[u] == usize::MAX && region[u] == WALL {
                    step[u] = k;
                    next.push(u);
                }
            }
        }
        front = next;
    }
    if front.is_empty() {
        return 0.0;
    }
    front.iter().map(|&u| normals[u].dot(n).abs()).sum::<f64>() / front.len() as f64
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

struct PatchShape {
    /// Weighted rms height over the fitted plane, mm.
    rms: f64,
    /// Area over 2π·(mean squared in-plane radius): 1 for a disc.
    roundness: f64,
    /// Largest |principal curvature| of z = a u² + b uv + c v² + d u + e v + f, 1/mm.
    max_curvature: f64,
}

/// Shape of a patch in the frame of its plane (centre `c`, normal `n`),
/// from the triangle centroids weighted by area.
fn patch_shape(
    members: &[usize],
    areas: &[f64],
    centroid: &[Point3],
    c: Point3,
    n: Vector3,
) -> Option<PatchShape> {
    let (e1, e2) = orthonormal_pair(&n);
    let mut ata = nalgebra::SMatrix::<f64, 6, 6>::zeros();
    let mut atz = nalgebra::SVector::<f64, 6>::zeros();
    let (mut sw, mut sz, mut szz, mut sr2) = (0.0, 0.0, 0.0, 0.0);
    for &t in members {
        let v = centroid[t] - c;
        let (u, w, z) = (v.dot(&e1), v.dot(&e2), v.dot(&n));
        let row = nalgebra::SVector::<f64, 6>::from([u * u, u * w, w * w, u, w, 1.0]);
        let a = areas[t];
        ata += a * row * row.transpose();
        atz += a * z * row;
        sw += a;
        sz += a * z;
        szz += a * z * z;
        sr2 += a * (u * u + w * w);
    }
    let coef = ata.cholesky()?.solve(&atz);
    // Hessian [[2a, b], [b, 2c]]: eigenvalues are the principal curvatures
    // at the centre (the slope there is small on a fitted plane).
    let (p, q, r) = (2.0 * coef[0], coef[1], 2.0 * coef[2]);
    let mean = 0.5 * (p + r);
    let rad = (0.25 * (p - r) * (p - r) + q * q).sqrt();
    Some(PatchShape {
        rms: (szz / sw - (sz / sw).powi(2)).max(0.0).sqrt(),
        roundness: sw / (2.0 * std::f64::consts::PI * sr2 / sw),
        max_curvature: (mean.abs() + rad),
    })
}
