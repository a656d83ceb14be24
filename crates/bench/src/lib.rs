//! `coapt bench …`: time and peak memory of whole stages, each measured in a
//! child `coapt` process so that peak memory belongs to one run alone. One
//! file per benchmark.

pub mod bounded;
pub mod close;
pub mod close_grid;
pub mod close_grid_plot;
pub mod cpu_time;
pub mod displacement_error;
pub mod limit_load;
pub mod marom;
pub mod marom_geometry;
pub mod phantom;
pub mod pipeline;
pub mod seed001;
pub mod segment;
pub mod stress_close;
pub mod surface;
pub mod work_dir;

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use coapt_base::{Error, Result};
use coapt_pipeline::manifest::Manifest;

/// One measured run of a stage.
#[derive(Debug, Clone)]
pub struct Sample {
    pub wall_s: f64,
    pub stage_s: f64,
    pub summary: serde_json::Value,
    pub peak_rss_mb: Option<f64>,
    pub output_bytes: u64,
}

/// Run `coapt <args> --out DIR` in a child process and read its manifest.
pub fn run_child(stage: &str, args: &[String], threads: usize) -> Result<Sample> {
    let exe = std::env::current_exe()
        .map_err(|e| Error::failed("bench", format!("cannot find coapt itself: {e}")))?;
    let work = work_dir::WorkDir::new(None, stage);
    let dir = work.path();
    let t0 = Instant::now();
    let out = Command::new(exe)
        .arg(stage)
        .args(args)
        .arg("--out")
        .arg(&dir)
        .args(["--quiet", "--threads", &threads.to_string()])
        .output()
        .map_err(|e| Error::failed("bench", format!("cannot start coapt: {e}")))?;
    let wall_s = t0.elapsed().as_secs_f64();
    if !out.status.success() {
        return Err(Error::failed(
            "bench",
            format!(
                "coapt {stage} {} failed: {}",
                args.join(" "),
                String::from_utf8_lossy(&out.stderr).trim()
            ),
        ));
    }
    let manifest = Manifest::load(dir)?;
    let rec = manifest
        .stage(stage)
        .ok_or_else(|| Error::failed("bench", format!("{stage} wrote no manifest record")))?;
    let sample = Sample {
        wall_s,
        stage_s: rec.seconds,
        summary: rec.summary.clone(),
        peak_rss_mb: rec.peak_rss_mb,
        output_bytes: dir_bytes(dir),
    };
    Ok(sample)
}

fn dir_bytes(dir: &Path) -> u64 {
    std::fs::read_dir(dir)
        .map(|it| {
            it.filter_map(|e| e.ok()?.metadata().ok())
                .map(|m| m.len())
                .sum()
        })
        .unwrap_or(0)
}

pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
