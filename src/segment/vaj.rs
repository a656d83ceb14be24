//! Separating the left ventricle at the ventriculo-aortic junction (VAJ).
//!
//! With nadir landmarks the VAJ is their plane (the annulus, where the truth
//! and the valve stage put it). Without them it is measured on the region:
//! geodesic distance from the top of the aorta sorts the lumen into
//! cross-sections; the area profile A(d) peaks at the sinuses and falls to
//! the annulus, below which the LVOT is about as wide as the annulus. The
//! VAJ is the first section below the sinus peak whose area is within 5 % of
//! the way from the LVOT plateau to the peak, and the plane is fitted (PCA)
//! to the voxels of that section.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::geom::{Matrix3, Point3, Vector3};

/// A plane with its normal pointing into the aorta.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Plane {
    pub point_mm: [f64; 3],
    pub normal: [f64; 3],
}

impl Plane {
    pub fn new(p: Point3, n: Vector3) -> Self {
        Plane {
            point_mm: [p.x, p.y, p.z],
            normal: [n.x, n.y, n.z],
        }
    }
    pub fn height(&self, q: &Point3) -> f64 {
        let p = Point3::from(self.point_mm);
        (q - p).dot(&Vector3::from(self.normal))
    }
}

/// Plane through the nadirs, normal toward the commissures.
pub fn plane_from_landmarks(nadirs: &[Point3; 3], commissures: &[Point3]) -> Option<Plane> {
    let c = Point3::from((nadirs[0].coords + nadirs[1].coords + nadirs[2].coords) / 3.0);
    let mut n = (nadirs[1] - nadirs[0]).cross(&(nadirs[2] - nadirs[0]));
    if n.norm() < 1e-9 {
        return None;
    }
    n.normalize_mut();
    if !commissures.is_empty() {
        let cc = commissures
            .iter()
            .fold(Vector3::zeros(), |a, p| a + p.coords)
            / commissures.len() as f64;
        if (cc - c.coords).dot(&n) < 0.0 {
            n = -n;
        }
    }
    Some(Plane::new(c, n))
}

/// Geodesic distance (mm) inside `region` from `sources`, 26-connected steps
/// of their Euclidean length (Dijkstra; ties by index: deterministic).
pub fn geodesic(
    region: &[bool],
    dims: [usize; 3],
    spacing: [f64; 3],
    sources: &[usize],
) -> Vec<f64> {
    let [ni, nj, nk] = dims;
    let mut dist = vec![f64::INFINITY; region.len()];
    let mut heap = BinaryHeap::new();
    for &s in sources {
        dist[s] = 0.0;
        heap.push(Reverse((0u64, s)));
    }
    let mut steps = Vec::new();
    for dz in -1i64..=1 {
        for dy in -1i64..=1 {
            for dx in -1i64..=1 {
                if (dx, dy, dz) != (0, 0, 0) {
                    let l = ((dx as f64 * spacing[0]).powi(2)
                        + (dy as f64 * spacing[1]).powi(2)
                        + (dz as f64 * spacing[2]).powi(2))
                    .sqrt();
                    steps.push((dx, dy, dz, l));
                }
            }
        }
    }
    while let Some(Reverse((key, v))) = heap.pop() {
        let d = f64::from_bits(key);
        if d > dist[v] {
            continue;
        }
        let (i, j, k) = (
            (v % ni) as i64,
            ((v / ni) % nj) as i64,
            (v / (ni * nj)) as i64,
        );
        for &(dx, dy, dz, l) in &steps {
            let (a, b, c) = (i + dx, j + dy, k + dz);
            if a < 0 || b < 0 || c < 0 || a >= ni as i64 || b >= nj as i64 || c >= nk as i64 {
                continue;
            }
            let u = a as usize + ni * (b as usize + nj * c as usize);
            if region[u] && d + l < dist[u] {
                dist[u] = d + l;
                heap.push(Reverse(((d + l).to_bits(), u)));
            }
        }
    }
    dist
}

/// Result of the measured VAJ.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Profile {
    /// Cross-section area (mm²) per 1 mm of geodesic distance from the top.
    pub area_mm2: Vec<f64>,
    pub sinus_mm: f64,
    pub vaj_mm: f64,
}

/// VAJ from the area profile; `world(v)` maps a grid index to LPS mm.
pub fn measure(
    dist: &[f64],
    region: &[bool],
    voxel_mm3: f64,
    world: impl Fn(usize) -> Point3,
) -> Option<(Plane, Profile)> {
    let dmax = dist
        .iter()
        .zip(region)
        .filter(|(d, r)| **r && d.is_finite())
        .map(|(d, _)| *d)
        .fold(0.0, f64::max);
    let nb = dmax.floor() as usize + 1;
    if nb < 10 {
        return None;
    }
    let mut count = vec![0usize; nb];
    for (d, r) in dist.iter().zip(region) {
        if *r && d.is_finite() {
            count[*d as usize] += 1;
        }
    }
    let raw: Vec<f64> = count.iter().map(|&c| c as f64 * voxel_mm3).collect();
    let area: Vec<f64> = (0..nb)
        .map(|b| {
            let (lo, hi) = (b.saturating_sub(1), (b + 1).min(nb - 1));
            raw[lo..=hi].iter().sum::<f64>() / (hi - lo + 1) as f64
        })
        .collect();
    // Sinus peak: the widest section in the lower half of the region.
    let lower = nb / 2;
    let sinus = (lower..nb).max_by(|&a, &b| area[a].total_cmp(&area[b]).then(b.cmp(&a)))?;
    if sinus + 2 >= nb {
        return None;
    }
    let floor = area[sinus + 1..]
        .iter()
        .cloned()
        .fold(f64::INFINITY, f64::min);
    let level = floor + 0.05 * (area[sinus] - floor);
    let vaj = (sinus + 1..nb).find(|&b| area[b] <= level)?;
    // Plane fit to the voxels of that section.
    let pts: Vec<Point3> = dist
        .iter()
        .zip(region)
        .enumerate()
        .filter(|(_, (d, r))| **r && d.is_finite() && (**d as usize) == vaj)
        .map(|(v, _)| world(v))
        .collect();
    if pts.len() < 10 {
        return None;
    }
    let c = pts.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / pts.len() as f64;
    let mut cov = Matrix3::zeros();
    for p in &pts {
        let d = p.coords - c;
        cov += d * d.transpose();
    }
    let eig = cov.symmetric_eigen();
    let imin = (0..3).min_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]))?;
    let mut n: Vector3 = eig.eigenvectors.column(imin).into();
    // Toward the aorta: the section one step nearer the top lies on the + side.
    let above: Vec<Point3> = dist
        .iter()
        .zip(region)
        .enumerate()
        .filter(|(_, (d, r))| **r && d.is_finite() && (**d as usize) + 5 == vaj)
        .map(|(v, _)| world(v))
        .collect();
    if !above.is_empty() {
        let ca = above.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / above.len() as f64;
        if (ca - c).dot(&n) < 0.0 {
            n = -n;
        }
    }
    Some((
        Plane::new(Point3::from(c), n),
        Profile {
            area_mm2: area,
            sinus_mm: sinus as f64 + 0.5,
            vaj_mm: vaj as f64 + 0.5,
        },
    ))
}
