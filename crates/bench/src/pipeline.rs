//! `coapt bench pipeline`: the chain of `pipelines/phantom.toml` (phantom CT
//! and landmarks → report.html, closure settings of `pipelines/close.toml`,
//! both as compiled into this coapt) per phantom preset, with the seconds
//! and peak memory of every stage and where the time goes inside them.
//! With `--ct` (and `--landmarks`) the same chain runs from a given scan
//! instead, as `coapt run` would from its config: the real CT's close,
//! held against the closure-trust issue's 5 s, is measured this way.
//!
//! Each stage runs in its own child `coapt run CONFIG --from S --until S`,
//! so its peak memory and wall time (start-up, input hashing) are its own
//! even where the high-water mark cannot be reset between stages of one
//! process (`provenance::reset_peak_rss`, Linux only). The children share one run directory and its
//! manifest, so the report still sees every stage's timing, as after a plain
//! `coapt run`. The phantom is input generation: timed, not in the total.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use clap::{Arg, ArgAction, ArgMatches, Command as ClapCommand};
use serde_json::{Value as Json, json};

use coapt_base::units::{self, Kind};
use coapt_base::{Error, Result};
use coapt_io::{nifti, volume_file};
use coapt_pipeline::config::RunConfig;
use coapt_pipeline::manifest::{Manifest, StageRecord, Status};
use coapt_pipeline::{StageSpec, runner};
use coapt_stages::registry;

const PHANTOM_TOML: &str = include_str!("../../../pipelines/phantom.toml");
const CLOSE_TOML: &str = include_str!("../../../pipelines/close.toml");
const TEMPLATE_TOML: &str = include_str!("../../../pipelines/templates/ozaki_default.toml");

/// Phases listed under "where time goes" per preset.
const TOP_PHASES: usize = 6;

pub fn command() -> ClapCommand {
    ClapCommand::new("pipeline")
        .about("The chain of pipelines/phantom.toml per preset, CT → report: seconds and peak memory of each stage (own child process), where the time goes")
        .arg(
            Arg::new("preset")
                .long("preset")
                .value_name("NAME")
                .action(ArgAction::Append)
                .value_delimiter(',')
                .value_parser(["sample", "standard", "full"])
                .default_value("sample")
                .help("phantom preset(s); repeat or separate by commas"),
        )
        .arg(
            Arg::new("ct")
                .long("ct")
                .value_name("PATH")
                .value_parser(clap::value_parser!(PathBuf))
                .help("also (or, without --preset, only) run the chain from this CT (a volume file or a DICOM folder) instead of a phantom"),
        )
        .arg(
            Arg::new("landmarks")
                .long("landmarks")
                .value_name("PATH")
                .value_parser(clap::value_parser!(PathBuf))
                .requires("ct")
                .help("the CT's landmarks (C1–C3, N1–N3); without them the chain finds its own"),
        )
        .arg(
            Arg::new("h")
                .long("h")
                .value_name("LENGTH")
                .default_value("0.5 mm")
                .help("leaflet mesh size ([leaflets] h)"),
        )
        .arg(
            Arg::new("work")
                .long("work")
                .value_name("DIR")
                .value_parser(clap::value_parser!(PathBuf))
                .help("keep configs and run directories here (DIR/<preset>/run); an unchanged phantom is then reused (default: a temporary directory, removed)"),
        )
        .arg(
            Arg::new("csv")
                .long("csv")
                .value_name("FILE")
                .value_parser(clap::value_parser!(PathBuf))
                .help("also write the table as CSV"),
        )
        .arg(
            Arg::new("json")
                .long("json")
                .value_name("FILE")
                .value_parser(clap::value_parser!(PathBuf))
                .help("also write every measurement (phases included) as JSON"),
        )
}

pub fn dispatch(m: &ArgMatches, threads: usize) -> Result<()> {
    let ct = m.get_one::<PathBuf>("ct");
    // A CT alone runs alone; the default preset joins it only when asked for.
    let presets: Vec<String> = if ct.is_some()
        && m.value_source("preset") != Some(clap::parser::ValueSource::CommandLine)
    {
        Vec::new()
    } else {
        m.get_many::<String>("preset")
            .expect("has default")
            .cloned()
            .collect()
    };
    let h_text = m.get_one::<String>("h").expect("has default");
    let h_mm = units::parse(Kind::Length, h_text)
        .map_err(|e| Error::usage(format!("--h {h_text}: {e}")))?;
    // units::parse has refused NaN and ±∞ already.
    if h_mm <= 0.0 {
        return Err(Error::usage(format!("--h {h_text}: must be positive")));
    }
    let work = super::work_dir::WorkDir::new(
        m.get_one::<PathBuf>("work").map(PathBuf::as_path),
        "pipeline",
    );
    let mut results = run_all(&presets, h_mm, threads, work.path())?;
    if let Some(ct) = ct {
        let landmarks = m.get_one::<PathBuf>("landmarks").map(PathBuf::as_path);
        results.push(run_ct(
            ct,
            landmarks,
            h_mm,
            threads,
            &work.path().join("ct"),
        )?);
    }
    println!("{}", table(&results));
    if let Some(path) = m.get_one::<PathBuf>("csv") {
        std::fs::write(path, csv(&results)).map_err(|e| Error::write(path, e))?;
    }
    if let Some(path) = m.get_one::<PathBuf>("json") {
        let text = serde_json::to_string_pretty(&to_json(&results)).expect("json") + "\n";
        std::fs::write(path, text).map_err(|e| Error::write(path, e))?;
    }
    Ok(())
}

/// One stage as measured.
#[derive(Debug, Clone, PartialEq)]
pub struct StageRow {
    pub stage: String,
    /// The stage's own seconds (manifest).
    pub seconds: f64,
    /// The child process's wall time: start-up, config, input hashing and
    /// manifest writing included.
    pub wall_s: f64,
    pub peak_rss_mb: Option<f64>,
    /// False when the runner reused an earlier run's outputs (phantom only).
    pub ran: bool,
    pub notes: String,
    /// Internal phases the stage reports (name, seconds).
    pub phases: Vec<(String, f64)>,
}

/// One preset's chain, or a given CT's.
#[derive(Debug, Clone, PartialEq)]
pub struct PresetRun {
    /// The preset, or "ct:" and the CT's file name.
    pub preset: String,
    pub dims: Vec<u64>,
    pub threads: usize,
    pub h_mm: f64,
    /// Load average (1 min) before the chain started: the machine may be shared.
    pub load_before: Option<f64>,
    /// The phantom's generation (none for a given CT).
    pub phantom: Option<StageRow>,
    pub chain: Vec<StageRow>,
}

impl PresetRun {
    /// CT → report: the stages' own seconds.
    pub fn total_s(&self) -> f64 {
        self.chain.iter().map(|r| r.seconds).sum()
    }

    pub fn total_wall_s(&self) -> f64 {
        self.chain.iter().map(|r| r.wall_s).sum()
    }

    /// The largest stage peak: what the chain needs at most.
    pub fn peak_rss_mb(&self) -> Option<f64> {
        self.chain
            .iter()
            .filter_map(|r| r.peak_rss_mb)
            .reduce(f64::max)
    }

    /// The largest phases over the chain, "stage.phase", largest first; a
    /// stage that reports no phases counts as one.
    pub fn where_time_goes(&self) -> Vec<(String, f64)> {
        let mut all: Vec<(String, f64)> = Vec::new();
        for r in &self.chain {
            if r.phases.is_empty() {
                all.push((r.stage.clone(), r.seconds));
                continue;
            }
            let named: f64 = r.phases.iter().map(|p| p.1).sum();
            all.extend(
                r.phases
                    .iter()
                    .map(|(n, s)| (format!("{}.{n}", r.stage), *s)),
            );
            // What the stage spent outside its named phases (reading inputs,
            // writing outputs, set-up).
            if r.seconds - named > 0.0 {
                all.push((format!("{}.(other)", r.stage), r.seconds - named));
            }
        }
        all.sort_by(|a, b| b.1.total_cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        all
    }
}

fn run_all(presets: &[String], h_mm: f64, threads: usize, work: &Path) -> Result<Vec<PresetRun>> {
    presets
        .iter()
        .map(|p| run_preset(p, h_mm, threads, &work.join(p)))
        .collect()
}

/// The run config: pipelines/phantom.toml with the preset and leaflet mesh
/// set, its template and closure settings copied beside it.
pub fn chain_config(preset: &str, h_mm: f64) -> Result<String> {
    let mut doc: toml::Table = PHANTOM_TOML
        .parse()
        .map_err(|e| Error::failed("bench", format!("pipelines/phantom.toml: {e}")))?;
    doc.remove("run");
    let mut inputs = toml::Table::new();
    inputs.insert("template".into(), "template.toml".into());
    inputs.insert("config".into(), "close.toml".into());
    doc.insert("inputs".into(), inputs.into());
    let section = |doc: &mut toml::Table, name: &str| -> Result<toml::Table> {
        match doc.remove(name) {
            None => Ok(toml::Table::new()),
            Some(toml::Value::Table(t)) => Ok(t),
            Some(_) => Err(Error::failed(
                "bench",
                format!("pipelines/phantom.toml: [{name}] is not a table"),
            )),
        }
    };
    let mut phantom = section(&mut doc, "phantom")?;
    phantom.insert("preset".into(), preset.into());
    doc.insert("phantom".into(), phantom.into());
    let mut leaflets = section(&mut doc, "leaflets")?;
    leaflets.insert("h".into(), units::format(Kind::Length, h_mm).into());
    doc.insert("leaflets".into(), leaflets.into());
    Ok(doc.to_string())
}

/// The run config for a given CT: pipelines/phantom.toml's chain without
/// its phantom, reading `ct` (and `landmarks`) instead, as absolute paths.
pub fn ct_chain_config(ct: &Path, landmarks: Option<&Path>, h_mm: f64) -> Result<String> {
    let mut doc: toml::Table = chain_config("sample", h_mm)?
        .parse()
        .map_err(|e| Error::failed("bench", format!("the chain's config: {e}")))?;
    doc.remove("phantom");
    let absolute = |p: &Path| -> Result<String> {
        let a = std::path::absolute(p).map_err(|e| Error::read(p, e))?;
        a.to_str()
            .map(str::to_string)
            .ok_or_else(|| Error::usage(format!("{}: the path is not valid UTF-8", p.display())))
    };
    let Some(toml::Value::Table(inputs)) = doc.get_mut("inputs") else {
        unreachable!("chain_config writes [inputs]");
    };
    inputs.insert("ct".into(), absolute(ct)?.into());
    if let Some(l) = landmarks {
        inputs.insert("landmarks".into(), absolute(l)?.into());
    }
    Ok(doc.to_string())
}

fn run_preset(preset: &str, h_mm: f64, threads: usize, dir: &Path) -> Result<PresetRun> {
    let mut run = run_chain(preset, &chain_config(preset, h_mm)?, h_mm, threads, dir)?;
    if run.phantom.is_none() {
        return Err(Error::failed(
            "bench",
            "pipelines/phantom.toml has no phantom stage",
        ));
    }
    let manifest = Manifest::load(&dir.join("run"))?;
    run.dims = manifest
        .stage("phantom")
        .and_then(|r| r.summary.get("dims")?.as_array().cloned())
        .map(|d| d.iter().filter_map(Json::as_u64).collect())
        .unwrap_or_default();
    Ok(run)
}

fn run_ct(
    ct: &Path,
    landmarks: Option<&Path>,
    h_mm: f64,
    threads: usize,
    dir: &Path,
) -> Result<PresetRun> {
    let header = volume_file::read_header(ct, &nifti::ReadOptions::default())?;
    let name = ct.file_name().map_or_else(
        || ct.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let cfg = ct_chain_config(ct, landmarks, h_mm)?;
    let mut run = run_chain(&format!("ct:{name}"), &cfg, h_mm, threads, dir)?;
    run.dims = header.dims.iter().map(|&d| d as u64).collect();
    Ok(run)
}

/// Write the config with the closure settings and template beside it, then
/// run each stage in its own child: a source stage (the phantom) unforced,
/// so that with --work an unchanged phantom is reused, every other forced.
fn run_chain(
    name: &str,
    cfg_text: &str,
    h_mm: f64,
    threads: usize,
    dir: &Path,
) -> Result<PresetRun> {
    std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
    let cfg = dir.join("chain.toml");
    for (file, text) in [
        ("chain.toml", cfg_text),
        ("close.toml", CLOSE_TOML),
        ("template.toml", TEMPLATE_TOML),
    ] {
        let p = dir.join(file);
        std::fs::write(&p, text).map_err(|e| Error::write(&p, e))?;
    }
    let run_dir = dir.join("run");
    let reg = registry();
    let chain = runner::plan(&RunConfig::load(&cfg, reg)?, reg)?;
    let load_before = load_average();

    let (source, rest): (Vec<&StageSpec>, Vec<&StageSpec>) =
        chain.iter().copied().partition(|s| s.is_source());
    let mut phantom = None;
    for spec in source {
        let wall = child(&cfg, &run_dir, spec.name, false, threads)?;
        phantom = Some(row(spec.name, wall, &run_dir)?);
    }
    let mut rows = Vec::new();
    for spec in rest {
        let wall = child(&cfg, &run_dir, spec.name, true, threads)?;
        rows.push(row(spec.name, wall, &run_dir)?);
    }
    Ok(PresetRun {
        preset: name.to_string(),
        dims: Vec::new(),
        threads,
        h_mm,
        load_before,
        phantom,
        chain: rows,
    })
}

/// `coapt run CONFIG --out RUN --from S --until S` in a child; its wall seconds.
fn child(cfg: &Path, run_dir: &Path, stage: &str, force: bool, threads: usize) -> Result<f64> {
    let exe = std::env::current_exe()
        .map_err(|e| Error::failed("bench", format!("cannot find coapt itself: {e}")))?;
    let mut cmd = Command::new(exe);
    cmd.arg("run")
        .arg(cfg)
        .arg("--out")
        .arg(run_dir)
        .args(["--from", stage, "--until", stage, "--quiet"])
        .args(["--threads", &threads.to_string()]);
    if force {
        cmd.arg("--force");
    }
    let t0 = Instant::now();
    let out = cmd
        .output()
        .map_err(|e| Error::failed("bench", format!("cannot start coapt: {e}")))?;
    let wall = t0.elapsed().as_secs_f64();
    if !out.status.success() {
        return Err(Error::failed(
            "bench",
            format!(
                "coapt run {} --from {stage} --until {stage} failed: {}",
                cfg.display(),
                String::from_utf8_lossy(&out.stderr).trim()
            ),
        ));
    }
    Ok(wall)
}

fn row(stage: &str, wall_s: f64, run_dir: &Path) -> Result<StageRow> {
    let manifest = Manifest::load(run_dir)?;
    let rec = manifest
        .stage(stage)
        .ok_or_else(|| Error::failed("bench", format!("{stage} wrote no manifest record")))?;
    let side = |file: &str| -> Json {
        std::fs::read(run_dir.join(file))
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or(Json::Null)
    };
    let extra = match stage {
        "close" => side("closure.json"),
        "report" => side("report.json"),
        _ => Json::Null,
    };
    Ok(StageRow {
        stage: stage.to_string(),
        seconds: rec.seconds,
        wall_s,
        peak_rss_mb: rec.peak_rss_mb,
        ran: rec.status == Status::Ran,
        notes: notes(rec, &extra),
        phases: phases(stage, &rec.summary, &extra),
    })
}

fn f(v: &Json, k: &str) -> Option<f64> {
    v.get(k)?.as_f64()
}

/// The internal phases a stage's summary (or its side file) reports.
pub fn phases(stage: &str, summary: &Json, extra: &Json) -> Vec<(String, f64)> {
    let mut out: Vec<(String, f64)> = Vec::new();
    let mut put = |name: &str, s: Option<f64>| {
        if let Some(s) = s.filter(|s| s.is_finite()) {
            out.push((name.to_string(), s));
        }
    };
    match stage {
        "phantom" => {
            put("generate", f(summary, "generate_s"));
            put("write", f(summary, "write_s"));
        }
        "segment" => {
            put("read", f(summary, "read_s"));
            for step in summary["timings_s"].as_array().into_iter().flatten() {
                if let (Some(n), Some(s)) = (step[0].as_str(), step[1].as_f64()) {
                    put(n, Some(s));
                }
            }
            put("write", f(summary, "write_s"));
        }
        "surface" => {
            put("read", f(summary, "read_s"));
            for (n, s) in summary["timing_s"].as_object().into_iter().flatten() {
                put(n, s.as_f64());
            }
        }
        "leaflets" => {
            let ms: Option<f64> = summary["mesh_ms"]
                .as_array()
                .map(|v| v.iter().filter_map(Json::as_f64).sum());
            put("mesh", ms.map(|ms| ms / 1000.0));
        }
        "close" => {
            for (n, s) in extra["timing_s"].as_object().into_iter().flatten() {
                put(n, s.as_f64());
            }
        }
        _ => {}
    }
    out
}

/// A few facts that say what the stage worked on.
fn notes(rec: &StageRecord, extra: &Json) -> String {
    let s = &rec.summary;
    let mut v: Vec<String> = Vec::new();
    match rec.stage.as_str() {
        "phantom" => {
            v.push("input generation, not in the total".into());
            if rec.status == Status::Skipped {
                v.push("reused: time of the run that made it".into());
            }
        }
        "segment" => {
            if let Some(ml) = f(s, "mask_ml") {
                v.push(format!("mask {ml:.1} ml"));
            }
        }
        "surface" => {
            if let Some(t) = s["triangles"].as_u64() {
                v.push(format!("{t} triangles"));
            }
        }
        "valve" => {
            if let Some(a) = s["annulus_from"].as_str() {
                v.push(format!("annulus from {a}"));
            }
        }
        "leaflets" => {
            if let Some(t) = s["triangles"].as_u64() {
                v.push(format!("{t} triangles"));
            }
            if let Some(h) = rec.params.get("h") {
                v.push(format!("h {h}"));
            }
        }
        "close" => {
            if let Some(n) = extra["nodes"].as_u64() {
                v.push(format!("{n} nodes"));
            }
            if let Some(it) = s["iterations"].as_u64() {
                // Continuation steps vs Newton steps: many continuation
                // steps mean the start was far from equilibrium.
                let mut by_phase: Vec<(String, usize)> = Vec::new();
                for step in extra["solver"]["history"].as_array().into_iter().flatten() {
                    let p = step["phase"].as_str().unwrap_or("?");
                    match by_phase.iter_mut().find(|(n, _)| n == p) {
                        Some((_, c)) => *c += 1,
                        None => by_phase.push((p.to_string(), 1)),
                    }
                }
                let split: Vec<String> = by_phase.iter().map(|(n, c)| format!("{c} {n}")).collect();
                if split.is_empty() {
                    v.push(format!("{it} iterations"));
                } else {
                    v.push(format!("{it} iterations ({})", split.join(" + ")));
                }
            }
            match s["converged"].as_bool() {
                Some(true) => v.push("converged".into()),
                Some(false) => v.push("NOT converged".into()),
                None => {}
            }
        }
        "report" => {
            if let Some(c) = extra["verdict"]["closed"].as_bool() {
                v.push(if c { "closed" } else { "NOT closed" }.into());
            }
            if let Some(h) = f(&extra["metrics"], "coaptation_height_mm") {
                v.push(format!("coaptation height {h:.2} mm"));
            }
        }
        _ => {}
    }
    v.join(", ")
}

fn load_average() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/loadavg").ok()?;
    text.split_whitespace().next()?.parse().ok()
}

fn mb(x: Option<f64>) -> String {
    x.map(|x| format!("{x:.0}")).unwrap_or_else(|| "n/a".into())
}

fn dims_text(d: &[u64]) -> String {
    d.iter().map(u64::to_string).collect::<Vec<_>>().join("×")
}

/// The table: one block per preset, one line per stage, the total, and the
/// largest phases.
pub fn table(runs: &[PresetRun]) -> String {
    let mut out = Vec::new();
    for r in runs {
        out.push(format!(
            "{} ({}), {} thread{}, leaflets h {}{}",
            r.preset,
            dims_text(&r.dims),
            r.threads,
            if r.threads == 1 { "" } else { "s" },
            units::format(Kind::Length, r.h_mm),
            r.load_before
                .map(|l| format!(", load average {l:.1} before"))
                .unwrap_or_default()
        ));
        out.push(format!(
            "  {:<12} {:>9} {:>8} {:>8}  notes",
            "stage", "stage s", "wall s", "peak MB"
        ));
        for s in r.phantom.iter().chain(&r.chain) {
            out.push(format!(
                "  {:<12} {:>9.2} {:>8.2} {:>8}  {}",
                s.stage,
                s.seconds,
                s.wall_s,
                mb(s.peak_rss_mb),
                s.notes
            ));
        }
        out.push(format!(
            "  {:<12} {:>9.2} {:>8.2} {:>8}  stages after any phantom; peak = largest stage",
            "CT → report",
            r.total_s(),
            r.total_wall_s(),
            mb(r.peak_rss_mb())
        ));
        let total = r.total_s();
        let top: Vec<String> = r
            .where_time_goes()
            .into_iter()
            .take(TOP_PHASES)
            .map(|(n, s)| format!("{n} {s:.2} s ({:.0} %)", 100.0 * s / total))
            .collect();
        out.push(format!("  where time goes: {}", top.join(", ")));
    }
    out.push(
        "(stage s: the stage's own seconds from manifest.json; wall s: its child `coapt run --from S --until S`, \
         start-up and input hashing included; use a release build)"
            .into(),
    );
    out.join("\n")
}

/// A CSV field, quoted when it holds a comma, quote or newline.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

pub const CSV_HEADER: &str = "preset,threads,h_mm,stage,seconds,wall_s,peak_rss_mb,notes";

pub fn csv(runs: &[PresetRun]) -> String {
    let mut out = String::from(CSV_HEADER) + "\n";
    for r in runs {
        let line = |stage: &str, s: f64, w: f64, peak: Option<f64>, notes: &str| {
            format!(
                "{},{},{},{},{s},{w},{},{}\n",
                field(&r.preset),
                r.threads,
                r.h_mm,
                field(stage),
                peak.map(|p| p.to_string()).unwrap_or_default(),
                field(notes)
            )
        };
        for s in r.phantom.iter().chain(&r.chain) {
            out += &line(&s.stage, s.seconds, s.wall_s, s.peak_rss_mb, &s.notes);
        }
        out += &line(
            "total",
            r.total_s(),
            r.total_wall_s(),
            r.peak_rss_mb(),
            "CT → report: stages after any phantom",
        );
    }
    out
}

pub fn to_json(runs: &[PresetRun]) -> Json {
    let stage = |s: &StageRow| {
        json!({
            "stage": s.stage, "seconds": s.seconds, "wall_s": s.wall_s,
            "peak_rss_mb": s.peak_rss_mb, "ran": s.ran, "notes": s.notes,
            "phases_s": s.phases.iter().map(|(n, t)| json!([n, t])).collect::<Vec<_>>(),
        })
    };
    Json::Array(
        runs.iter()
            .map(|r| {
                json!({
                    "preset": r.preset, "dims": r.dims, "threads": r.threads, "h_mm": r.h_mm,
                    "load_average_before": r.load_before,
                    "phantom": r.phantom.as_ref().map(stage),
                    "stages": r.chain.iter().map(stage).collect::<Vec<_>>(),
                    "total_s": r.total_s(), "total_wall_s": r.total_wall_s(),
                    "peak_rss_mb": r.peak_rss_mb(),
                    "where_time_goes_s": r.where_time_goes().iter().map(|(n, t)| json!([n, t])).collect::<Vec<_>>(),
                })
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(stage: &str, seconds: f64, peak: f64, phases: &[(&str, f64)]) -> StageRow {
        StageRow {
            stage: stage.into(),
            seconds,
            wall_s: seconds + 0.05,
            peak_rss_mb: Some(peak),
            ran: true,
            notes: String::new(),
            phases: phases.iter().map(|(n, s)| (n.to_string(), *s)).collect(),
        }
    }

    fn run() -> PresetRun {
        PresetRun {
            preset: "sample".into(),
            dims: vec![112, 112, 112],
            threads: 2,
            h_mm: 0.5,
            load_before: None,
            phantom: Some(row("phantom", 9.0, 500.0, &[])),
            chain: vec![
                row("segment", 1.0, 40.0, &[("read", 0.125), ("edt", 0.5)]),
                row("valve", 0.3, 35.0, &[]),
                row("close", 3.0, 170.0, &[("solve", 2.75)]),
            ],
        }
    }

    #[test]
    fn totals_leave_the_phantom_out() {
        let r = run();
        assert_eq!(r.total_s(), 4.3);
        assert_eq!(r.peak_rss_mb(), Some(170.0));
    }

    #[test]
    fn time_goes_to_named_phases_and_the_rest_of_each_stage() {
        let w = run().where_time_goes();
        let names: Vec<&str> = w.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "close.solve",
                "segment.edt",
                "segment.(other)",
                "valve",
                "close.(other)",
                "segment.read"
            ]
        );
        let sum: f64 = w.iter().map(|p| p.1).sum();
        assert!((sum - run().total_s()).abs() < 1e-12);
    }

    #[test]
    fn csv_has_one_line_per_stage_and_a_total() {
        let mut r = run();
        r.chain[1].notes = "annulus from nadirs, \"quoted\"".into();
        let text = csv(&[r]);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], CSV_HEADER);
        assert_eq!(lines.len(), 1 + 1 + 3 + 1);
        assert!(
            lines[1].starts_with("sample,2,0.5,phantom,9,"),
            "{}",
            lines[1]
        );
        assert!(
            lines[3].ends_with(",\"annulus from nadirs, \"\"quoted\"\"\""),
            "{}",
            lines[3]
        );
        assert!(
            lines[5].starts_with("sample,2,0.5,total,4.3,"),
            "{}",
            lines[5]
        );
    }

    #[test]
    fn phases_are_read_from_each_stage_summary() {
        let seg = json!({"read_s": 0.1, "write_s": 0.2, "segment_s": 9.0,
                         "timings_s": [["hough_track", 0.3], ["edt", 0.4]]});
        assert_eq!(
            phases("segment", &seg, &Json::Null),
            [
                ("read".to_string(), 0.1),
                ("hough_track".into(), 0.3),
                ("edt".into(), 0.4),
                ("write".into(), 0.2)
            ]
        );
        let leaf = json!({"mesh_ms": [100.0, 200.0, 300.0]});
        assert_eq!(
            phases("leaflets", &leaf, &Json::Null),
            [("mesh".into(), 0.6)]
        );
        let closure = json!({"timing_s": {"setup": 0.5, "solve": 2.0, "low_pressure_solve": null}});
        assert_eq!(
            phases("close", &json!({}), &closure),
            [("setup".into(), 0.5), ("solve".into(), 2.0)]
        );
        assert!(phases("report", &json!({"x": 1.0}), &Json::Null).is_empty());
    }

    #[test]
    fn close_notes_split_the_iterations_by_solver_phase() {
        let rec: StageRecord = serde_json::from_value(json!({
            "stage": "close", "status": "ran", "reason": "", "inputs": {}, "outputs": {},
            "params": {}, "coapt_version": "0", "git_commit": null, "command_line": [],
            "threads": 2, "started": "", "seconds": 1.0, "peak_rss_mb": 1.0,
            "summary": {"iterations": 3, "converged": false},
        }))
        .unwrap();
        let log = json!({"nodes": 10, "solver": {"history": [
            {"phase": "continuation"}, {"phase": "continuation"}, {"phase": "newton"}]}});
        assert_eq!(
            notes(&rec, &log),
            "10 nodes, 3 iterations (2 continuation + 1 newton), NOT converged"
        );
        assert_eq!(notes(&rec, &Json::Null), "3 iterations, NOT converged");
    }

    /// The stages a run config plans, in chain order.
    fn planned(cfg: &RunConfig) -> Vec<&'static str> {
        runner::plan(cfg, registry())
            .unwrap()
            .iter()
            .map(|s| s.name)
            .collect()
    }

    #[test]
    fn a_ct_runs_the_chain_without_the_phantom_from_absolute_inputs() {
        let text = ct_chain_config(
            Path::new("scans/ct.nii.gz"),
            Some(Path::new("scans/lm.mrk.json")),
            0.5,
        )
        .unwrap();
        let cfg = RunConfig::parse(Path::new("/x/chain.toml"), &text, registry()).unwrap();
        assert!(!cfg.sections.contains_key("phantom"));
        let here = std::env::current_dir().unwrap();
        assert_eq!(cfg.inputs["ct"], here.join("scans/ct.nii.gz"));
        assert_eq!(cfg.inputs["landmarks"], here.join("scans/lm.mrk.json"));
        assert_eq!(cfg.inputs["config"], Path::new("/x/close.toml"));
        let names = planned(&cfg);
        assert_eq!(
            names,
            ["segment", "surface", "valve", "leaflets", "close", "report"]
        );
        // Without landmarks the chain finds its own.
        let text = ct_chain_config(Path::new("/scans/ct.nii.gz"), None, 0.5).unwrap();
        let cfg = RunConfig::parse(Path::new("/x/chain.toml"), &text, registry()).unwrap();
        assert!(!cfg.inputs.contains_key("landmarks"));
        assert!(planned(&cfg).contains(&"landmarks"));
    }

    #[test]
    fn the_config_is_phantom_toml_with_preset_and_mesh_set() {
        let text = chain_config("full", 0.7).unwrap();
        let cfg = RunConfig::parse(Path::new("/x/chain.toml"), &text, registry()).unwrap();
        assert!(cfg.run_dir.is_none());
        assert_eq!(
            cfg.sections["phantom"]["preset"],
            coapt_pipeline::Value::Choice("full".into())
        );
        assert_eq!(
            cfg.sections["leaflets"]["h"].canonical(),
            units::format(Kind::Length, 0.7)
        );
        assert_eq!(cfg.inputs["config"], Path::new("/x/close.toml"));
        let names = planned(&cfg);
        assert_eq!(
            names,
            [
                "phantom", "segment", "surface", "valve", "leaflets", "close", "report"
            ]
        );
    }
}
