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

use crate::geom::{Point3, Vector3};

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
    /// Geodesic distance from the top (mm) of each station.
    pub station_mm: Vec<f64>,
    /// Cross-section area (mm²) perpendicular to the centreline there.
    pub area_mm2: Vec<f64>,
    pub sinus_mm: f64,
    pub vaj_mm: f64,
}

/// Stations this close to the far end of the region are not judged: their
/// 1-mm slab leaves the region where the IDT cut it.
const END_MARGIN_MM: usize = 6;
/// Slab half-thickness and lateral reach of a cross-section (mm).
const SLAB_MM: f64 = 0.5;
const REACH_MM: f64 = 30.0;

/// VAJ from the area profile along a centreline made of the centroids of
/// geodesic shells (1 mm); `world(v)` maps a grid index to LPS mm.
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
    if nb < 20 {
        return None;
    }
    let mut shells: Vec<Vec<Point3>> = vec![Vec::new(); nb];
    for (v, (d, r)) in dist.iter().zip(region).enumerate() {
        if *r && d.is_finite() {
            shells[*d as usize].push(world(v));
        }
    }
    let centroid = |b: usize| -> Vector3 {
        let (lo, hi) = (b.saturating_sub(3), (b + 3).min(nb - 1));
        let mut c = Vector3::zeros();
        let mut n = 0usize;
        for s in &shells[lo..=hi] {
            for p in s {
                c += p.coords;
                n += 1;
            }
        }
        c / n.max(1) as f64
    };
    let centres: Vec<Vector3> = (0..nb).map(centroid).collect();
    let tangent = |b: usize| -> Vector3 {
        let (lo, hi) = (b.saturating_sub(3), (b + 3).min(nb - 1));
        (centres[hi] - centres[lo])
            .try_normalize(1e-9)
            .unwrap_or(Vector3::z())
    };
    let first = nb / 3;
    let last = nb.checked_sub(END_MARGIN_MM + 1)?;
    if last <= first + 3 {
        return None;
    }
    let mut stations = Vec::new();
    let mut area = Vec::new();
    for b in first..=last {
        let (c, t) = (centres[b], tangent(b));
        let (lo, hi) = (
            b.saturating_sub(REACH_MM as usize),
            (b + REACH_MM as usize).min(nb - 1),
        );
        let mut n = 0usize;
        for s in &shells[lo..=hi] {
            for p in s {
                let d = p.coords - c;
                if d.dot(&t).abs() < SLAB_MM && d.norm() < REACH_MM {
                    n += 1;
                }
            }
        }
        stations.push(b as f64 + 0.5);
        area.push(n as f64 * voxel_mm3 / (2.0 * SLAB_MM));
    }
    let m = area.len();
    let sinus = (m / 3..m).max_by(|&a, &b| area[a].total_cmp(&area[b]).then(b.cmp(&a)))?;
    if sinus + 2 >= m {
        return None;
    }
    // The annulus is the first local minimum of the (3-station smoothed)
    // area past the sinus peak, once the section has narrowed by 10 %;
    let sm: Vec<f64> = (0..m)
        .map(|x| {
            area[x.saturating_sub(1)..=(x + 1).min(m - 1)]
                .iter()
                .sum::<f64>()
                / ((x + 1).min(m - 1) - x.saturating_sub(1) + 1) as f64
        })
        .collect();
    let local_min = (sinus + 1..m - 1)
        .find(|&x| sm[x] < 0.9 * sm[sinus] && sm[x] <= sm[x - 1] && sm[x] < sm[x + 1]);
    let x = match local_min {
        Some(x) => x,
        None => {
            // The section keeps narrowing to the end (the sweep's far end is
            // not a plane): take the first station past the steepest fall
            // where the fall has slowed to half its steepest rate, i.e. where
            // the sinus has ended and the LVOT begins.
            let fall: Vec<f64> = (sinus..m - 1).map(|x| sm[x] - sm[x + 1]).collect();
            let (steep, &max_fall) = fall.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
            let after = (steep + 1..fall.len()).find(|&f| fall[f] < 0.5 * max_fall)?;
            sinus + after
        }
    };
    let b = first + x;
    // Normal toward the aorta: against the direction of increasing distance.
    let n = -tangent(b);
    Some((
        Plane::new(Point3::from(centres[b]), n),
        Profile {
            station_mm: stations.clone(),
            area_mm2: area,
            sinus_mm: stations[sinus],
            vaj_mm: stations[x],
        },
    ))
}
