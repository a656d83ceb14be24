//! Hough circleness on an axial slice, in millimetres (gradient voting, as
//! ITK's HoughTransform2DCirclesImageFilter; docs/segment.md).
//!
//! Edges are the gradient maxima along the gradient (non-maximum suppression,
//! so a rim is one pixel thick whatever the blur). Each edge pixel votes
//! along +∇I (towards the bright side: a contrast lumen is bright) at every
//! step of one pixel between r_min and r_max, into the radius bin of that
//! step, with a weight equal to the arc length (mm) the pixel stands for.
//! A full circle of radius r therefore casts 2πr mm of votes at its centre,
//! and the circleness
//!     C(c) = max_b  Σ_{window around c} A(·, b) / (2π r_b)
//! is the fraction of the circumference whose edges point at c, in [0, 1].
//! A rim pixel votes once per bin, so the window at one bin counts it at
//! most once. The window reaches WINDOW_HALF_MM each side of c (3 × 3
//! pixels at 0.75 mm and coarser, 5 × 5 with a partial outer ring at
//! 0.5 mm): a real lumen is not a perfect circle, its edge normals miss the
//! centre by a millimetre or so, and a window of fixed pixels shrank in
//! millimetres on finer grids (the real CT's anchor scored 0.63 at 0.75 mm
//! and 0.38 at 0.5 mm).

use super::filter::{kernel, smooth2};

#[derive(Debug, Clone, Copy)]
pub struct HoughParams {
    pub r_min_mm: f64,
    pub r_max_mm: f64,
    /// Gaussian of the derivative filter.
    pub sigma_mm: f64,
    /// Least gradient magnitude of an edge (HU/mm).
    pub grad_min: f64,
    /// The bright side of an edge (1.5 mm along +∇I) must reach this (HU).
    pub bright_min: f64,
}

impl Default for HoughParams {
    fn default() -> Self {
        HoughParams {
            r_min_mm: 10.0,
            r_max_mm: 35.0,
            sigma_mm: 1.5,
            grad_min: 30.0,
            bright_min: 150.0,
        }
    }
}

/// Per-pixel circleness in [0, 1] and the radius (mm) it was found at.
pub struct CircleMap {
    pub ni: usize,
    pub nj: usize,
    /// The circleness: votes within WINDOW_HALF_MM, what thresholds judge.
    pub c: Vec<f32>,
    /// Where circles are: the same sums, uncapped where the window is wider
    /// than 3 × 3 pixels (capped, they are flat about a centre).
    pub peak: Vec<f32>,
    pub r_mm: Vec<f32>,
    /// The slice lightly smoothed (σ = EDGE_SIGMA_MM), for edge radii.
    edge_img: Vec<f32>,
    sx: f64,
    sy: f64,
}

/// Smoothing for the radial edge search: light, so the wall's outer edge
/// (wall → fat, ~1.8 mm out) does not pull the lumen edge outward, as the
/// Hough σ does by about half a millimetre.
const EDGE_SIGMA_MM: f64 = 0.6;
/// Rays of the radial edge search.
const EDGE_RAYS: usize = 72;

/// How far from a centre (mm) a vote still counts for it: the reach of the
/// 3 × 3 window on the 0.75 mm grid a 1.5 mm scan is read at.
const WINDOW_HALF_MM: f64 = 1.125;

/// The window's weights by pixel offset 0, 1, 2, … on pixels of `s` mm:
/// 3 × 3 at least; on finer pixels out to WINDOW_HALF_MM, the outermost
/// ring weighted by the part of it that lies within.
fn window_weights(s: f64) -> Vec<f32> {
    let mut w = vec![1.0, 1.0];
    for d in 2.. {
        let inside = (WINDOW_HALF_MM - (d as f64 - 0.5) * s) / s;
        if inside <= 1e-9 {
            break;
        }
        w.push(inside.min(1.0) as f32);
    }
    w
}

/// Σ of `w[|k − c|]·at(k)` for k within the weights' reach of `c` in 0..n:
/// the centre first, then outwards pair by pair (a fixed order, so a
/// 3 × 3 window adds as it always has).
fn centred_sum(c: usize, n: usize, w: &[f32], at: impl Fn(usize) -> f32) -> f32 {
    let mut s = at(c);
    for (d, &wd) in w.iter().enumerate().skip(1) {
        if c >= d {
            s += wd * at(c - d);
        }
        if c + d < n {
            s += wd * at(c + d);
        }
    }
    s
}

/// Per pixel, the largest over the radius bins of the votes within
/// the window `weights` (by offset in i and j) over the bin's circumference
/// 2π r(b), and that bin.
fn windowed_max(
    acc: &[f32],
    ni: usize,
    nj: usize,
    nb: usize,
    weights: (&[f32], &[f32]),
    r: impl Fn(usize) -> f64,
) -> (Vec<f32>, Vec<usize>) {
    let n = ni * nj;
    let mut c = vec![0f32; n];
    let mut best_b = vec![0usize; n];
    let mut tmp = vec![0f32; n];
    for b in 0..nb {
        let a = &acc[b * n..(b + 1) * n];
        for j in 0..nj {
            for i in 0..ni {
                tmp[i + j * ni] = centred_sum(i, ni, weights.0, |ii| a[ii + j * ni]);
            }
        }
        let norm = 1.0 / (2.0 * std::f64::consts::PI * r(b)) as f32;
        for j in 0..nj {
            for i in 0..ni {
                let v = i + j * ni;
                let cv = centred_sum(j, nj, weights.1, |jj| tmp[i + jj * ni]) * norm;
                if cv > c[v] {
                    c[v] = cv;
                    best_b[v] = b;
                }
            }
        }
    }
    (c, best_b)
}

/// A detected circle, in pixel coordinates of the slice.
#[derive(Debug, Clone, Copy)]
pub struct Circle {
    pub i: f64,
    pub j: f64,
    pub r_mm: f64,
    pub c: f64,
}

#[inline]
fn bilinear(img: &[f32], ni: usize, nj: usize, x: f64, y: f64) -> f64 {
    let x = x.clamp(0.0, (ni - 1) as f64);
    let y = y.clamp(0.0, (nj - 1) as f64);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(ni - 1), (y0 + 1).min(nj - 1));
    let (fx, fy) = (x - x0 as f64, y - y0 as f64);
    let v = |i: usize, j: usize| img[i + j * ni] as f64;
    (1.0 - fy) * ((1.0 - fx) * v(x0, y0) + fx * v(x1, y0))
        + fy * ((1.0 - fx) * v(x0, y1) + fx * v(x1, y1))
}

/// Circleness of a slice `img` (HU, i fastest) with pixel size `sx`×`sy` mm.
pub fn circleness(
    img: &[f32],
    ni: usize,
    nj: usize,
    sx: f64,
    sy: f64,
    p: &HoughParams,
) -> CircleMap {
    let mut sm = img.to_vec();
    smooth2(
        &mut sm,
        ni,
        nj,
        &kernel(p.sigma_mm / sx),
        &kernel(p.sigma_mm / sy),
    );
    // Gradient in HU/mm (central differences of the smoothed slice).
    let n = ni * nj;
    let mut gx = vec![0f32; n];
    let mut gy = vec![0f32; n];
    let mut mag = vec![0f32; n];
    for j in 1..nj.saturating_sub(1) {
        for i in 1..ni - 1 {
            let v = i + j * ni;
            let a = (sm[v + 1] - sm[v - 1]) as f64 / (2.0 * sx);
            let b = (sm[v + ni] - sm[v - ni]) as f64 / (2.0 * sy);
            gx[v] = a as f32;
            gy[v] = b as f32;
            mag[v] = a.hypot(b) as f32;
        }
    }
    let h = sx.min(sy);
    let nb = ((p.r_max_mm - p.r_min_mm) / h).floor() as usize + 1;
    let mut acc = vec![0f32; nb * n];
    for j in 1..nj.saturating_sub(1) {
        for i in 1..ni - 1 {
            let v = i + j * ni;
            let m = mag[v] as f64;
            if m < p.grad_min {
                continue;
            }
            let (ux, uy) = (gx[v] as f64 / m, gy[v] as f64 / m);
            // Non-maximum suppression one pixel (h mm) along ±∇I.
            let (dx, dy) = (ux * h / sx, uy * h / sy);
            let (fi, fj) = (i as f64, j as f64);
            if bilinear(&mag, ni, nj, fi + dx, fj + dy) > m
                || bilinear(&mag, ni, nj, fi - dx, fj - dy) > m
            {
                continue;
            }
            let bright = bilinear(&sm, ni, nj, fi + ux * 1.5 / sx, fj + uy * 1.5 / sy);
            if bright < p.bright_min {
                continue;
            }
            // Arc length (mm) this pixel stands for on a one-pixel-thick edge.
            let w = (1.0 / (ux.abs() / sy).max(uy.abs() / sx)) as f32;
            for b in 0..nb {
                let d = p.r_min_mm + b as f64 * h;
                let ci = (fi + ux * d / sx).round();
                let cj = (fj + uy * d / sy).round();
                if ci < 0.0 || cj < 0.0 || ci >= ni as f64 || cj >= nj as f64 {
                    break;
                }
                acc[b * n + ci as usize + cj as usize * ni] += w;
            }
        }
    }
    // Votes within the window in mm, per bin, normalised by the bin's
    // circumference.
    let r_bin = |b: usize| p.r_min_mm + b as f64 * h;
    let (wi, wj) = (window_weights(sx), window_weights(sy));
    let (mut c, best_b) = windowed_max(&acc, ni, nj, nb, (&wi, &wj), r_bin);
    // Radius: parabolic peak of the windowed votes over the neighbouring bins.
    let box_at = |b: usize, v: usize| -> f64 {
        let (i, j) = (v % ni, v / ni);
        let (hi, hj) = (wi.len() - 1, wj.len() - 1);
        let mut s = 0.0;
        for jj in j.saturating_sub(hj)..=(j + hj).min(nj - 1) {
            for ii in i.saturating_sub(hi)..=(i + hi).min(ni - 1) {
                let w = wi[ii.abs_diff(i)] * wj[jj.abs_diff(j)];
                s += (w * acc[b * n + ii + jj * ni]) as f64;
            }
        }
        s / r_bin(b)
    };
    let mut r_mm = vec![0f32; n];
    for v in 0..n {
        let b = best_b[v];
        let mut rb = r_bin(b);
        if c[v] > 0.05 && b > 0 && b + 1 < nb {
            let (l, m, r) = (box_at(b - 1, v), box_at(b, v), box_at(b + 1, v));
            let den = l - 2.0 * m + r;
            if den < 0.0 {
                rb += (0.5 * (l - r) / den).clamp(-0.5, 0.5) * h;
            }
        }
        r_mm[v] = rb as f32;
    }
    // A wider window's capped sums are flat about a circle's centre (every
    // vote within reach of several pixels); its uncapped ones peak there.
    // A 3 × 3 window keeps the capped map, as it always had.
    let peak = if wi.len() == 2 && wj.len() == 2 {
        c.iter().map(|x| x.min(1.0)).collect()
    } else {
        c.clone()
    };
    for x in c.iter_mut() {
        *x = x.min(1.0);
    }
    let mut edge_img = img.to_vec();
    smooth2(
        &mut edge_img,
        ni,
        nj,
        &kernel(EDGE_SIGMA_MM / sx),
        &kernel(EDGE_SIGMA_MM / sy),
    );
    CircleMap {
        ni,
        nj,
        c,
        peak,
        r_mm,
        edge_img,
        sx,
        sy,
    }
}

impl CircleMap {
    /// Up to `max` circles by greedy peak picking: take the best pixel of
    /// the location map (`peak`), blank a disc of its radius, repeat while
    /// its circleness C ≥ `c_min`.
    pub fn peaks(&self, sx: f64, sy: f64, c_min: f64, max: usize) -> Vec<Circle> {
        let mut c = self.peak.clone();
        let mut out = Vec::new();
        while out.len() < max {
            let Some((v, &cv)) = c
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1).then(b.0.cmp(&a.0)))
            else {
                break;
            };
            if cv <= 0.0 || (self.c[v] as f64) < c_min {
                break;
            }
            let (i, j) = (v % self.ni, v / self.ni);
            let r = self.r_mm[v] as f64;
            out.push(self.refine(i, j, r));
            for jj in 0..self.nj {
                for ii in 0..self.ni {
                    let dx = (ii as f64 - i as f64) * sx;
                    let dy = (jj as f64 - j as f64) * sy;
                    if dx * dx + dy * dy <= r * r {
                        c[ii + jj * self.ni] = 0.0;
                    }
                }
            }
        }
        out
    }

    /// Sub-pixel centre: the mean over the 3×3 neighbourhood weighted by
    /// the location map (`peak`).
    pub fn refine(&self, i: usize, j: usize, r: f64) -> Circle {
        let (mut sw, mut si, mut sj) = (0.0, 0.0, 0.0);
        for jj in j.saturating_sub(1)..=(j + 1).min(self.nj - 1) {
            for ii in i.saturating_sub(1)..=(i + 1).min(self.ni - 1) {
                let w = self.peak[ii + jj * self.ni] as f64;
                sw += w;
                si += w * ii as f64;
                sj += w * jj as f64;
            }
        }
        let (ci, cj) = if sw > 0.0 {
            (si / sw, sj / sw)
        } else {
            (i as f64, j as f64)
        };
        Circle {
            i: ci,
            j: cj,
            r_mm: self.edge_radius(ci, cj, r).unwrap_or(r),
            c: self.c[i + j * self.ni] as f64,
        }
    }

    /// Radius of the lumen edge around (ci, cj): along each ray, the steepest
    /// bright-to-dark fall within ±30 % of `r0` (parabolic sub-step), median
    /// over the rays. The votes fix the centre; this fixes the radius.
    pub fn edge_radius(&self, ci: f64, cj: f64, r0: f64) -> Option<f64> {
        let h = 0.25 * self.sx.min(self.sy);
        let (a, b) = (0.7 * r0, 1.3 * r0);
        let n = ((b - a) / h) as usize;
        let mut radii = Vec::with_capacity(EDGE_RAYS);
        let mut prof = vec![0.0; n + 1];
        for t in 0..EDGE_RAYS {
            let th = t as f64 * 2.0 * std::f64::consts::PI / EDGE_RAYS as f64;
            let (ux, uy) = (th.cos() / self.sx, th.sin() / self.sy);
            for (s, v) in prof.iter_mut().enumerate() {
                let d = a + s as f64 * h;
                *v = bilinear(&self.edge_img, self.ni, self.nj, ci + ux * d, cj + uy * d);
            }
            // Derivative along the ray; the edge is its most negative value.
            let g: Vec<f64> = (1..n).map(|s| prof[s + 1] - prof[s - 1]).collect();
            let Some((m, _)) = g.iter().enumerate().min_by(|x, y| x.1.total_cmp(y.1)) else {
                continue;
            };
            if m == 0 || m + 1 >= g.len() {
                continue;
            }
            let (l, c, r) = (g[m - 1], g[m], g[m + 1]);
            let den = l - 2.0 * c + r;
            let off = if den > 0.0 {
                (0.5 * (l - r) / den).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            radii.push(a + (m as f64 + 1.0 + off) * h);
        }
        if radii.len() < EDGE_RAYS / 2 {
            return None;
        }
        radii.sort_unstable_by(f64::total_cmp);
        Some(radii[radii.len() / 2])
    }
}
