//! `cargo bench --bench phantom`: in-process phantom generation per preset.
//! (`coapt bench phantom` measures the same per preset in child processes,
//! with peak memory and file output.)

use std::time::Instant;

use coapt::phantom::{PhantomParams, Preset, generate};

fn main() {
    let presets = std::env::var("COAPT_BENCH_PRESETS").unwrap_or_else(|_| "sample,standard".into());
    println!(
        "{:<9} {:>10} {:>10} {:>9}",
        "preset", "Mvoxels", "seconds", "Mvox/s"
    );
    for name in presets.split(',') {
        let preset: Preset = match name.trim().parse() {
            Ok(p) => p,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(2);
            }
        };
        let params = PhantomParams::new(preset, 1);
        let t0 = Instant::now();
        let ph = generate(&params, &|_| {}).expect("phantom generates");
        let s = t0.elapsed().as_secs_f64();
        let mv = ph.ct.len() as f64 / 1e6;
        println!(
            "{:<9} {:>10.2} {:>10.2} {:>9.1}",
            name.trim(),
            mv,
            s,
            mv / s
        );
    }
}
