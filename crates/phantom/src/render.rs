//! Rasterisation with analytic partial volume, scanner blur, correlated noise
//! and quantisation.
//!
//! Every pass is parallel over axial slices and every value depends only on
//! its voxel (noise from a counter-based hash of the voxel index), and sums
//! are reduced per slice then combined in slice order: the output is
//! bit-identical whatever the number of threads.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use super::scene::{AIR_HU, Probe, Scene};
use super::shapes::Aabb;
use coapt_base::rng::hash_normal;
use coapt_geom::Point3;

/// Axis-aligned LPS grid (i → +x, j → +y, k → +z), like a DICOM axial series.
#[derive(Debug, Clone, Copy)]
pub struct Grid {
    pub dims: [usize; 3],
    pub spacing: [f64; 3],
    /// World position of voxel [0, 0, 0].
    pub origin: Point3,
}

impl Grid {
    pub fn point(&self, i: usize, j: usize, k: usize) -> Point3 {
        Point3::new(
            self.origin.x + i as f64 * self.spacing[0],
            self.origin.y + j as f64 * self.spacing[1],
            self.origin.z + k as f64 * self.spacing[2],
        )
    }

    pub fn len(&self) -> usize {
        self.dims.iter().product()
    }

    /// Index range [lo, hi) along `axis` of voxel centres inside [a, b].
    fn range(&self, axis: usize, a: f64, b: f64) -> (usize, usize) {
        let o = self.origin[axis];
        let s = self.spacing[axis];
        let lo = ((a - o) / s).ceil().max(0.0);
        let hi = ((b - o) / s).floor() + 1.0;
        let n = self.dims[axis] as f64;
        (lo.min(n) as usize, hi.clamp(0.0, n) as usize)
    }

    /// Top face of the volume: top slice centre + half a voxel.
    pub fn z_top(&self) -> f64 {
        self.origin.z + (self.dims[2] as f64 - 0.5) * self.spacing[2]
    }
}

/// Scanner point-spread function, full width at half maximum.
pub const PSF_FWHM_MM: f64 = 0.8;
/// In-plane correlation of the noise (Gaussian σ in voxels).
pub const NOISE_CORRELATION_VOXELS: f64 = 0.6;
const FWHM_TO_SIGMA: f64 = 2.354_820_045_030_949;

/// Slices finished by a parallel pass, reported every few slices. The call
/// happens under a lock so the values a caller sees never go backwards.
struct SliceProgress<'a> {
    done: AtomicUsize,
    last: Mutex<f64>,
    total: usize,
    from: f64,
    to: f64,
    report: &'a (dyn Fn(f64) + Sync),
}

/// Report every this many slices (and at the end).
const PROGRESS_EVERY: usize = 8;

impl<'a> SliceProgress<'a> {
    fn new(total: usize, from: f64, to: f64, report: &'a (dyn Fn(f64) + Sync)) -> Self {
        SliceProgress {
            done: AtomicUsize::new(0),
            last: Mutex::new(from),
            total,
            from,
            to,
            report,
        }
    }

    fn slice_done(&self) {
        let n = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        if n % PROGRESS_EVERY == 0 || n == self.total {
            let f = self.from + (self.to - self.from) * n as f64 / self.total as f64;
            let mut last = self.last.lock().unwrap_or_else(|e| e.into_inner());
            if f > *last {
                *last = f;
                (self.report)(f);
            }
        }
    }
}

/// In-plane tile size (voxels) for per-tile layer classification.
const TILE: usize = 8;
/// Our distances are only approximately 1-Lipschitz (ellipsoid bound,
/// normalised lumen distance, smooth unions): classify a tile as fully
/// inside or outside only with this factor of slack, plus a fixed margin.
const LIPSCHITZ_SAFETY: f64 = 2.0;
const TILE_MARGIN_MM: f64 = 1.0;

/// How a layer covers a tile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Cover {
    Full,
    Partial,
}

/// Output of the rasterisation pass.
pub struct Raster {
    pub image: Vec<f32>,
    pub mask: Vec<u8>,
    /// Correlated unit-ish noise field, kept so it is generated only once.
    noise: Vec<f32>,
    /// Per-slice (sum, sum of squares) of the noise field.
    noise_sums: Vec<(f64, f64)>,
}

/// Normalised Gaussian kernel of σ (in samples), truncated at 3σ; [1] if tiny.
fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    if sigma < 1e-3 {
        return vec![1.0];
    }
    let r = (3.0 * sigma).ceil().max(1.0) as i64;
    let w: Vec<f64> = (-r..=r)
        .map(|x| (-(x * x) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let s: f64 = w.iter().sum();
    w.iter().map(|v| (v / s) as f32).collect()
}

/// 1-D convolution along a strided line with clamp-to-edge.
fn convolve_line(src: &[f32], dst: &mut [f32], n: usize, stride: usize, base: usize, k: &[f32]) {
    let r = (k.len() / 2) as i64;
    for x in 0..n as i64 {
        let mut acc = 0.0f32;
        for (t, w) in k.iter().enumerate() {
            let xi = (x + t as i64 - r).clamp(0, n as i64 - 1) as usize;
            acc += w * src[base + xi * stride];
        }
        dst[base + x as usize * stride] = acc;
    }
}

/// Separable in-plane blur of one slice (ni × nj), using `tmp` as scratch.
fn blur_slice(slice: &mut [f32], tmp: &mut [f32], ni: usize, nj: usize, kx: &[f32], ky: &[f32]) {
    if kx.len() > 1 {
        for j in 0..nj {
            convolve_line(slice, tmp, ni, 1, j * ni, kx);
        }
    } else {
        tmp.copy_from_slice(slice);
    }
    if ky.len() > 1 {
        for i in 0..ni {
            convolve_line(tmp, slice, nj, ni, i, ky);
        }
    } else {
        slice.copy_from_slice(tmp);
    }
}

/// Correlated noise of slice k, before scaling.
fn noise_slice(seed: u64, grid: &Grid, k: usize, out: &mut [f32], tmp: &mut [f32], kn: &[f32]) {
    let [ni, nj, _] = grid.dims;
    let base = (k * ni * nj) as u64;
    for (n, v) in out.iter_mut().enumerate() {
        *v = hash_normal(seed, base + n as u64) as f32;
    }
    blur_slice(out, tmp, ni, nj, kn, kn);
}

/// Index box of a world box on one slice, or None if it misses the slice.
fn slice_box(grid: &Grid, b: &Aabb, z: f64) -> Option<[usize; 4]> {
    if z < b.lo.z || z > b.hi.z {
        return None;
    }
    let (i0, i1) = grid.range(0, b.lo.x, b.hi.x);
    let (j0, j1) = grid.range(1, b.lo.y, b.hi.y);
    (i0 < i1 && j0 < j1).then_some([i0, i1, j0, j1])
}

/// Paint every layer with analytic partial volume and evaluate the truth
/// mask at voxel centres; `progress` receives [0, share].
pub fn rasterise(
    scene: &Scene,
    grid: &Grid,
    noise_seed: u64,
    calcium_excluded: bool,
    progress: &(dyn Fn(f64) + Sync),
    share: f64,
) -> Raster {
    let [ni, nj, nk] = grid.dims;
    let plane = ni * nj;
    let mut image = vec![0f32; grid.len()];
    let mut mask = vec![0u8; grid.len()];
    let mut noise_sums = vec![(0.0, 0.0); nk];
    let mut noise = vec![0f32; grid.len()];
    let [sx, sy, sz] = grid.spacing;
    // Coverage ramps are at most this wide: grow culling boxes by it.
    let reach = sx + sy + sz;
    let kn = gaussian_kernel(NOISE_CORRELATION_VOXELS);
    let tracker = SliceProgress::new(nk, 0.0, share, progress);
    let an = &scene.anatomy;
    let calcium = if calcium_excluded {
        an.calcium.as_slice()
    } else {
        &[]
    };
    image
        .par_chunks_mut(plane)
        .zip(mask.par_chunks_mut(plane))
        .zip(noise_sums.par_iter_mut())
        .zip(noise.par_chunks_mut(plane))
        .enumerate()
        .for_each(|(k, (((img, msk), sums), nz))| {
            let z = grid.origin.z + k as f64 * sz;
            let active: Vec<(usize, [usize; 4])> = scene
                .layers
                .iter()
                .enumerate()
                .filter_map(|(l, layer)| {
                    slice_box(grid, &layer.aabb.grow(reach), z).map(|b| (l, b))
                })
                .collect();
            let truth_box = slice_box(grid, &scene.truth_aabb, z);
            // Tiles of TILE×TILE voxels: each layer is classified once per
            // tile from its distance at the tile centre (distances are close
            // to 1-Lipschitz), so voxels deep inside or far outside a layer
            // never evaluate it.
            let tile_radius = 0.5 * TILE as f64 * (sx * sx + sy * sy).sqrt();
            let margin = LIPSCHITZ_SAFETY * (tile_radius + reach) + TILE_MARGIN_MM;
            let mut plan: Vec<(usize, [usize; 4], Cover)> = Vec::with_capacity(active.len());
            for tj in (0..nj).step_by(TILE) {
                for ti in (0..ni).step_by(TILE) {
                    let (ti1, tj1) = ((ti + TILE).min(ni), (tj + TILE).min(nj));
                    let centre = Point3::new(
                        grid.origin.x + 0.5 * (ti + ti1 - 1) as f64 * sx,
                        grid.origin.y + 0.5 * (tj + tj1 - 1) as f64 * sy,
                        z,
                    );
                    let probe = Probe::new(centre, an);
                    plan.clear();
                    for &(l, b) in &active {
                        if b[0] >= ti1 || b[1] <= ti || b[2] >= tj1 || b[3] <= tj {
                            continue;
                        }
                        let d = (scene.layers[l].shape)(&probe).0;
                        let cover = if d > margin {
                            continue;
                        } else if d < -margin {
                            Cover::Full
                        } else {
                            Cover::Partial
                        };
                        plan.push((l, b, cover));
                    }
                    for j in tj..tj1 {
                        let in_truth_row = truth_box.is_some_and(|b| j >= b[2] && j < b[3]);
                        for i in ti..ti1 {
                            let p = grid.point(i, j, k);
                            let probe = Probe::new(p, an);
                            let mut v = AIR_HU;
                            for &(l, b, cover) in &plan {
                                if i < b[0] || i >= b[1] || j < b[2] || j >= b[3] {
                                    continue;
                                }
                                let layer = &scene.layers[l];
                                if cover == Cover::Full {
                                    v = (layer.hu)(&p);
                                    continue;
                                }
                                let (d, n) = (layer.shape)(&probe);
                                // Width of the voxel projected on the surface normal.
                                let w = n.x.abs() * sx + n.y.abs() * sy + n.z.abs() * sz;
                                let c = match layer.thin_mm {
                                    None => (0.5 - d / w).clamp(0.0, 1.0),
                                    Some(t) => slab_coverage(d + 0.5 * t, t, w),
                                };
                                if c > 0.0 {
                                    v += c * ((layer.hu)(&p) - v);
                                }
                            }
                            img[i + ni * j] = v as f32;
                            if in_truth_row {
                                let b = truth_box.unwrap();
                                if i >= b[0]
                                    && i < b[1]
                                    && probe.lumen().0 < 0.0
                                    && an.lumen.in_truth_range(&p)
                                {
                                    let calcified = calcium.iter().any(|e| {
                                        let q = e.rot.transpose() * (p - e.centre);
                                        q.component_div(&e.semi).norm_squared() < 1.0
                                    });
                                    msk[i + ni * j] = u8::from(!calcified);
                                }
                            }
                        }
                    }
                }
            }
            // Noise statistics of this slice, in a fixed order.
            let mut tmp = vec![0f32; plane];
            noise_slice(noise_seed, grid, k, nz, &mut tmp, &kn);
            let (mut s, mut s2) = (0.0f64, 0.0f64);
            for &v in nz.iter() {
                s += v as f64;
                s2 += (v as f64) * (v as f64);
            }
            *sums = (s, s2);
            tracker.slice_done();
        });
    Raster {
        image,
        mask,
        noise,
        noise_sums,
    }
}

/// Share of a voxel of projected width `w` covered by a slab of thickness
/// `t` whose mid-surface is `x` ≥ 0 from the voxel centre (box filter).
fn slab_coverage(x: f64, t: f64, w: f64) -> f64 {
    let lo = (x - 0.5 * w).max(-0.5 * t);
    let hi = (x + 0.5 * w).min(0.5 * t);
    ((hi - lo) / w).clamp(0.0, 1.0)
}

/// HU range of the output (12-bit CT with the usual −1024 offset).
pub const HU_MIN: f64 = -1024.0;
pub const HU_MAX: f64 = 3071.0;

/// Blur by the PSF, add noise scaled to std `noise_hu`, round and clamp.
/// `progress` receives values in [start, 1].
pub fn finish(
    raster: &Raster,
    grid: &Grid,
    noise_hu: f64,
    progress: &(dyn Fn(f64) + Sync),
    start: f64,
) -> Vec<i16> {
    let [ni, nj, nk] = grid.dims;
    let plane = ni * nj;
    let sigma_mm = PSF_FWHM_MM / FWHM_TO_SIGMA;
    let kx = gaussian_kernel(sigma_mm / grid.spacing[0]);
    let ky = gaussian_kernel(sigma_mm / grid.spacing[1]);
    let kz = gaussian_kernel(sigma_mm / grid.spacing[2]);
    // Noise mean and std over the whole volume, summed in slice order.
    let (s, s2) = raster
        .noise_sums
        .iter()
        .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    let n = grid.len() as f64;
    let mean = s / n;
    let std = (s2 / n - mean * mean).max(0.0).sqrt();
    let scale = if noise_hu > 0.0 && std > 0.0 {
        noise_hu / std
    } else {
        0.0
    };
    let rz = (kz.len() / 2) as i64;
    let tracker = SliceProgress::new(nk, start, 1.0, progress);
    let mut out = vec![0i16; grid.len()];
    out.par_chunks_mut(plane).enumerate().for_each(|(k, o)| {
        let mut acc = vec![0f32; plane];
        for (t, w) in kz.iter().enumerate() {
            let kk = (k as i64 + t as i64 - rz).clamp(0, nk as i64 - 1) as usize;
            let src = &raster.image[kk * plane..(kk + 1) * plane];
            for (a, &v) in acc.iter_mut().zip(src) {
                *a += w * v;
            }
        }
        let mut tmp = vec![0f32; plane];
        blur_slice(&mut acc, &mut tmp, ni, nj, &kx, &ky);
        let nz = &raster.noise[k * plane..(k + 1) * plane];
        for ((dst, &a), &e) in o.iter_mut().zip(&acc).zip(nz) {
            let v = a as f64
                + if scale > 0.0 {
                    (e as f64 - mean) * scale
                } else {
                    0.0
                };
            *dst = v.round().clamp(HU_MIN, HU_MAX) as i16;
        }
        tracker.slice_done();
    });
    out
}
