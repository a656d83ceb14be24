//! `coapt cohort summary RUN… --out cohort.csv`: one row per run directory
//! of a cohort (a `coapt run` directory or a Snakefile's
//! `{out}/{case}/{variant}`), read from the artifacts the stages wrote:
//! the verdict and key metrics (report.json), the solve (closure.json), the
//! templates (leaflets.json), the root (valve.json) and, when the run was
//! swept, the recommended size (design/design.json; a run with no report of
//! its own is then described by that size's run). A run without a
//! report is a row saying so, not a failed summary: a cohort has cases that
//! stop early, and the table is where they show.

use std::path::{Path, PathBuf};

use serde_json::Value as Json;

use coapt_base::{Error, Result};
use coapt_io::design_json::Design;
use coapt_io::report_json::Report;

/// The columns, in order; units in the names.
pub const COLUMNS: [&str; 20] = [
    "case",
    "status",
    "summary",
    "criteria_met",
    "failed_criteria",
    "closed",
    "central_coaptation_mm",
    "effective_height_mm",
    "effective_height_pressure_mmhg",
    "coaptation_height_mm",
    "coaptation_area_min_mm2",
    "regurgitant_orifice_mm2",
    "billowing_max_mm",
    "solver_converged",
    "crossing_pairs",
    "templates",
    "annulus_diameter_mm",
    "intercommissural_mm",
    "recommended_size",
    "run_dir",
];

/// The table for `runs`, in the order given.
pub fn table(runs: &[PathBuf]) -> Result<String> {
    for r in runs {
        if !r.is_dir() {
            return Err(Error::bad_input(r, "not a run directory"));
        }
    }
    let names = case_names(runs);
    let mut out = COLUMNS.join(",") + "\n";
    for (run, name) in runs.iter().zip(names) {
        let row = row(run, &name)?;
        out += &row.iter().map(|f| field(f)).collect::<Vec<_>>().join(",");
        out.push('\n');
    }
    Ok(out)
}

/// Each run's path below the directories' deepest common ancestor
/// (`p1/default`), or its own name when that leaves nothing.
fn case_names(runs: &[PathBuf]) -> Vec<String> {
    let parts: Vec<Vec<String>> = runs
        .iter()
        .map(|r| {
            std::path::absolute(r)
                .unwrap_or_else(|_| r.clone())
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect()
        })
        .collect();
    let mut common = parts.first().map_or(0, Vec::len);
    for p in &parts {
        common = common.min(p.iter().zip(&parts[0]).take_while(|(a, b)| a == b).count());
    }
    parts
        .iter()
        .map(|p| {
            // One run (or the same run twice) keeps its own name.
            let from = common.min(p.len().saturating_sub(1));
            p[from..].join("/")
        })
        .collect()
}

/// A JSON file of the run, or `None` when absent; a file that is there
/// but unreadable is an error naming it.
fn read(path: &Path) -> Result<Option<Json>> {
    match std::fs::read(path) {
        Ok(b) => serde_json::from_slice(&b)
            .map(Some)
            .map_err(|e| Error::bad_input(path, format!("not valid JSON: {e}"))),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(Error::read(path, e)),
    }
}

fn num(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite())
        .map_or(String::new(), |x| format!("{x:.3}"))
}

fn row(run: &Path, case: &str) -> Result<Vec<String>> {
    let mut r = vec![String::new(); COLUMNS.len()];
    let put = |r: &mut Vec<String>, col: &str, v: String| {
        let k = COLUMNS.iter().position(|c| *c == col).expect("a column");
        r[k] = v;
    };
    put(&mut r, "case", case.to_string());
    put(&mut r, "run_dir", run.display().to_string());
    if let Some(v) = read(&run.join("valve.json"))? {
        put(
            &mut r,
            "annulus_diameter_mm",
            num(v["sections"]["annulus"]["equivalent_diameter_mm"].as_f64()),
        );
        if let Ok(f) = coapt_io::valve_json::read_frame(&run.join("valve.json")) {
            let d = f.intercommissural_mm();
            put(
                &mut r,
                "intercommissural_mm",
                d.iter()
                    .map(|x| format!("{x:.2}"))
                    .collect::<Vec<_>>()
                    .join(";"),
            );
        }
    }
    // A swept run: its design's recommended size stands for the case.
    let mut from = run.to_path_buf();
    let design = run.join("design/design.json");
    if design.is_file() {
        let size = Design::read(&design)?.recommended_size;
        put(
            &mut r,
            "recommended_size",
            size.map_or("none".to_string(), |s| s.to_string()),
        );
        if let Some(size) = size
            && !run.join("report.json").exists()
        {
            from = run
                .join("design")
                .join(coapt_io::design_json::size_dir(size));
        }
    }
    if let Some(l) = read(&from.join("leaflets.json"))? {
        let names: Vec<&str> = l["leaflets"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|x| x["template"].as_str())
            .collect();
        put(&mut r, "templates", names.join(";"));
    }
    let report = from.join("report.json");
    if !report.is_file() {
        let last = read(&run.join("manifest.json"))?
            .and_then(|m| {
                m["stages"]
                    .as_array()
                    .and_then(|s| s.last().and_then(|x| x["stage"].as_str().map(String::from)))
            })
            .map_or(String::new(), |s| format!(" (last stage recorded: {s})"));
        put(&mut r, "status", "no_report".to_string());
        put(&mut r, "summary", format!("no report.json{last}"));
        return Ok(r);
    }
    let rep = Report::read(&report)?;
    let v = &rep.verdict;
    put(
        &mut r,
        "status",
        v.status.map_or(String::new(), |s| s.name().to_string()),
    );
    put(&mut r, "summary", v.summary.clone());
    let met = rep.criteria.iter().filter(|c| c.pass == Some(true)).count();
    put(
        &mut r,
        "criteria_met",
        format!("{met}/{}", rep.criteria.len()),
    );
    put(&mut r, "failed_criteria", v.failed_criteria.join(";"));
    put(
        &mut r,
        "closed",
        v.closed.map_or(String::new(), |b| b.to_string()),
    );
    let m = &rep.metrics;
    for (col, x) in [
        ("central_coaptation_mm", m.central_coaptation_height_mm),
        ("effective_height_mm", m.effective_height_mm),
        (
            "effective_height_pressure_mmhg",
            m.effective_height_pressure_mmhg,
        ),
        ("coaptation_height_mm", m.coaptation_height_mm),
        ("regurgitant_orifice_mm2", m.regurgitant_orifice_area_mm2),
        // Per leaflet; the smallest is the one a surgeon worries about.
        ("coaptation_area_min_mm2", m.coaptation_area_mm2.min),
    ] {
        put(&mut r, col, num(x));
    }
    let billow = m
        .billowing_mm
        .iter()
        .flatten()
        .copied()
        .fold(f64::NAN, f64::max);
    put(&mut r, "billowing_max_mm", num(Some(billow)));
    put(
        &mut r,
        "solver_converged",
        rep.solver
            .converged
            .map_or(String::new(), |b| b.to_string()),
    );
    if let Some(c) = read(&from.join("closure.json"))? {
        put(
            &mut r,
            "crossing_pairs",
            c["intersecting_triangle_pairs"]
                .as_u64()
                .map_or(String::new(), |n| n.to_string()),
        );
    }
    Ok(r)
}

/// RFC 4180: a field with a comma, quote or line break is quoted, quotes
/// doubled.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        let mut q = String::with_capacity(s.len() + 2);
        q.push('"');
        for ch in s.chars() {
            if ch == '"' {
                q.push('"');
            }
            q.push(ch);
        }
        q.push('"');
        q
    } else {
        s.to_string()
    }
}

/// Write the table atomically (no partial file on failure).
pub fn write(runs: &[PathBuf], out: &Path) -> Result<usize> {
    let text = table(runs)?;
    let mut tx = coapt_io::atomic::Transaction::new();
    tx.write_bytes(out, text.as_bytes())?;
    tx.commit()?;
    Ok(runs.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_quoted_as_rfc_4180_asks() {
        assert_eq!(field("plain"), "plain");
        assert_eq!(field("a, b"), "\"a, b\"");
        assert_eq!(field("say \"no\""), "\"say \"\"no\"\"\"");
    }

    #[test]
    fn cases_are_named_below_their_common_folder() {
        let runs = [
            PathBuf::from("/c/out/p1/default"),
            PathBuf::from("/c/out/p2/default"),
            PathBuf::from("/c/out/p2/big"),
        ];
        assert_eq!(case_names(&runs), ["p1/default", "p2/default", "p2/big"]);
        assert_eq!(case_names(&runs[..1]), ["default"]);
    }
}
