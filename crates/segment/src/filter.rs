//! Separable Gaussian smoothing in mm on a 3-D grid (noise suppression
//! before thresholding) and on 2-D slices (gradients for the Hough filter).

use rayon::prelude::*;

/// Normalised Gaussian kernel of standard deviation `sigma_px` (±3σ).
pub fn kernel(sigma_px: f64) -> Vec<f32> {
    if sigma_px < 1e-3 {
        return vec![1.0];
    }
    let r = (3.0 * sigma_px).ceil() as i64;
    let mut k: Vec<f64> = (-r..=r)
        .map(|x| (-(x * x) as f64 / (2.0 * sigma_px * sigma_px)).exp())
        .collect();
    let s: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= s);
    k.into_iter().map(|v| v as f32).collect()
}

/// Convolve one line with clamped borders into `dst`. Taps outermost, so
/// the inner loop runs along the line and vectorises; every sample still
/// sums its taps in kernel order from zero, the same f32 operations as a
/// per-sample loop (results do not depend on the loop order).
fn line(src: &[f32], dst: &mut [f32], k: &[f32], pad: &mut Vec<f32>) {
    let n = src.len();
    let r = k.len() / 2;
    pad.clear();
    pad.extend(std::iter::repeat_n(src[0], r));
    pad.extend_from_slice(src);
    pad.extend(std::iter::repeat_n(src[n - 1], r));
    dst.fill(0.0);
    for (t, &w) in k.iter().enumerate() {
        for (d, &x) in dst.iter_mut().zip(&pad[t..t + n]) {
            *d += w * x;
        }
    }
}

/// Smooth a 2-D image (i fastest) in place.
pub fn smooth2(img: &mut [f32], ni: usize, nj: usize, kx: &[f32], ky: &[f32]) {
    if ni == 0 || nj == 0 {
        return;
    }
    let mut pad = Vec::with_capacity(ni + kx.len());
    let mut buf = vec![0f32; ni];
    if kx.len() > 1 {
        for row in img.chunks_exact_mut(ni) {
            line(row, &mut buf, kx, &mut pad);
            row.copy_from_slice(&buf);
        }
    }
    if ky.len() > 1 {
        // Along j a row at a time: out_j = Σ_t w_t · row(clamp(j + t − r)).
        let src = img.to_vec();
        let r = (ky.len() / 2) as isize;
        for (j, out) in img.chunks_exact_mut(ni).enumerate() {
            out.fill(0.0);
            for (t, &w) in ky.iter().enumerate() {
                let jj = (j as isize + t as isize - r).clamp(0, nj as isize - 1) as usize;
                for (o, &x) in out.iter_mut().zip(&src[jj * ni..(jj + 1) * ni]) {
                    *o += w * x;
                }
            }
        }
    }
}

/// Smooth a 3-D grid with a Gaussian of `sigma_mm` (per-axis pixels).
pub fn smooth3(vol: &mut [f32], dims: [usize; 3], spacing: [f64; 3], sigma_mm: f64) {
    let [ni, nj, nk] = dims;
    let plane = ni * nj;
    let kx = kernel(sigma_mm / spacing[0]);
    let ky = kernel(sigma_mm / spacing[1]);
    let kz = kernel(sigma_mm / spacing[2]);
    vol.par_chunks_mut(plane)
        .for_each(|s| smooth2(s, ni, nj, &kx, &ky));
    if kz.len() > 1 {
        let src = vol.to_vec();
        vol.par_chunks_mut(plane).enumerate().for_each(|(k, out)| {
            let r = (kz.len() / 2) as isize;
            out.iter_mut().for_each(|v| *v = 0.0);
            for (t, &w) in kz.iter().enumerate() {
                let kk = (k as isize + t as isize - r).clamp(0, nk as isize - 1) as usize;
                let s = &src[kk * plane..(kk + 1) * plane];
                for (o, &x) in out.iter_mut().zip(s) {
                    *o += w * x;
                }
            }
        });
    }
}
