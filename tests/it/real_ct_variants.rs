//! Variants of the real CT for property tests ("masks agree with each other
//! in the root"): resampled, reoriented and cropped copies of
//! `shared/real/ct.nii.gz`, each in its own directory with the landmarks
//! copied unchanged (they are world LPS coordinates, valid on every grid).
//!
//! [`write_variants`] makes them; the test below checks that each variant
//! shows the same anatomy at the same world points. The lead runs
//! `coapt segment` on them and compares masks with
//! [`crate::real_ct::dice_in_root`].

#![allow(dead_code)] // the generator is for the lead's segmentation tests

use std::path::{Path, PathBuf};

use coapt::geom::{Matrix3, Matrix4, Point3, Vector3, Volume};
use coapt::io::nifti;
use rayon::prelude::*;

use crate::real_ct;

/// HU written where a variant's grid reaches outside the original scan.
pub const OUTSIDE_HU: f32 = -1024.0;

/// One variant: `dir/ct.nii.gz` and `dir/landmarks.mrk.json`.
#[derive(Debug, Clone)]
pub struct Variant {
    pub name: String,
    pub dir: PathBuf,
    pub ct: PathBuf,
    pub landmarks: PathBuf,
    /// True when the voxels are the original's, permuted or cropped (no
    /// interpolation): values at corresponding voxels are identical.
    pub exact: bool,
    /// Voxel spacing of the variant (mm).
    pub spacing: f64,
    /// Whether the ascending aorta is still joined to the descending aorta
    /// through the arch inside the field of view.
    pub has_arch: bool,
}

/// Trilinear value of `src` at world point `p`; `None` outside the grid
/// (a point on the last voxel centre is inside).
pub fn trilinear(src: &Volume<i16>, p: &Point3) -> Option<f64> {
    let x = src.world_to_index(p);
    let d = src.dims();
    let s = src.as_slice();
    let mut i0 = [0usize; 3];
    let mut f = [0f64; 3];
    for a in 0..3 {
        // 1e-9 voxel of slack so grids that share voxel centres up to
        // rounding of the affine products still hit them.
        if !(x[a] >= -1e-9 && x[a] <= (d[a] - 1) as f64 + 1e-9) {
            return None;
        }
        let xa = x[a].clamp(0.0, (d[a] - 1) as f64);
        let lo = (xa.floor() as usize).min(d[a].saturating_sub(2));
        i0[a] = lo;
        f[a] = if d[a] == 1 { 0.0 } else { xa - lo as f64 };
    }
    let at = |i: usize, j: usize, k: usize| {
        let i = (i0[0] + i).min(d[0] - 1);
        let j = (i0[1] + j).min(d[1] - 1);
        let k = (i0[2] + k).min(d[2] - 1);
        s[i + d[0] * (j + d[1] * k)] as f64
    };
    let mut v = 0.0;
    for (dk, wk) in [(0, 1.0 - f[2]), (1, f[2])] {
        for (dj, wj) in [(0, 1.0 - f[1]), (1, f[1])] {
            for (di, wi) in [(0, 1.0 - f[0]), (1, f[0])] {
                let w = wi * wj * wk;
                if w != 0.0 {
                    v += w * at(di, dj, dk);
                }
            }
        }
    }
    Some(v)
}

/// `src` resampled onto the grid (`dims`, LPS `affine`) by trilinear
/// interpolation, rounded to the nearest HU; [`OUTSIDE_HU`] outside `src`.
pub fn resample_trilinear(src: &Volume<i16>, dims: [usize; 3], affine: Matrix4) -> Volume<i16> {
    let grid = Volume::filled([1, 1, 1], affine, 0i16).expect("valid affine");
    let plane = dims[0] * dims[1];
    let mut values = vec![0i16; plane * dims[2]];
    values
        .par_chunks_mut(plane)
        .enumerate()
        .for_each(|(k, slice)| {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = grid.index_to_world([i as f64, j as f64, k as f64]);
                    let v = trilinear(src, &p).unwrap_or(OUTSIDE_HU as f64);
                    slice[i + dims[0] * j] = v.round() as i16;
                }
            }
        });
    Volume::from_fortran_vec(dims, affine, values).expect("sizes match")
}

/// A grid with unit directions `dir` (columns) and per-axis `spacing` that
/// covers the whole field of view of `src` (its voxel centres' bounding box
/// in the new axes).
fn covering_grid(src: &Volume<i16>, dir: &Matrix3, spacing: [f64; 3]) -> ([usize; 3], Matrix4) {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for p in src.corner_centres() {
        let w = dir.transpose() * p.coords;
        lo = lo.inf(&w);
        hi = hi.sup(&w);
    }
    // 1e-6 mm slack: a corner that lies on a voxel centre stays inside.
    let dims = [0, 1, 2].map(|a| ((hi[a] - lo[a]) / spacing[a] + 1e-6).floor() as usize + 1);
    let origin = Point3::from(dir * lo);
    let affine = coapt::geom::volume::affine_from_parts(spacing, dir, origin);
    (dims, affine)
}

/// The same voxels with the index axes permuted and/or reversed: new axis
/// `a` walks original axis `perm[a]`, backwards when `flip[a]`. Exact.
pub fn reorient(src: &Volume<i16>, perm: [usize; 3], flip: [bool; 3]) -> Volume<i16> {
    let d = src.dims();
    let nd = perm.map(|p| d[p]);
    let s = src.as_slice();
    let mut values = Vec::with_capacity(s.len());
    for k in 0..nd[2] {
        for j in 0..nd[1] {
            for i in 0..nd[0] {
                let mut o = [0usize; 3];
                for (a, &n) in [i, j, k].iter().enumerate() {
                    o[perm[a]] = if flip[a] { nd[a] - 1 - n } else { n };
                }
                values.push(s[src.linear_index(o[0], o[1], o[2])]);
            }
        }
    }
    // New axis a: the original column perm[a], negated when flipped; the
    // origin is the original voxel at new index 0.
    let a = src.affine();
    let mut o0 = [0f64; 3];
    let mut m = Matrix4::identity();
    for ax in 0..3 {
        let sign = if flip[ax] { -1.0 } else { 1.0 };
        for r in 0..3 {
            m[(r, ax)] = sign * a[(r, perm[ax])];
        }
        o0[perm[ax]] = if flip[ax] { (nd[ax] - 1) as f64 } else { 0.0 };
    }
    let origin = src.index_to_world(o0);
    for r in 0..3 {
        m[(r, 3)] = origin[r];
    }
    Volume::from_fortran_vec(nd, m, values).expect("sizes match")
}

/// The smallest k such that TotalSeg's aorta in slices 0..=k joins the
/// root (the region's seed) to the descending aorta: where the arch closes.
fn arch_closing_slice(r: &real_ct::Region) -> usize {
    let [ni, nj, nk] = r.dims;
    let seed = r.seed[0] + ni * (r.seed[1] + nj * r.seed[2]);
    // The descending aorta: TotalSeg's aorta voxel in the lowest slice.
    let low = (0..r.aorta.len())
        .find(|&l| r.aorta[l])
        .expect("aorta not empty");
    assert!(
        low / (ni * nj) < r.seed[2],
        "the descending aorta starts below the root"
    );
    (r.seed[2]..nk)
        .find(|&top| {
            let inside: Vec<bool> = r
                .aorta
                .iter()
                .enumerate()
                .map(|(l, &a)| a && l / (ni * nj) <= top)
                .collect();
            real_ct::component(&inside, r.dims, seed)[low]
        })
        .expect("the arch closes inside the scan")
}

fn rotation(axis: Vector3, deg: f64) -> Matrix3 {
    *nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), deg.to_radians())
        .matrix()
}

/// Write the variants of the real CT in `real` under `out/<name>/`:
/// `iso0.5`, `iso1.0`, `iso1.5`, `iso2.0` and `fine0.35x0.6` (0.35 mm in
/// plane, 0.6 mm slices) (trilinear, the original axes and first voxel
/// centre, covering its field of view); `ras` (i and j reversed:
/// a RAS-ordered array), `kij` (LPS axes permuted: i runs along the original
/// k), `flipk` (k reversed), exact; `oblique20` (1.5 mm, axes rotated 20°
/// about (1, 2, 3), trilinear); `crop_arch` (the aorta's i/j bounding box +
/// 15 mm, all slices, so the arch is in) and `crop_no_arch` (the same, top
/// two slices below where the arch joins the ascending to the descending
/// aorta), exact.
pub fn write_variants(real: &Path, out: &Path) -> Vec<Variant> {
    let ct = nifti::read_i16(&real.join("ct.nii.gz")).unwrap();
    let region = real_ct::region().expect("shared/real");
    let lm = real.join("landmarks.mrk.json");
    let mut vs = Vec::new();
    let mut put = |name: &str, v: &Volume<i16>, exact: bool, has_arch: bool| {
        let dir = out.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        let ct = dir.join("ct.nii.gz");
        nifti::write(&ct, v).unwrap();
        let landmarks = dir.join("landmarks.mrk.json");
        std::fs::copy(&lm, &landmarks).unwrap();
        vs.push(Variant {
            name: name.into(),
            dir,
            ct,
            landmarks,
            exact,
            spacing: v.spacing()[0],
            has_arch,
        });
    };
    for s in [0.5, 1.0, 1.5, 2.0] {
        let (dims, affine) = covering_grid(&ct, &ct.direction(), [s; 3]);
        put(
            &format!("iso{s:.1}"),
            &resample_trilinear(&ct, dims, affine),
            false,
            true,
        );
    }
    // A thin-slice CTA's grid: 0.35 mm in plane, 0.6 mm slices.
    let (dims, affine) = covering_grid(&ct, &ct.direction(), [0.35, 0.35, 0.6]);
    put(
        "fine0.35x0.6",
        &resample_trilinear(&ct, dims, affine),
        false,
        true,
    );
    put(
        "ras",
        &reorient(&ct, [0, 1, 2], [true, true, false]),
        true,
        true,
    );
    put(
        "kij",
        &reorient(&ct, [2, 0, 1], [false, false, false]),
        true,
        true,
    );
    put(
        "flipk",
        &reorient(&ct, [0, 1, 2], [false, false, true]),
        true,
        true,
    );
    let dir = rotation(Vector3::new(1.0, 2.0, 3.0), 20.0) * ct.direction();
    let (dims, affine) = covering_grid(&ct, &dir, [1.5; 3]);
    put(
        "oblique20",
        &resample_trilinear(&ct, dims, affine),
        false,
        true,
    );

    let [ni, nj, nk] = ct.dims();
    let (mut lo, mut hi) = ([usize::MAX; 2], [0usize; 2]);
    for (l, _) in region.aorta.iter().enumerate().filter(|&(_, &a)| a) {
        let ij = [l % ni, (l / ni) % nj];
        for a in 0..2 {
            lo[a] = lo[a].min(ij[a]);
            hi[a] = hi[a].max(ij[a]);
        }
    }
    let m = 10; // 15 mm at 1.5 mm
    let (i0, j0) = (lo[0].saturating_sub(m), lo[1].saturating_sub(m));
    let (i1, j1) = ((hi[0] + m + 1).min(ni), (hi[1] + m + 1).min(nj));
    put(
        "crop_arch",
        &ct.crop([i0, j0, 0], [i1, j1, nk]).unwrap(),
        true,
        true,
    );
    let top = arch_closing_slice(region) - 2;
    put(
        "crop_no_arch",
        &ct.crop([i0, j0, 0], [i1, j1, top + 1]).unwrap(),
        true,
        false,
    );
    vs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::common::tmpdir;

    /// Points to compare: the six landmarks and the region's annulus, STJ
    /// and top centres (world LPS).
    fn points(real: &Path) -> Vec<(String, Point3)> {
        let lm: serde_json::Value =
            serde_json::from_slice(&std::fs::read(real.join("landmarks.mrk.json")).unwrap())
                .unwrap();
        let mut out: Vec<(String, Point3)> = lm["markups"][0]["controlPoints"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| {
                let p: Vec<f64> = c["position"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_f64().unwrap())
                    .collect();
                (
                    c["label"].as_str().unwrap().to_string(),
                    Point3::new(p[0], p[1], p[2]),
                )
            })
            .collect();
        assert_eq!(lm["markups"][0]["coordinateSystem"], "LPS");
        let r = real_ct::region().unwrap();
        out.push(("annulus".into(), r.annulus_centre));
        out.push(("stj".into(), r.stj_centre));
        out.push(("top".into(), r.top_point));
        out
    }

    /// Min and max of the original voxels within `radius` mm of `p`.
    fn range_near(ct: &Volume<i16>, p: &Point3, radius: f64) -> (f64, f64) {
        let c = ct.world_to_index(p);
        let s = ct.spacing();
        let d = ct.dims();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let span = [0, 1, 2].map(|a| (radius / s[a]).ceil() as i64 + 1);
        for dk in -span[2]..=span[2] {
            for dj in -span[1]..=span[1] {
                for di in -span[0]..=span[0] {
                    let ijk = [
                        c[0].round() as i64 + di,
                        c[1].round() as i64 + dj,
                        c[2].round() as i64 + dk,
                    ];
                    if (0..3).any(|a| ijk[a] < 0 || ijk[a] >= d[a] as i64) {
                        continue;
                    }
                    let w = ct.index_to_world(ijk.map(|x| x as f64));
                    if (w - p).norm() <= radius {
                        let v = ct.as_slice()
                            [ct.linear_index(ijk[0] as usize, ijk[1] as usize, ijk[2] as usize)]
                            as f64;
                        lo = lo.min(v);
                        hi = hi.max(v);
                    }
                }
            }
        }
        (lo, hi)
    }

    /// Every variant shows the same anatomy at the same world points:
    /// * exact variants (permuted, flipped, cropped) give the original's
    ///   trilinear value at each landmark to 1e-6 HU, and the right voxels:
    ///   their voxel count and HU histogram equal the original's (crops: the
    ///   original's sub-box);
    /// * `iso1.5` is the original grid, so resampling must reproduce it bit
    ///   for bit;
    /// * trilinear variants: a value at p is a convex combination of
    ///   variant voxels within √3·s_v of p, each a convex combination of
    ///   original voxels within √3·s_o of it, so it must lie within the
    ///   min/max of the original voxels within √3·(s_v + s_o) of p (±0.5 HU
    ///   for the rounding to int16); and it must be within 25 % of the local
    ///   original range of the original's own trilinear value;
    /// * the crops keep the region R inside, and only `crop_no_arch` has
    ///   the ascending aorta cut off from the descending.
    #[test]
    fn variants_show_the_same_anatomy_at_the_same_world_points() {
        let Some(real) = real_ct::real_dir() else {
            return;
        };
        let keep = std::env::var_os("COAPT_KEEP_VARIANTS").map(PathBuf::from);
        let scratch = keep.is_none().then(|| tmpdir("real-ct-variants"));
        let out = keep
            .clone()
            .unwrap_or_else(|| scratch.as_deref().unwrap().to_path_buf());
        let vs = write_variants(&real, &out);
        let ct = nifti::read_i16(&real.join("ct.nii.gz")).unwrap();
        let pts = points(&real);
        let s_o = ct.spacing()[0];
        let names: Vec<&str> = vs.iter().map(|v| v.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "iso0.5",
                "iso1.0",
                "iso1.5",
                "iso2.0",
                "fine0.35x0.6",
                "ras",
                "kij",
                "flipk",
                "oblique20",
                "crop_arch",
                "crop_no_arch"
            ]
        );
        for v in &vs {
            let got = nifti::read_i16(&v.ct).unwrap();
            assert!((got.spacing()[0] - v.spacing).abs() < 1e-5, "{}", v.name);
            if v.name == "iso1.5" {
                assert!(got.same_grid(&ct, 1e-4), "iso1.5 is the original grid");
                assert_eq!(
                    got.as_slice(),
                    ct.as_slice(),
                    "iso1.5 reproduces the original"
                );
            }
            if v.exact && !v.name.starts_with("crop") {
                let mut a = got.as_slice().to_vec();
                let mut b = ct.as_slice().to_vec();
                a.sort_unstable();
                b.sort_unstable();
                assert_eq!(a, b, "{}: the same voxels, reordered", v.name);
            }
            for (label, p) in &pts {
                let want = trilinear(&ct, p).unwrap();
                let have = trilinear(&got, p)
                    .unwrap_or_else(|| panic!("{}: {label} outside the variant", v.name));
                if v.exact {
                    assert!(
                        (have - want).abs() < 1e-6,
                        "{} {label}: {have} vs {want}",
                        v.name
                    );
                } else {
                    let radius = 3f64.sqrt() * (v.spacing + s_o) + 1e-6;
                    let (lo, hi) = range_near(&ct, p, radius);
                    assert!(
                        have >= lo - 0.5 && have <= hi + 0.5,
                        "{} {label}: {have} outside [{lo}, {hi}]",
                        v.name
                    );
                    assert!(
                        (have - want).abs() <= 0.25 * (hi - lo) + 0.5,
                        "{} {label}: {have} vs {want} (local range {lo}..{hi})",
                        v.name
                    );
                }
                // Anatomy: the annulus and STJ centres are in the contrast-filled lumen.
                if label == "annulus" || label == "stj" {
                    assert!(have > 300.0, "{} {label}: {have} HU", v.name);
                }
            }
        }
        // Crops: R inside both; the arch in one only.
        let r = real_ct::region().unwrap();
        let [ni, nj, _] = r.dims;
        for v in vs.iter().filter(|v| v.name.starts_with("crop")) {
            let got = nifti::read_i16(&v.ct).unwrap();
            for (l, _) in r.r.iter().enumerate().filter(|&(_, &x)| x) {
                let ijk = [l % ni, (l / ni) % nj, l / (ni * nj)].map(|x| x as f64);
                let c = got.world_to_index(&r.ct.index_to_world(ijk));
                let d = got.dims();
                assert!(
                    (0..3).all(|a| c[a] > -0.5 && c[a] < d[a] as f64 - 0.5),
                    "{}: R voxel {ijk:?} outside the crop",
                    v.name
                );
            }
        }
        let arch = arch_closing_slice(r);
        let crop = vs.iter().find(|v| v.name == "crop_no_arch").unwrap();
        let top = nifti::read_i16(&crop.ct).unwrap().dims()[2] - 1;
        assert!(
            top < arch,
            "crop_no_arch top slice {top} is below the arch ({arch})"
        );
        assert!(vs.iter().find(|v| v.name == "crop_arch").unwrap().has_arch);
        if keep.is_none() {
            let _ = std::fs::remove_dir_all(&out);
        }
    }
}
