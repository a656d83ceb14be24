//! Gaussian pre-blur of a binary mask, so that marching cubes at iso 0.5
//! follows a smooth level set instead of the voxel staircase.

use rayon::prelude::*;

use coapt_base::Result;
use coapt_geom::Volume;

/// Crop `mask` to the box of its nonzero voxels plus a margin of 3σ + 2
/// voxels (clipped to the grid), as f32 0/1, blurred with a Gaussian of
/// standard deviation `sigma_mm` along each axis (replicating the border, so
/// a mask cut by the border stays cut flat there). Returns `None` for an
/// empty mask.
pub fn blurred(mask: &Volume<u8>, sigma_mm: f64) -> Result<Option<Volume<f32>>> {
    let d = mask.dims();
    let sp = mask.spacing();
    let sig = [0, 1, 2].map(|a| sigma_mm / sp[a]);
    let margin = sig.map(|s| (3.0 * s).ceil() as usize + 2);
    let mut lo = [usize::MAX; 3];
    let mut hi = [0usize; 3];
    for k in 0..d[2] {
        for j in 0..d[1] {
            let row = &mask.as_slice()[d[0] * (j + d[1] * k)..d[0] * (j + d[1] * k + 1)];
            if let Some(f) = row.iter().position(|&v| v != 0) {
                let l = d[0] - 1 - row.iter().rev().position(|&v| v != 0).unwrap();
                for (a, (x0, x1)) in [(f, l), (j, j), (k, k)].into_iter().enumerate() {
                    lo[a] = lo[a].min(x0);
                    hi[a] = hi[a].max(x1);
                }
            }
        }
    }
    if lo[0] == usize::MAX {
        return Ok(None);
    }
    let lo = [0, 1, 2].map(|a| lo[a].saturating_sub(margin[a]));
    let hi = [0, 1, 2].map(|a| (hi[a] + margin[a] + 1).min(d[a]));
    let mut vol = mask.crop(lo, hi)?.map(|&v| (v != 0) as u8 as f32);
    for (a, &s) in sig.iter().enumerate() {
        if s > 0.0 {
            vol = blur_axis(&vol, a, s);
        }
    }
    Ok(Some(vol))
}

fn blur_axis(vol: &Volume<f32>, axis: usize, sigma: f64) -> Volume<f32> {
    let r = (3.0 * sigma).ceil() as i64;
    let mut w: Vec<f64> = (-r..=r)
        .map(|m| (-(m * m) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let s: f64 = w.iter().sum();
    w.iter_mut().for_each(|x| *x /= s);
    let d = vol.dims();
    let src = vol.as_slice();
    let mut out = vol.clone();
    out.as_slice_mut()
        .par_chunks_mut(d[0])
        .enumerate()
        .for_each(|(row, o)| {
            let (j, k) = ((row % d[1]) as i64, (row / d[1]) as i64);
            for (i, ov) in o.iter_mut().enumerate() {
                let mut acc = 0.0f64;
                for (m, &wm) in (-r..=r).zip(&w) {
                    let mut p = [i as i64, j, k];
                    p[axis] = (p[axis] + m).clamp(0, d[axis] as i64 - 1);
                    acc += wm
                        * src[p[0] as usize + d[0] * (p[1] as usize + d[1] * p[2] as usize)] as f64;
                }
                *ov = acc as f32;
            }
        });
    out
}
