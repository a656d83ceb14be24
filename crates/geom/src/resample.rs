//! A volume re-laid on an axis-aligned LPS grid: index i → patient left,
//! j → posterior, k → superior.
//!
//! Scans come in every orientation (permuted, flipped, oblique affines) and
//! at 0.3–2 mm; the segmentation reasons in axial slices and in millimetres
//! of a fine enough grid, so it runs on this grid instead. When the source
//! axes are already world axes (a signed permutation) the grid keeps every
//! source sample: its spacing divides the source spacing by a whole number,
//! its planes pass through the source's, and those samples are copied, not
//! interpolated, so an LPS-ordered scan at ≤ `max_spacing` comes out as the
//! same numbers. Otherwise (oblique) the grid is isotropic and the values are
//! trilinear.

use rayon::prelude::*;

use super::volume::affine_from_parts;
use super::{Matrix3, Point3, Vector3, Volume};
use coapt_base::Result;

/// An axis-aligned LPS grid: voxel `[i, j, k]` sits at
/// `origin + (i·s₀, j·s₁, k·s₂)`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LpsGrid {
    pub origin: [f64; 3],
    pub spacing: [f64; 3],
    pub dims: [usize; 3],
}

/// Which world axis each source index axis runs along, with its sign, when
/// the source's axes are world axes (to `1e-6` in direction cosines).
fn signed_permutation(src_dir: &Matrix3) -> Option<[(usize, f64); 3]> {
    let mut out = [(0, 1.0); 3];
    let mut used = [false; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let col = src_dir.column(c);
        let a = (0..3).max_by(|&x, &y| col[x].abs().total_cmp(&col[y].abs()))?;
        if (col[a].abs() - 1.0).abs() > 1e-6 || used[a] {
            return None;
        }
        used[a] = true;
        *o = (a, col[a].signum());
    }
    Some(out)
}

impl LpsGrid {
    /// The grid covering the world box `[lo, hi]` (clipped to the source's
    /// extent) at spacing ≤ `max_spacing` mm and ≥ `min_spacing` mm. A
    /// permuted source keeps its own spacing between the two bounds (its
    /// samples are grid points), a coarser one is divided, a finer one
    /// sampled at `min_spacing`.
    pub fn covering<T>(
        src: &Volume<T>,
        lo: Point3,
        hi: Point3,
        max_spacing: f64,
        min_spacing: f64,
    ) -> Option<LpsGrid> {
        // The source's world bounding box (its corner voxel centres).
        let mut blo = [f64::INFINITY; 3];
        let mut bhi = [f64::NEG_INFINITY; 3];
        for p in src.corner_centres() {
            for a in 0..3 {
                blo[a] = blo[a].min(p[a]);
                bhi[a] = bhi[a].max(p[a]);
            }
        }
        let lo = [0, 1, 2].map(|a| lo[a].max(blo[a]));
        let hi = [0, 1, 2].map(|a| hi[a].min(bhi[a]));
        if (0..3).any(|a| !(hi[a] >= lo[a])) {
            return None;
        }
        let sp = src.spacing();
        let divide = |s: f64| s / (s / max_spacing - 1e-9).ceil().max(1.0);
        let (spacing, anchor) = match signed_permutation(&src.direction()) {
            Some(perm) => {
                let mut spacing = [0.0; 3];
                for (c, &(a, _)) in perm.iter().enumerate() {
                    spacing[a] = divide(sp[c]).max(min_spacing);
                }
                (spacing, Some(src.origin()))
            }
            None => {
                let s = divide(sp.iter().copied().fold(f64::INFINITY, f64::min)).max(min_spacing);
                ([s; 3], None)
            }
        };
        let mut origin = [0.0; 3];
        let mut dims = [0; 3];
        for a in 0..3 {
            // On a permuted source the planes pass through its samples.
            let first = match anchor {
                Some(o) => o[a] + ((lo[a] - o[a]) / spacing[a] - 1e-9).ceil() * spacing[a],
                None => lo[a],
            };
            origin[a] = first;
            dims[a] = ((hi[a] - first) / spacing[a] + 1e-9).floor() as usize + 1;
        }
        Some(LpsGrid {
            origin,
            spacing,
            dims,
        })
    }

    pub fn len(&self) -> usize {
        self.dims.iter().product()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// `src` sampled on `grid`: exact copies where a grid point is a source
/// sample, trilinear between samples, `outside` beyond the source.
pub fn resample_i16(src: &Volume<i16>, grid: &LpsGrid, outside: i16) -> Result<Volume<i16>> {
    let affine = affine_from_parts(
        grid.spacing,
        &Matrix3::identity(),
        Point3::from(grid.origin),
    );
    let d = src.dims();
    let data = src.as_slice();
    let [ni, nj, _] = grid.dims;
    let inv = *src.inverse_affine();
    let col = |c: usize| Vector3::new(inv[(0, c)], inv[(1, c)], inv[(2, c)]);
    // Source index of grid voxel [i, j, k] = base + i·di + j·dj + k·dk.
    let base = src.world_to_index(&Point3::from(grid.origin));
    let (di, dj, dk) = (
        col(0) * grid.spacing[0],
        col(1) * grid.spacing[1],
        col(2) * grid.spacing[2],
    );
    let mut out = vec![outside; grid.len()];
    out.par_chunks_mut(ni * nj)
        .enumerate()
        .for_each(|(k, plane)| {
            for j in 0..nj {
                for i in 0..ni {
                    let q = Vector3::from(base) + di * i as f64 + dj * j as f64 + dk * k as f64;
                    plane[i + ni * j] = sample(data, d, [q.x, q.y, q.z], outside);
                }
            }
        });
    Volume::from_fortran_vec(grid.dims, affine, out)
}

/// Trilinear value of `src` at the world point `p`; `outside` beyond the
/// grid's outermost sample centres.
pub fn value_at(src: &Volume<i16>, p: &Point3, outside: i16) -> i16 {
    sample(src.as_slice(), src.dims(), src.world_to_index(p), outside)
}

/// Trilinear value at a continuous source index; an index within 1e-6 of a
/// sample plane is that plane, so samples are copied bit for bit.
fn sample(data: &[i16], d: [usize; 3], q: [f64; 3], outside: i16) -> i16 {
    let mut base = [0usize; 3];
    let mut frac = [0.0f64; 3];
    for a in 0..3 {
        let r = q[a].round();
        let x = if (q[a] - r).abs() < 1e-6 { r } else { q[a] };
        if !(x >= 0.0 && x <= (d[a] - 1) as f64) {
            return outside;
        }
        let f = x.floor();
        base[a] = (f as usize).min(d[a] - 1);
        frac[a] = x - f;
    }
    let at = |i: usize, j: usize, k: usize| data[i + d[0] * (j + d[1] * k)] as f64;
    if frac == [0.0; 3] {
        return at(base[0], base[1], base[2]) as i16;
    }
    let mut v = 0.0;
    for c in 0..8 {
        let mut w = 1.0;
        let mut idx = [0usize; 3];
        for a in 0..3 {
            let hi = c >> a & 1 == 1;
            w *= if hi { frac[a] } else { 1.0 - frac[a] };
            idx[a] = if hi {
                (base[a] + 1).min(d[a] - 1)
            } else {
                base[a]
            };
        }
        if w != 0.0 {
            v += w * at(idx[0], idx[1], idx[2]);
        }
    }
    v.round() as i16
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Matrix4;

    /// A linear field is reproduced exactly by trilinear interpolation (up
    /// to the i16 rounding), whatever the source's orientation.
    fn field(p: &Point3) -> f64 {
        3.0 * p.x - 2.0 * p.y + 1.5 * p.z + 100.0
    }

    fn source(affine: Matrix4, dims: [usize; 3]) -> Volume<i16> {
        let mut v = Volume::filled(dims, affine, 0i16).unwrap();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = v.index_to_world([i as f64, j as f64, k as f64]);
                    v[[i, j, k]] = field(&p).round() as i16;
                }
            }
        }
        v
    }

    /// The work grid over all of `src` (spacing 0.5–1 mm).
    fn whole(src: &Volume<i16>) -> LpsGrid {
        LpsGrid::covering(
            src,
            Point3::new(-100.0, -100.0, -100.0),
            Point3::new(100.0, 100.0, 100.0),
            1.0,
            0.5,
        )
        .unwrap()
    }

    #[test]
    fn permuted_source_is_copied_sample_for_sample() {
        // i → −z (feet), j → +x, k → −y at 1.5 / 0.8 / 2 mm.
        let dir = Matrix3::from_columns(&[-Vector3::z(), Vector3::x(), -Vector3::y()]);
        let a = affine_from_parts([1.5, 0.8, 2.0], &dir, Point3::new(10.0, -5.0, 40.0));
        let src = source(a, [12, 20, 9]);
        let g = whole(&src);
        // 1.5 → 2 × 0.75 along z, 0.8 kept along x, 2 → 2 × 1 along y.
        assert_eq!(g.spacing, [0.8, 1.0, 0.75]);
        let out = resample_i16(&src, &g, -1024).unwrap();
        let mut copied = 0;
        for k in 0..g.dims[2] {
            for j in 0..g.dims[1] {
                for i in 0..g.dims[0] {
                    let p = out.index_to_world([i as f64, j as f64, k as f64]);
                    let q = src.world_to_index(&p);
                    if q.iter().all(|x| (x - x.round()).abs() < 1e-6) {
                        let s = src[[
                            q[0].round() as usize,
                            q[1].round() as usize,
                            q[2].round() as usize,
                        ]];
                        assert_eq!(out[[i, j, k]], s, "sample at {p:?}");
                        copied += 1;
                    }
                }
            }
        }
        assert_eq!(copied, src.len(), "every source sample is a grid point");
        // The grid spans the source's box exactly.
        let far = out.index_to_world([
            (g.dims[0] - 1) as f64,
            (g.dims[1] - 1) as f64,
            (g.dims[2] - 1) as f64,
        ]);
        assert!((far - Point3::new(10.0 + 19.0 * 0.8, -5.0, 40.0)).norm() < 1e-9);
    }

    #[test]
    fn a_finer_source_is_sampled_at_the_least_spacing() {
        // 0.3 × 0.35 × 0.6 mm, axis-aligned: in-plane 0.5, slices kept.
        let a = affine_from_parts([0.3, 0.35, 0.6], &Matrix3::identity(), Point3::origin());
        let src = source(a, [40, 40, 20]);
        let g = whole(&src);
        assert_eq!(g.spacing, [0.5, 0.5, 0.6]);
        let out = resample_i16(&src, &g, -1024).unwrap();
        let mut worst = 0.0f64;
        for k in 0..g.dims[2] {
            for j in 0..g.dims[1] {
                for i in 0..g.dims[0] {
                    let p = out.index_to_world([i as f64, j as f64, k as f64]);
                    worst = worst.max((out[[i, j, k]] as f64 - field(&p)).abs());
                }
            }
        }
        assert!(worst <= 1.0, "trilinear error {worst} HU on a linear field");
    }

    #[test]
    fn oblique_source_interpolates_a_linear_field() {
        let rot = nalgebra::Rotation3::from_euler_angles(0.35, -0.2, 0.5).into_inner();
        let a = affine_from_parts([1.2, 1.2, 1.6], &rot, Point3::new(-3.0, 4.0, 7.0));
        let src = source(a, [24, 22, 18]);
        let lo = src.index_to_world([6.0, 6.0, 5.0]);
        let hi = src.index_to_world([14.0, 14.0, 11.0]);
        let (lo, hi) = (
            Point3::new(lo.x.min(hi.x), lo.y.min(hi.y), lo.z.min(hi.z)),
            Point3::new(lo.x.max(hi.x), lo.y.max(hi.y), lo.z.max(hi.z)),
        );
        let g = LpsGrid::covering(&src, lo, hi, 1.0, 0.5).unwrap();
        assert_eq!(g.spacing, [0.6; 3]);
        let out = resample_i16(&src, &g, -1024).unwrap();
        assert!(out.is_right_handed());
        let (mut inside, mut worst) = (0, 0.0f64);
        for k in 0..g.dims[2] {
            for j in 0..g.dims[1] {
                for i in 0..g.dims[0] {
                    let v = out[[i, j, k]];
                    if v == -1024 {
                        continue;
                    }
                    let p = out.index_to_world([i as f64, j as f64, k as f64]);
                    // Source values are rounded to whole HU: ≤ 0.5 + 0.5.
                    worst = worst.max((v as f64 - field(&p)).abs());
                    inside += 1;
                }
            }
        }
        assert!(inside > g.len() / 2, "{inside} of {} inside", g.len());
        assert!(worst <= 1.0, "trilinear error {worst} HU on a linear field");
    }

    #[test]
    fn box_outside_the_source_is_none() {
        let src = source(Matrix4::identity(), [4, 4, 4]);
        assert!(
            LpsGrid::covering(
                &src,
                Point3::new(10.0, 0.0, 0.0),
                Point3::new(20.0, 3.0, 3.0),
                1.0,
                0.5
            )
            .is_none()
        );
    }
}
