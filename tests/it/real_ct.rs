//! Scoring a mask against TotalSegmentator in the root + ascending region of
//! the real CT (`shared/real/`): the same region and metrics as
//! `tools/real_ct_compare.py` (its docstring defines them; this file follows
//! it step for step), with coapt's own NIfTI reader, so tests can assert the
//! numbers without Python.
//!
//! Region: annulus plane (centroid + least-squares normal of TotalSeg's
//! annulus ring, normal toward the STJ centroid) at the bottom; at the top a
//! plane perpendicular to TotalSeg's aorta centreline 40 mm along it above the
//! STJ centroid; T = the 6-connected component of TotalSeg's aorta between
//! the two planes that starts next to the annulus centre; R = the slab within
//! 10 mm of T. A mask M is scored as M ∩ R against T.

#![allow(dead_code)] // support functions for the lead's variant tests, not all used here yet

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use coapt::geom::{Matrix3, Point3, Vector3, Volume};
use coapt::io::nifti;
use coapt::segment::edt;

const ABOVE_STJ_MM: f64 = 40.0;
const STEP_MM: f64 = 5.0;
const LAYER_HALF_MM: f64 = 1.5;
const LAYER_RADIUS_MM: f64 = 25.0;
const NEIGHBOURHOOD_MM: f64 = 10.0;

/// Dice and symmetric surface distances of M ∩ R against T, and the volume
/// of M ∩ R.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scores {
    pub dice: f64,
    pub mean_mm: f64,
    pub p95_mm: f64,
    pub ml: f64,
}

/// `shared/real` beside the repository, or `None` (with a note on stderr) on
/// machines without it.
pub fn real_dir() -> Option<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("shared")
        .join("real");
    if d.join("ct.nii.gz").is_file() {
        Some(d)
    } else {
        eprintln!("skipped: {}/ct.nii.gz not found", d.display());
        None
    }
}

/// The region on the CT grid, with the numbers that define it.
pub struct Region {
    pub ct: Volume<f32>,
    pub dims: [usize; 3],
    pub spacing: [f64; 3],
    pub voxel_ml: f64,
    pub aorta: Vec<bool>,
    pub annulus_centre: Point3,
    pub annulus_normal: Vector3,
    pub stj_centre: Point3,
    pub h_stj: f64,
    /// Centreline points from the STJ centroid, with their arc length.
    pub centreline: Vec<(f64, Point3)>,
    pub top_point: Point3,
    pub top_normal: Vector3,
    pub seed: [usize; 3],
    pub t: Vec<bool>,
    pub r: Vec<bool>,
}

fn read_mask(path: &Path) -> Volume<bool> {
    let v = nifti::read_f32(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    v.map(|&x| x != 0.0)
}

fn voxels_world(v: &Volume<bool>) -> Vec<Point3> {
    let [ni, nj, nk] = v.dims();
    let s = v.as_slice();
    let mut out = Vec::new();
    for k in 0..nk {
        for j in 0..nj {
            for i in 0..ni {
                if s[i + ni * (j + nj * k)] {
                    out.push(v.index_to_world([i as f64, j as f64, k as f64]));
                }
            }
        }
    }
    out
}

fn centroid(p: &[Point3]) -> Point3 {
    let s = p.iter().fold(Vector3::zeros(), |a, q| a + q.coords);
    Point3::from(s / p.len() as f64)
}

/// Unit normal of the least-squares plane through `p` (eigenvector of the
/// smallest eigenvalue of the scatter matrix = the smallest right singular
/// vector of the centred points).
fn plane_normal(p: &[Point3], c: &Point3) -> Vector3 {
    let mut m = Matrix3::zeros();
    for q in p {
        let d = q - c;
        m += d * d.transpose();
    }
    let e = m.symmetric_eigen();
    let i = (0..3)
        .min_by(|&a, &b| e.eigenvalues[a].total_cmp(&e.eigenvalues[b]))
        .unwrap();
    e.eigenvectors.column(i).normalize()
}

/// The centreline march of `tools/real_ct_compare.py::march_centreline`.
fn march_centreline(
    aorta: &[Point3],
    c_a: &Point3,
    c_s: &Point3,
) -> (Vec<(f64, Point3)>, Point3, Vector3) {
    let mut p = *c_s;
    let mut d = (c_s - c_a).normalize();
    let mut pts = vec![(0.0, p)];
    let mut arc = 0.0;
    while arc < ABOVE_STJ_MM {
        let q = p + STEP_MM * d;
        let (mut sum, mut n) = (Vector3::zeros(), 0usize);
        for x in aorta {
            let rel = x - q;
            let ax = rel.dot(&d);
            if ax.abs() <= LAYER_HALF_MM && (rel - ax * d).norm() <= LAYER_RADIUS_MM {
                sum += x.coords;
                n += 1;
            }
        }
        assert!(
            n > 0 && pts.len() <= 100,
            "the centreline march left TotalSeg's aorta above the STJ"
        );
        let pn = Point3::from(sum / n as f64);
        let step = (pn - p).norm();
        d = (pn - p) / step;
        arc += step;
        p = pn;
        pts.push((arc, p));
    }
    let (a0, p0) = pts[pts.len() - 2];
    let (a1, p1) = pts[pts.len() - 1];
    let top = p0 + (ABOVE_STJ_MM - a0) / (a1 - a0) * (p1 - p0);
    let chord = p1 - pts[pts.len().saturating_sub(3)].1;
    (pts, top, chord.normalize())
}

/// Voxels of A with a 6-neighbour outside A or outside the grid.
fn boundary(a: &[bool], [ni, nj, nk]: [usize; 3]) -> Vec<bool> {
    let mut b = vec![false; a.len()];
    for k in 0..nk {
        for j in 0..nj {
            for i in 0..ni {
                let l = i + ni * (j + nj * k);
                if !a[l] {
                    continue;
                }
                b[l] = i == 0
                    || j == 0
                    || k == 0
                    || i + 1 == ni
                    || j + 1 == nj
                    || k + 1 == nk
                    || !a[l - 1]
                    || !a[l + 1]
                    || !a[l - ni]
                    || !a[l + ni]
                    || !a[l - ni * nj]
                    || !a[l + ni * nj];
            }
        }
    }
    b
}

/// 6-neighbour erosion with the grid border outside (scipy's
/// `binary_erosion(a, cross, border_value=0)`): A minus its boundary.
pub fn erode(a: &[bool], dims: [usize; 3]) -> Vec<bool> {
    let b = boundary(a, dims);
    a.iter().zip(&b).map(|(&x, &y)| x && !y).collect()
}

/// The 6-connected component of `inside` containing `seed` (the stage's
/// own flood fill).
pub fn component(inside: &[bool], dims: [usize; 3], seed: usize) -> Vec<bool> {
    coapt::segment::morphology::flood_fill(inside, dims, seed)
}

/// Numpy's default percentile: linear between order statistics at
/// q (n - 1).
fn percentile(sorted: &[f64], q: f64) -> f64 {
    let pos = q / 100.0 * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    sorted[lo] + (pos - lo as f64) * (sorted[hi] - sorted[lo])
}

impl Region {
    pub fn load(real: &Path) -> Region {
        let ct = nifti::read_f32(&real.join("ct.nii.gz"))
            .unwrap_or_else(|e| panic!("{}: {e}", real.join("ct.nii.gz").display()));
        let load = |name: &str| {
            let m = read_mask(&real.join(name));
            assert!(m.same_grid(&ct, 1e-6), "{name} is not on the CT grid");
            m
        };
        let aorta = load("totalseg_aorta.nii.gz");
        let ring = voxels_world(&load("totalseg_annulus.nii.gz"));
        let stj = voxels_world(&load("totalseg_stj.nii.gz"));
        let c_a = centroid(&ring);
        let c_s = centroid(&stj);
        let mut n = plane_normal(&ring, &c_a);
        if n.dot(&(c_s - c_a)) < 0.0 {
            n = -n;
        }
        let h_stj = n.dot(&(c_s - c_a));
        let (centreline, top_point, top_normal) =
            march_centreline(&voxels_world(&aorta), &c_a, &c_s);

        let dims = ct.dims();
        let [ni, nj, nk] = dims;
        let am = aorta.as_slice();
        let mut slab = vec![false; am.len()];
        // Seed: the voxel of aorta ∩ slab nearest c_a; ties to the lowest
        // (i, j, k) lexicographically, as numpy's argwhere + argmin.
        let mut best: Option<(f64, [usize; 3])> = None;
        for k in 0..nk {
            for j in 0..nj {
                for i in 0..ni {
                    let x = ct.index_to_world([i as f64, j as f64, k as f64]);
                    let l = i + ni * (j + nj * k);
                    slab[l] = n.dot(&(x - c_a)) >= 0.0 && top_normal.dot(&(x - top_point)) <= 0.0;
                    if slab[l] && am[l] {
                        let dist = (x - c_a).norm();
                        let better = match best {
                            None => true,
                            Some((bd, b)) => dist < bd || (dist == bd && [i, j, k] < b),
                        };
                        if better {
                            best = Some((dist, [i, j, k]));
                        }
                    }
                }
            }
        }
        let (_, seed) = best.expect("TotalSeg's aorta does not reach the slab above the annulus");
        let inside: Vec<bool> = slab.iter().zip(am).map(|(&s, &a)| s && a).collect();
        let t = component(&inside, dims, seed[0] + ni * (seed[1] + nj * seed[2]));
        let spacing = ct.spacing();
        let d2 = edt::distance_sq_to(&t, dims, spacing);
        let lim = (NEIGHBOURHOOD_MM * NEIGHBOURHOOD_MM) as f32;
        let r = slab.iter().zip(&d2).map(|(&s, &d)| s && d <= lim).collect();
        Region {
            voxel_ml: ct.voxel_volume() / 1000.0,
            dims,
            spacing,
            aorta: am.to_vec(),
            annulus_centre: c_a,
            annulus_normal: n,
            stj_centre: c_s,
            h_stj,
            centreline,
            top_point,
            top_normal,
            seed,
            t,
            r,
            ct,
        }
    }

    /// A mask file on the CT grid by nearest neighbour through both affines
    /// (CT index → world → mask index, rounded as floor(x + 0.5); outside
    /// the mask's grid is background).
    pub fn resample(&self, path: &Path) -> Vec<bool> {
        let m = read_mask(path);
        let c = m.inverse_affine() * self.ct.affine();
        let md = m.dims();
        let ms = m.as_slice();
        let [ni, nj, nk] = self.dims;
        let mut out = vec![false; ni * nj * nk];
        for k in 0..nk {
            for j in 0..nj {
                for i in 0..ni {
                    let x = [i as f64, j as f64, k as f64];
                    let mut idx = [0usize; 3];
                    let mut ok = true;
                    for (r, v) in idx.iter_mut().enumerate() {
                        let f = (c[(r, 0)] * x[0]
                            + c[(r, 1)] * x[1]
                            + c[(r, 2)] * x[2]
                            + c[(r, 3)]
                            + 0.5)
                            .floor();
                        ok &= f >= 0.0 && f < md[r] as f64;
                        *v = if ok { f as usize } else { 0 };
                    }
                    if ok {
                        out[i + ni * (j + nj * k)] = ms[idx[0] + md[0] * (idx[1] + md[1] * idx[2])];
                    }
                }
            }
        }
        out
    }

    /// Scores of a mask already on the CT grid.
    pub fn score(&self, m: &[bool]) -> Scores {
        let m: Vec<bool> = m.iter().zip(&self.r).map(|(&a, &b)| a && b).collect();
        let nm = m.iter().filter(|&&v| v).count();
        let nt = self.t.iter().filter(|&&v| v).count();
        let inter = m.iter().zip(&self.t).filter(|&(&a, &b)| a && b).count();
        let dice = 2.0 * inter as f64 / (nm + nt) as f64;
        let ml = nm as f64 * self.voxel_ml;
        if nm == 0 {
            return Scores {
                dice,
                mean_mm: f64::INFINITY,
                p95_mm: f64::INFINITY,
                ml,
            };
        }
        let (bm, bt) = (boundary(&m, self.dims), boundary(&self.t, self.dims));
        let to_t = edt::distance_sq_to(&bt, self.dims, self.spacing);
        let to_m = edt::distance_sq_to(&bm, self.dims, self.spacing);
        let mut d: Vec<f64> = bm
            .iter()
            .zip(&to_t)
            .chain(bt.iter().zip(&to_m))
            .filter(|&(&b, _)| b)
            .map(|(_, &d2)| (d2 as f64).sqrt())
            .collect();
        let mean_mm = d.iter().sum::<f64>() / d.len() as f64;
        d.sort_by(f64::total_cmp);
        Scores {
            dice,
            mean_mm,
            p95_mm: percentile(&d, 95.0),
            ml,
        }
    }
}

/// The region of `shared/real`, built once per test process.
pub fn region() -> Option<&'static Region> {
    static R: OnceLock<Option<Region>> = OnceLock::new();
    R.get_or_init(|| real_dir().map(|d| Region::load(&d)))
        .as_ref()
}

/// Scores of the mask file `mask` (any grid) in the root region of the real
/// CT. Panics when `shared/real` is absent: call [`real_dir`] first.
pub fn root_region_scores(mask: &Path) -> Scores {
    let r = region().expect("shared/real not found");
    r.score(&r.resample(mask))
}

/// Dice of two mask files (any grids) with each other inside R (NaN when
/// both are empty there).
pub fn dice_in_root(a: &Path, b: &Path) -> f64 {
    let r = region().expect("shared/real not found");
    let (ma, mb) = (r.resample(a), r.resample(b));
    let (mut na, mut nb, mut both) = (0usize, 0usize, 0usize);
    for ((&x, &y), &inr) in ma.iter().zip(&mb).zip(&r.r) {
        let (x, y) = (x && inr, y && inr);
        na += x as usize;
        nb += y as usize;
        both += (x && y) as usize;
    }
    2.0 * both as f64 / (na + nb) as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::common::tmpdir;

    /// The region `tools/real_ct_compare.py --self-check --json` reports on
    /// shared/real (voxel counts exact; the geometry to 1e-6 mm).
    #[test]
    fn region_matches_the_python_tool() {
        let Some(r) = region() else { return };
        let count = |v: &[bool]| v.iter().filter(|&&x| x).count();
        assert_eq!(r.seed, [57, 47, 81]);
        assert_eq!(count(&r.t), 13250, "T voxels");
        assert_eq!(count(&r.r), 36347, "R voxels");
        assert!((r.h_stj - 20.561168891858134).abs() < 1e-6, "{}", r.h_stj);
        let close = |a: &Point3, b: [f64; 3]| (a - Point3::from(b)).norm() < 1e-6;
        assert!(close(
            &r.annulus_centre,
            [13.954041772959183, -184.05106026785714, 660.7790938396843]
        ));
        assert!(close(
            &r.top_point,
            [5.512197790818335, -178.1229930900139, 718.8405565569301]
        ));
        let n = Vector3::new(-0.5259032303378792, -0.2621234832206024, 0.8091458903464084);
        assert!((r.annulus_normal - n).norm() < 1e-6, "{}", r.annulus_normal);
        // The top plane is 40 mm of centreline above the STJ.
        let last = r.centreline.last().unwrap().0;
        assert!(last >= ABOVE_STJ_MM && last < ABOVE_STJ_MM + 2.0 * STEP_MM);
    }

    #[test]
    fn totalseg_against_itself_is_perfect() {
        let Some(dir) = real_dir() else { return };
        let t0 = std::time::Instant::now();
        let r = region().unwrap();
        let t1 = std::time::Instant::now();
        // The whole TotalSeg aorta as a file: R cuts it back to exactly T.
        let s = root_region_scores(&dir.join("totalseg_aorta.nii.gz"));
        // Printed, not asserted: the cost of the region (once per process)
        // and of one scoring call (read + resample + EDTs).
        eprintln!(
            "real_ct: region {:.0} ms (or 0 if another test built it), one score {:.0} ms",
            (t1 - t0).as_secs_f64() * 1e3,
            t1.elapsed().as_secs_f64() * 1e3
        );
        assert_eq!(s.dice, 1.0);
        assert_eq!((s.mean_mm, s.p95_mm), (0.0, 0.0));
        let t_ml = r.t.iter().filter(|&&x| x).count() as f64 * r.voxel_ml;
        assert_eq!(s.ml, t_ml);
        assert_eq!(
            dice_in_root(
                &dir.join("totalseg_aorta.nii.gz"),
                &dir.join("totalseg_aorta.nii.gz")
            ),
            1.0
        );
    }

    /// Expected numbers from `python3 tools/real_ct_compare.py --self-check
    /// --json out.json` (scipy's EDT, numpy's percentile; entry
    /// `aorta_shift_k1`: the whole TotalSeg aorta with its affine moved by one
    /// voxel step along k, +1.5 mm, resampled by nearest neighbour; entry
    /// `eroded_1`: T eroded by one voxel, 6-connected, border outside).
    #[test]
    fn one_voxel_shift_and_erosion_match_the_python_tool() {
        let Some(dir) = real_dir() else { return };
        let r = region().unwrap();
        let mut aorta = nifti::read_u8(&dir.join("totalseg_aorta.nii.gz")).unwrap();
        let mut a = *aorta.affine();
        for row in 0..3 {
            a[(row, 3)] += a[(row, 2)];
        }
        aorta.set_affine(a).unwrap();
        let d = tmpdir("real-ct-shift");
        let p = d.join("shifted.nii.gz");
        nifti::write(&p, &aorta).unwrap();
        let s = root_region_scores(&p);
        assert!((s.dice - 0.9686320844608759).abs() < 1e-6, "{s:?}");
        assert!((s.mean_mm - 0.43610586011342156).abs() < 0.01, "{s:?}");
        assert!((s.p95_mm - 1.5).abs() < 0.01, "{s:?}");
        assert!((s.ml - 43.831125).abs() < 1e-6, "{s:?}");

        let e = r.score(&erode(&r.t, r.dims));
        assert!((e.dice - 0.8881429890073005).abs() < 1e-6, "{e:?}");
        assert!((e.mean_mm - 1.510915263853158).abs() < 0.01, "{e:?}");
        assert!((e.p95_mm - 1.5).abs() < 0.01, "{e:?}");
        assert!((e.ml - 35.721).abs() < 1e-6, "{e:?}");
        let _ = std::fs::remove_dir_all(&d);
    }
}
