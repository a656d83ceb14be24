//! The region of interest: a box around the tracked ascending aorta,
//! reaching far enough below the last tracked slice for the root and the
//! LVOT, widened to hold the landmarks when given. Everything heavy runs on
//! this crop; `Volume::crop` keeps its affine exact.

use serde::Serialize;

use rayon::prelude::*;

use super::track::TrackPoint;
use coapt_base::Result;
use coapt_geom::{Point3, Volume};

/// Lateral margin beyond the tracked radius (mm).
const XY_MARGIN_MM: f64 = 30.0;
/// How far below the last tracked slice the box reaches (mm): the root,
/// the LVOT and the LV entrance the IDT must see to stop before it.
const BELOW_MM: f64 = 70.0;
/// The box reaches at least this far below the top slice (mm), whatever the
/// tracking did: tracking may stop early in a noisy scan, and the root of an
/// adult aorta lies 60–120 mm below the top of a cardiac CTA.
const MIN_DEPTH_MM: f64 = 130.0;
/// Lateral reach around the last tracked centre over that depth (mm): the
/// root of a tilted valve sits off the tracked axis.
const BELOW_LATERAL_MM: f64 = 50.0;
/// Margin around landmarks (mm).
const LANDMARK_MARGIN_MM: f64 = 30.0;
/// Margin around the box of the lumen reached on the coarse grid (mm): its
/// blocks are 2 mm and the smoothing and opening need a few voxels more.
const REACH_MARGIN_MM: f64 = 8.0;

#[derive(Debug, Clone, Copy)]
pub struct RoiBox {
    pub lo: [usize; 3],
    pub hi: [usize; 3],
}

#[derive(Debug, Clone, Serialize)]
pub struct RoiReport {
    pub lo: [usize; 3],
    pub hi: [usize; 3],
    pub dims: [usize; 3],
    pub fraction_of_volume: f64,
}

/// `reach`: index box of the lumen followed past the track
/// ([`super::reach::lumen_reach`]), if found.
pub fn roi_box(
    ct: &Volume<i16>,
    track: &[TrackPoint],
    dk: isize,
    landmarks: &[Point3],
    reach: Option<&super::reach::Reach>,
) -> RoiBox {
    let d = ct.dims();
    let sp = ct.spacing();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut add = |p: [f64; 3], m: [f64; 3]| {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a] - m[a]);
            hi[a] = hi[a].max(p[a] + m[a]);
        }
    };
    for t in track {
        let m = t.r_mm + XY_MARGIN_MM;
        add([t.i, t.j, t.k as f64], [m / sp[0], m / sp[1], 0.0]);
    }
    let last = track.last().expect("a track has its seed");
    let top = track[0].k as f64;
    let below_last = last.k as f64 + dk as f64 * BELOW_MM / sp[2];
    let below_top = top + dk as f64 * MIN_DEPTH_MM / sp[2];
    let below = if dk < 0 {
        below_last.min(below_top)
    } else {
        below_last.max(below_top)
    };
    for kk in [last.k as f64, below] {
        add(
            [last.i, last.j, kk],
            [BELOW_LATERAL_MM / sp[0], BELOW_LATERAL_MM / sp[1], 0.0],
        );
    }
    for p in landmarks {
        let q = ct.world_to_index(p);
        add(
            q,
            [
                LANDMARK_MARGIN_MM / sp[0],
                LANDMARK_MARGIN_MM / sp[1],
                LANDMARK_MARGIN_MM / sp[2],
            ],
        );
    }
    if let Some(super::reach::Reach {
        lo: rlo, hi: rhi, ..
    }) = reach
    {
        let m = [0, 1, 2].map(|a| REACH_MARGIN_MM / sp[a]);
        add([0, 1, 2].map(|a| rlo[a] as f64), m);
        add([0, 1, 2].map(|a| rhi[a] as f64 - 1.0), m);
    }
    let mut b = RoiBox {
        lo: [0; 3],
        hi: [0; 3],
    };
    for a in 0..3 {
        b.lo[a] = lo[a].floor().clamp(0.0, (d[a] - 1) as f64) as usize;
        b.hi[a] = (hi[a].ceil() as i64 + 1).clamp(b.lo[a] as i64 + 1, d[a] as i64) as usize;
    }
    b
}

impl RoiBox {
    pub fn report(&self, ct: &Volume<i16>) -> RoiReport {
        let dims = [0, 1, 2].map(|a| self.hi[a] - self.lo[a]);
        RoiReport {
            lo: self.lo,
            hi: self.hi,
            dims,
            fraction_of_volume: dims.iter().product::<usize>() as f64 / ct.len() as f64,
        }
    }
}

/// The ROI of `ct` as f32 HU, converted straight from the CT (one pass,
/// parallel over slices), and an all-zero uint8 volume on the ROI grid that
/// carries its exact affine, the one `Volume::crop` gives.
pub fn crop_f32(ct: &Volume<i16>, b: &RoiBox) -> Result<(Volume<u8>, Vec<f32>)> {
    let d = ct.dims();
    let dims = [0, 1, 2].map(|a| b.hi[a] - b.lo[a]);
    let mut affine = *ct.affine();
    let shift =
        affine * nalgebra::Vector4::new(b.lo[0] as f64, b.lo[1] as f64, b.lo[2] as f64, 1.0);
    for r in 0..3 {
        affine[(r, 3)] = shift[r];
    }
    let n = dims.iter().product::<usize>();
    let grid = Volume::from_fortran_vec(dims, affine, vec![0u8; n])?;
    let src = ct.as_slice();
    let mut img = vec![0f32; n];
    img.par_chunks_mut(dims[0] * dims[1])
        .enumerate()
        .for_each(|(k, plane)| {
            for (j, row) in plane.chunks_exact_mut(dims[0]).enumerate() {
                let o = b.lo[0] + d[0] * (b.lo[1] + j + d[1] * (b.lo[2] + k));
                for (x, &v) in row.iter_mut().zip(&src[o..o + dims[0]]) {
                    *x = v as f32;
                }
            }
        });
    Ok((grid, img))
}
