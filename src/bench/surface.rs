//! `coapt bench surface`: in-process timings of marching cubes on one mask,
//! against the memory-bandwidth bound of one pass over the same bytes, and of
//! the whole default stage. Prints JSON (read by `tools/surface_crosscheck.py`).

use std::path::Path;
use std::time::Instant;

use rayon::prelude::*;
use serde_json::json;

use super::median;
use crate::Result;
use crate::io::nifti;
use crate::surface::{SurfaceParams, extract, surface_from_mask};

/// Time `f` `repeat` times; (min, median) seconds and the last result.
fn timed<T>(repeat: u32, mut f: impl FnMut() -> T) -> (f64, f64, T) {
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..repeat {
        let t = Instant::now();
        let r = std::hint::black_box(f());
        times.push(t.elapsed().as_secs_f64());
        last = Some(r);
    }
    let min = times.iter().cloned().fold(f64::INFINITY, f64::min);
    (min, median(times), last.expect("repeat ≥ 1"))
}

pub fn run(mask_path: &Path, iso: f64, repeat: u32, threads: usize) -> Result<String> {
    let mask = nifti::read_u8(mask_path)?;
    let bytes = mask.as_slice();
    // The bound: one parallel read of every voxel (a byte sum the compiler
    // vectorises: u32 partial sums of 64 Ki bytes cannot overflow), in the
    // same thread pool as the extraction.
    let (bw_min, bw_med, sum) = timed(repeat, || {
        bytes
            .par_chunks(1 << 16)
            .map(|c| c.iter().map(|&b| b as u32).sum::<u32>() as u64)
            .sum::<u64>()
    });
    let (mc_min, mc_med, s) = timed(repeat, || extract(&mask, iso));
    let params = SurfaceParams {
        iso,
        ..SurfaceParams::default()
    };
    let (st_min, st_med, (_, report)) = timed(repeat.min(3), || {
        surface_from_mask(&mask, &params).expect("mask not empty")
    });
    let out = json!({
        "mask": mask_path.display().to_string(),
        "dims": mask.dims(),
        "voxels": bytes.len(),
        "voxel_sum": sum,
        "threads": threads,
        "iso": iso,
        "repeat": repeat,
        "one_pass_s": {"min": bw_min, "median": bw_med},
        "one_pass_gb_per_s": bytes.len() as f64 / bw_min / 1e9,
        "marching_cubes_s": {"min": mc_min, "median": mc_med},
        "marching_cubes_vertices": s.vertices.len(),
        "marching_cubes_triangles": s.triangles.len(),
        "marching_cubes_over_one_pass": mc_min / bw_min,
        "stage_default_s": {"min": st_min, "median": st_med},
        "stage_default_triangles": report.triangles,
    });
    Ok(serde_json::to_string_pretty(&out).expect("json"))
}
