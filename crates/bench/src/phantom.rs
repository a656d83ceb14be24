//! `coapt bench phantom`: generation time and peak memory per preset.

use super::{Sample, median, run_child};
use coapt_base::Result;

/// Phantom generation per preset: a text table.
pub fn run(presets: &[String], repeat: u32, threads: usize) -> Result<String> {
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
