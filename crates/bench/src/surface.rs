//! `coapt bench surface`: in-process timings of marching cubes on one volume
//! at one thread and at `--threads`, each against the memory-bandwidth bound
//! of one pass over the same samples in a pool of the same size, and
//! (`--stage`) the whole default stage. Prints JSON (read by
//! `tools/surface_crosscheck.py`).
//!
//! A uint8 file is meshed as a mask; an int16 file (a CT) is meshed as read,
//! classified by integer compares at `--iso` (`--iso 150` on the CT gives the
//! surface of the CT thresholded at 150 HU, interpolated on the HU values).

use super::cpu_time;
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Arg, ArgAction, ArgMatches, Command};
use rayon::prelude::*;
use serde_json::{Value, json};

use super::median;
use coapt_base::{Error, Result};
use coapt_geom::Volume;
use coapt_io::nifti::{self, DataType};
use coapt_surface::marching_cubes::Sample;
use coapt_surface::{SurfaceParams, extract, surface_from_mask};

pub fn command() -> Command {
    Command::new("surface")
        .about("Marching cubes at 1 and --threads threads vs one pass over the volume (in process, JSON)")
        .arg(Arg::new("mask").long("mask").value_name("PATH").required(true).value_parser(clap::value_parser!(PathBuf)).help("uint8 mask, or int16 CT (meshed at --iso HU)"))
        .arg(Arg::new("iso").long("iso").value_name("X").default_value("0.5").value_parser(clap::value_parser!(f64)))
        .arg(
            Arg::new("repeat")
                .long("repeat")
                .value_name("N")
                .default_value("5")
                .value_parser(clap::value_parser!(u32).range(1..=50)),
        )
        .arg(Arg::new("stage").long("stage").action(ArgAction::SetTrue).help("also time the default stage (uint8 masks)"))
}

pub fn dispatch(m: &ArgMatches, threads: usize) -> Result<()> {
    let path = m.get_one::<PathBuf>("mask").expect("required");
    let iso = *m.get_one::<f64>("iso").expect("has default");
    if !iso.is_finite() {
        return Err(Error::usage(format!("--iso {iso}: must be finite")));
    }
    let repeat = *m.get_one::<u32>("repeat").expect("has default");
    println!("{}", run(path, iso, repeat, threads, m.get_flag("stage"))?);
    Ok(())
}

/// Wall and CPU times of `repeat` calls of `f`, and the last result.
struct Timed<T> {
    min: f64,
    median: f64,
    /// Least CPU time of the calling thread over the calls, when known.
    cpu_min: Option<f64>,
    last: T,
}

fn timed<T>(repeat: u32, mut f: impl FnMut() -> T) -> Timed<T> {
    let mut times = Vec::new();
    let mut cpu: Option<f64> = None;
    let mut last = None;
    for _ in 0..repeat {
        let c = cpu_time::thread_cpu_s();
        let t = Instant::now();
        let r = std::hint::black_box(f());
        times.push(t.elapsed().as_secs_f64());
        if let (Some(c0), Some(c1)) = (c, cpu_time::thread_cpu_s()) {
            cpu = Some(cpu.map_or(c1 - c0, |m| m.min(c1 - c0)));
        }
        last = Some(r);
    }
    let min = times.iter().cloned().fold(f64::INFINITY, f64::min);
    Timed {
        min,
        median: median(times),
        cpu_min: cpu,
        last: last.expect("repeat ≥ 1"),
    }
}

/// Samples the bound pass reads: summed as i64 over chunks (so the compiler
/// vectorises the inner sum and no partial sum overflows).
trait Summed: Sample {
    fn chunk_sum(c: &[Self]) -> i64;
    const NAME: &'static str;
}

impl Summed for u8 {
    fn chunk_sum(c: &[u8]) -> i64 {
        // 64 Ki bytes: a u32 sum cannot overflow.
        c.iter().map(|&b| b as u32).sum::<u32>() as i64
    }
    const NAME: &'static str = "uint8";
}

impl Summed for i16 {
    fn chunk_sum(c: &[i16]) -> i64 {
        // 64 Ki samples of |v| ≤ 2¹⁵: an i32 sum cannot overflow.
        c.iter().map(|&v| v as i32).sum::<i32>() as i64
    }
    const NAME: &'static str = "int16";
}

pub fn run(path: &Path, iso: f64, repeat: u32, threads: usize, stage: bool) -> Result<String> {
    let header = nifti::read_header(path)?;
    let mut out = match header.datatype {
        DataType::I16 => measure(&nifti::read_i16(path)?, iso, repeat, threads)?,
        _ => {
            let mask = nifti::read_u8(path)?;
            let mut out = measure(&mask, iso, repeat, threads)?;
            if stage {
                out["stage_default"] = stage_timing(&mask, iso, repeat, threads)?;
            }
            out
        }
    };
    out["file"] = json!(path.display().to_string());
    Ok(serde_json::to_string_pretty(&out).expect("json"))
}

fn pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::failed("bench", format!("thread pool of {threads}: {e}")))
}

fn measure<T: Summed>(vol: &Volume<T>, iso: f64, repeat: u32, threads: usize) -> Result<Value> {
    let data = vol.as_slice();
    let mut counts = vec![1];
    if threads > 1 {
        counts.push(threads);
    }
    let mut rows = Vec::new();
    let mut first: Option<coapt_surface::Isosurface> = None;
    let mut identical = true;
    for &t in &counts {
        let p = pool(t)?;
        let bw = p.install(|| {
            timed(repeat, || {
                data.par_chunks(1 << 16).map(T::chunk_sum).sum::<i64>()
            })
        });
        let mc = p.install(|| timed(repeat, || extract(vol, iso)));
        match &first {
            None => first = Some(mc.last),
            Some(f) => {
                identical &= f.vertices == mc.last.vertices
                    && f.triangles == mc.last.triangles
                    && f.on_border == mc.last.on_border;
            }
        }
        let mut row = json!({
            "threads": t,
            "one_pass_s": {"min": bw.min, "median": bw.median},
            "one_pass_gb_per_s": std::mem::size_of_val(data) as f64 / bw.min / 1e9,
            "sample_sum": bw.last,
            "marching_cubes_s": {"min": mc.min, "median": mc.median},
            "marching_cubes_over_one_pass": mc.min / bw.min,
        });
        if let (1, Some(b), Some(m)) = (t, bw.cpu_min, mc.cpu_min) {
            row["cpu_s"] = json!({"one_pass": b, "marching_cubes": m});
            row["cpu_marching_cubes_over_one_pass"] = json!(m / b);
        }
        rows.push(row);
    }
    let s = first.expect("one thread count at least");
    Ok(json!({
        "dims": vol.dims(),
        "voxels": data.len(),
        "dtype": T::NAME,
        "bytes": std::mem::size_of_val(data),
        "iso": iso,
        "repeat": repeat,
        "one_pass": format!("parallel sum of every {} sample (bytes read once)", T::NAME),
        "marching_cubes_vertices": s.vertices.len(),
        "marching_cubes_triangles": s.triangles.len(),
        "identical_across_thread_counts": identical,
        "per_threads": rows,
        "loadavg": std::fs::read_to_string("/proc/loadavg").ok().map(|l| l.trim().to_string()),
    }))
}

fn stage_timing(mask: &Volume<u8>, iso: f64, repeat: u32, threads: usize) -> Result<Value> {
    let params = SurfaceParams {
        iso,
        ..SurfaceParams::default()
    };
    let p = pool(threads)?;
    let st = p.install(|| timed(repeat.min(3), || surface_from_mask(mask, &params)));
    let (_, report) = st.last?;
    Ok(json!({
        "threads": threads,
        "s": {"min": st.min, "median": st.median},
        "triangles": report.triangles,
    }))
}
