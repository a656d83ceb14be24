//! `coapt bench …`: time and peak memory of whole stages, each measured in a
//! child `coapt` process so that peak memory belongs to one run alone.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use crate::pipeline::manifest::Manifest;
use crate::{Error, Result};

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
fn run_child(stage: &str, args: &[String], threads: usize) -> Result<Sample> {
    let exe = std::env::current_exe()
        .map_err(|e| Error::failed("bench", format!("cannot find coapt itself: {e}")))?;
    let dir = std::env::temp_dir().join(format!("coapt-bench-{}-{}", stage, std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
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
        let _ = std::fs::remove_dir_all(&dir);
        return Err(Error::failed(
            "bench",
            format!(
                "coapt {stage} {} failed: {}",
                args.join(" "),
                String::from_utf8_lossy(&out.stderr).trim()
            ),
        ));
    }
    let manifest = Manifest::load(&dir)?;
    let rec = manifest
        .stage(stage)
        .ok_or_else(|| Error::failed("bench", format!("{stage} wrote no manifest record")))?;
    let sample = Sample {
        wall_s,
        stage_s: rec.seconds,
        summary: rec.summary.clone(),
        peak_rss_mb: rec.peak_rss_mb,
        output_bytes: dir_bytes(&dir),
    };
    let _ = std::fs::remove_dir_all(&dir);
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

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Phantom generation per preset: a text table.
pub fn phantom(presets: &[String], repeat: u32, threads: usize) -> Result<String> {
    let mut rows = vec![format!(
        "{:<9} {:>13} {:>8} {:>10} {:>8} {:>8} {:>9} {:>9} {:>9}",
        "preset",
        "dims",
        "Mvoxels",
        "generate s",
        "write s",
        "stage s",
        "Mvox/s",
        "peak MB",
        "out MB"
    )];
    for preset in presets {
        let args = vec!["--preset".to_string(), preset.clone()];
        let samples: Vec<Sample> = (0..repeat)
            .map(|_| run_child("phantom", &args, threads))
            .collect::<Result<_>>()?;
        let s0 = &samples[0];
        let get = |s: &Sample, k: &str| {
            s.summary
                .get(k)
                .and_then(|v| v.as_f64())
                .unwrap_or(f64::NAN)
        };
        let gen_s = median(samples.iter().map(|s| get(s, "generate_s")).collect());
        let write_s = median(samples.iter().map(|s| get(s, "write_s")).collect());
        let stage_s = median(samples.iter().map(|s| s.stage_s).collect());
        let voxels = get(s0, "voxels");
        let dims = s0
            .summary
            .get("dims")
            .and_then(|d| d.as_array())
            .map(|d| {
                d.iter()
                    .map(|x| x.to_string())
                    .collect::<Vec<_>>()
                    .join("×")
            })
            .unwrap_or_default();
        rows.push(format!(
            "{:<9} {:>13} {:>8.2} {:>10.2} {:>8.2} {:>8.2} {:>9.1} {:>9.0} {:>9.2}",
            preset,
            dims,
            voxels / 1e6,
            gen_s,
            write_s,
            stage_s,
            voxels / 1e6 / gen_s,
            s0.peak_rss_mb.unwrap_or(f64::NAN),
            s0.output_bytes as f64 / 1e6
        ));
    }
    rows.push(format!(
        "({threads} thread{}, median of {repeat} run{}; use a release build)",
        if threads == 1 { "" } else { "s" },
        if repeat == 1 { "" } else { "s" }
    ));
    Ok(rows.join("\n"))
}
