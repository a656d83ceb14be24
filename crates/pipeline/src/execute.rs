//! Carry out one stage and record it; decide whether an earlier record still holds.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use super::manifest::{FileRecord, StageRecord, Status};
use super::params::Params;
use super::progress::{LogMode, Progress};
use super::provenance;
use super::spec::{StageIo, StageSpec};
use coapt_base::Result;

/// Context shared by every stage execution of one coapt invocation.
#[derive(Debug, Clone, Default)]
pub struct Invocation {
    pub command_line: Vec<String>,
    pub threads: usize,
    pub log: LogMode,
}

/// Hash the stage's inputs.
pub fn hash_inputs(io: &StageIo, run_dir: &Path) -> Result<BTreeMap<String, FileRecord>> {
    io.inputs
        .iter()
        .map(|(name, path)| Ok((name.to_string(), FileRecord::of_input(path, run_dir)?)))
        .collect()
}

/// `None` if `previous` still describes what running the stage now would
/// produce (same inputs, parameters and version; outputs intact), else the
/// reason the stage must run.
pub fn reason_to_run(
    previous: Option<&StageRecord>,
    inputs: &BTreeMap<String, FileRecord>,
    params: &Params,
    io: &StageIo,
) -> Option<String> {
    let Some(prev) = previous else {
        return Some("no earlier run in this directory".into());
    };
    if prev.coapt_version != provenance::version()
        || prev.git_commit.as_deref() != provenance::git_commit()
    {
        return Some(format!(
            "coapt changed ({} {} → {})",
            prev.coapt_version,
            prev.git_commit.as_deref().unwrap_or(""),
            provenance::version_line()
        ));
    }
    let now = params.canonical();
    for (k, v) in &now {
        match prev.params.get(k) {
            Some(old) if old == v => {}
            Some(old) => return Some(format!("parameter {k} changed ({old} → {v})")),
            None => return Some(format!("parameter {k} is new")),
        }
    }
    for (name, rec) in inputs {
        match prev.inputs.get(name) {
            Some(old) if old.blake3 == rec.blake3 => {}
            Some(_) => return Some(format!("input {name} changed ({})", rec.path)),
            None => return Some(format!("input {name} is new")),
        }
    }
    if let Some(gone) = prev.inputs.keys().find(|k| !inputs.contains_key(*k)) {
        return Some(format!("input {gone} is no longer given"));
    }
    for (name, path) in &io.outputs {
        let Some(old) = prev.outputs.get(*name) else {
            return Some(format!("output {name} was not recorded"));
        };
        match provenance::hash_file(path) {
            Ok((h, _)) if h == old.blake3 => {}
            Ok(_) => return Some(format!("output {} was modified", path.display())),
            Err(_) => return Some(format!("output {} is missing", path.display())),
        }
    }
    None
}

/// Run the stage now and return its record.
pub fn execute(
    spec: &StageSpec,
    io: &StageIo,
    params: &Params,
    inputs: BTreeMap<String, FileRecord>,
    run_dir: &Path,
    reason: String,
    inv: &Invocation,
) -> Result<StageRecord> {
    super::no_overwrite::check(spec, io)?;
    for (_, path) in &io.outputs {
        let n = coapt_io::Transaction::remove_stale(path);
        if n > 0 {
            tracing::info!(
                stage = spec.name,
                "{}: removed {n} temporary file(s) a killed run left beside {}",
                spec.name,
                path.display()
            );
        }
    }
    let started = provenance::now_utc();
    tracing::info!(stage = spec.name, event = "start", reason = %reason, "{}: running ({reason})", spec.name);
    let progress = Progress::new(spec.name, inv.log);
    provenance::reset_peak_rss();
    let t0 = Instant::now();
    let result = (spec.run)(io, params, &progress);
    progress.finish();
    let summary = result?;
    let seconds = t0.elapsed().as_secs_f64();
    let outputs = io
        .outputs
        .iter()
        .map(|(name, path)| Ok((name.to_string(), FileRecord::of(path, run_dir)?)))
        .collect::<Result<BTreeMap<_, _>>>()?;
    tracing::info!(
        stage = spec.name,
        event = "ran",
        seconds,
        "{}: done in {seconds:.2} s",
        spec.name
    );
    Ok(StageRecord {
        stage: spec.name.to_string(),
        status: Status::Ran,
        reason,
        inputs,
        outputs,
        params: params.canonical(),
        coapt_version: provenance::version().to_string(),
        git_commit: provenance::git_commit().map(str::to_string),
        command_line: inv.command_line.clone(),
        threads: inv.threads,
        started,
        seconds,
        peak_rss_mb: provenance::peak_rss_mb(),
        checked: None,
        summary,
    })
}
