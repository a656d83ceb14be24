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

/// Convolve `n` samples at `stride` starting at `base` (clamped border).
fn line(src: &[f32], dst: &mut [f32], n: usize, k: &[f32]) {
    let r = (k.len() / 2) as isize;
    for (x, d) in dst.iter_mut().enumerate().take(n) {
        let mut acc = 0f32;
        for (t, &w) in k.iter().enumerate() {
            let y = (x as isize + t as isize - r).clamp(0, n as isize - 1) as usize;
            acc += w * src[y];
        }
        *d = acc;
    }
}

/// Smooth a 2-D image (i fastest) in place.
pub fn smooth2(img: &mut [f32], ni: usize, nj: usize, kx: &[f32], ky: &[f32]) {
    let mut buf = vec![0f32; ni.max(nj)];
    let mut col = vec![0f32; nj];
    if kx.len() > 1 {
        for j in 0..nj {
            line(&img[j * ni..(j + 1) * ni], &mut buf, ni, kx);
            img[j * ni..(j + 1) * ni].copy_from_slice(&buf[..ni]);
        }
    }
    if ky.len() > 1 {
        for i in 0..ni {
            for j in 0..nj {
                col[j] = img[i + j * ni];
            }
            line(&col, &mut buf, nj, ky);
            for j in 0..nj {
                img[i + j * ni] = buf[j];
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
