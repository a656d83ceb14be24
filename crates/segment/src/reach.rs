//! Where the lumen goes below the axial track, found on a coarse grid so the
//! region of interest can follow a tilted root without landmarks.
//!
//! The axial track stops where the aorta bends toward the valve; a tilted
//! root (60°) then lies 40–80 mm to the side of the last tracked centre, out
//! of a fixed box. Without the LVOT and the LV entrance in the box the IDT
//! sees no chamber to stop before and stopped inside the sinuses (full
//! preset, tilt 60°, noise 50 HU: the region ended 0–12 mm above the
//! annulus, Dice 0.959). With landmarks the box held them and was right.
//!
//! Here the CT is averaged over blocks of about 2 mm (noise drops by the
//! square root of the block's voxel count), thresholded halfway between the
//! stage threshold and the blood pool (stricter, so thin gaps to the
//! pulmonary trunk or atrium that the averaging blurs stay closed more
//! often), and a Dijkstra distance (mm, 26-neighbour) is grown from the seed
//! on the top slice down the bright blocks. Its 2-mm shells are cross-sections
//! of the lumen; where a shell holds more than [`CHAMBER_FACTOR`] times the
//! median shell so far, the front has entered a chamber (the LV), and it
//! goes on only [`PAST_CHAMBER_MM`] further. The box of the blocks reached
//! is added to the region of interest. (Growing a fixed 140 mm from the end
//! of the track instead swallowed the whole LV: a third of the full volume.)

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use rayon::prelude::*;

use super::track::TrackPoint;
use coapt_geom::Volume;

/// Block edge wanted (mm).
const BLOCK_MM: f64 = 2.0;
/// Shell width (mm).
const SHELL_MM: f64 = 2.0;
/// Shells judged before a chamber can be declared (the ascending aorta).
const MIN_SHELLS: usize = 10;
/// A shell this many times the median one is a chamber.
pub const CHAMBER_FACTOR: f64 = 2.0;
/// How far the front goes past the chamber's entrance (mm): what the IDT
/// needs to see of the LV to stop before it.
pub const PAST_CHAMBER_MM: f64 = 15.0;
/// Longest lumen path followed (mm), when no chamber is met.
pub const MAX_PATH_MM: f64 = 400.0;
/// Where the coarse threshold lies between the stage threshold (0) and the
/// blood pool (1).
const COARSE_CUT: f64 = 0.6;

/// What the coarse front did, for `segment.json`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Reach {
    /// Index-space box (inclusive lo, exclusive hi) of the blocks reached.
    pub lo: [usize; 3],
    pub hi: [usize; 3],
    /// Blocks per 2-mm shell of lumen path from the seed.
    pub shell_blocks: Vec<usize>,
    /// Path length where a chamber was entered (mm), if one was.
    pub chamber_mm: Option<f64>,
}

/// The lumen reached from the seed, or None when no track point is bright
/// on the coarse grid.
pub fn lumen_reach(
    ct: &Volume<i16>,
    track: &[TrackPoint],
    threshold: f64,
    blood: f64,
    max_path_mm: f64,
) -> Option<Reach> {
    let d = ct.dims();
    let sp = ct.spacing();
    let b = [0, 1, 2].map(|a| ((BLOCK_MM / sp[a]).round() as usize).max(1));
    let cd = [0, 1, 2].map(|a| d[a].div_ceil(b[a]));
    let cut = (threshold + COARSE_CUT * (blood - threshold)) as f32;
    let ci: Vec<usize> = (0..d[0]).map(|i| i / b[0]).collect();
    // Every other row and slice of a block is enough for its mean (12 of
    // 48 voxels on the full preset) and reads a quarter of the volume.
    let sub = [0, 1, 2].map(|a| if b[a] >= 2 { 2 } else { 1 });
    let src = ct.as_slice();
    // One coarse plane per task: each block's sum is made by one thread in
    // a fixed order, so the result does not depend on the thread count.
    let bright: Vec<bool> = (0..cd[2])
        .into_par_iter()
        .flat_map_iter(|ck| {
            let mut sum = vec![0f32; cd[0] * cd[1]];
            let mut cnt = vec![0u32; cd[0] * cd[1]];
            for k in (ck * b[2]..((ck + 1) * b[2]).min(d[2])).step_by(sub[2]) {
                for j in (0..d[1]).filter(|j| (j % b[1]) % sub[1] == 0) {
                    let row = &src[d[0] * (j + d[1] * k)..d[0] * (j + 1 + d[1] * k)];
                    let cj = j / b[1];
                    for (i, &v) in row.iter().enumerate() {
                        let c = ci[i] + cd[0] * cj;
                        sum[c] += v as f32;
                        cnt[c] += 1;
                    }
                }
            }
            sum.into_iter()
                .zip(cnt)
                .map(move |(s, n)| n > 0 && s >= cut * n as f32)
        })
        .collect();
    let coarse = |t: &TrackPoint| -> usize {
        let c = [
            (t.i.round().max(0.0) as usize / b[0]).min(cd[0] - 1),
            (t.j.round().max(0.0) as usize / b[1]).min(cd[1] - 1),
            (t.k / b[2]).min(cd[2] - 1),
        ];
        c[0] + cd[0] * (c[1] + cd[1] * c[2])
    };
    // The first bright track point (noise can darken a block at the seed).
    let source = track.iter().map(coarse).find(|&c| bright[c])?;
    let step = [0, 1, 2].map(|a| b[a] as f64 * sp[a]);
    let mut dist = vec![f64::INFINITY; bright.len()];
    let mut heap = BinaryHeap::new();
    dist[source] = 0.0;
    heap.push(Reverse((0u64, source)));
    let mut lo = [usize::MAX; 3];
    let mut hi = [0usize; 3];
    let mut shells: Vec<usize> = Vec::new();
    let mut limit = max_path_mm;
    let mut chamber = None;
    while let Some(Reverse((key, v))) = heap.pop() {
        let dv = f64::from_bits(key);
        if dv > dist[v] {
            continue;
        }
        if dv > limit {
            break;
        }
        // Pops come in increasing distance: a shell is complete once the
        // front has moved past it.
        let shell = (dv / SHELL_MM) as usize;
        while shells.len() <= shell {
            let done = shells.len();
            if limit == max_path_mm && done > MIN_SHELLS {
                let last = shells[done - 1];
                let mut prior = shells[..done - 1].to_vec();
                prior.sort_unstable();
                if last as f64 > CHAMBER_FACTOR * prior[prior.len() / 2] as f64 {
                    chamber = Some((done - 1) as f64 * SHELL_MM);
                    limit = done as f64 * SHELL_MM + PAST_CHAMBER_MM;
                }
            }
            shells.push(0);
        }
        shells[shell] += 1;
        let c = [v % cd[0], (v / cd[0]) % cd[1], v / (cd[0] * cd[1])];
        for a in 0..3 {
            lo[a] = lo[a].min(c[a] * b[a]);
            hi[a] = hi[a].max(((c[a] + 1) * b[a]).min(d[a]));
        }
        for dz in -1i64..=1 {
            for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let q = [c[0] as i64 + dx, c[1] as i64 + dy, c[2] as i64 + dz];
                    if (0..3).any(|a| q[a] < 0 || q[a] >= cd[a] as i64) {
                        continue;
                    }
                    let u = q[0] as usize + cd[0] * (q[1] as usize + cd[1] * q[2] as usize);
                    if !bright[u] {
                        continue;
                    }
                    let l = ((dx as f64 * step[0]).powi(2)
                        + (dy as f64 * step[1]).powi(2)
                        + (dz as f64 * step[2]).powi(2))
                    .sqrt();
                    let du = dv + l;
                    if du < dist[u] {
                        dist[u] = du;
                        heap.push(Reverse((du.to_bits(), u)));
                    }
                }
            }
        }
    }
    Some(Reach {
        lo,
        hi,
        shell_blocks: shells,
        chamber_mm: chamber,
    })
}
