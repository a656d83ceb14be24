//! The cohort workflow (`pipelines/Snakefile`): two phantoms through every
//! stage with `snakemake --cores 2`, a third whose landmarks coapt finds in
//! the CT, a fourth whose landmarks file holds only the nadirs, and the
//! same report.json metrics as `coapt run` on the same inputs, with a
//! landmarks file, without one and with part of one. Snakemake comes from PyPI into a venv
//! this test makes (`~/.cache/coapt-snakemake`); without Python or network
//! it says that it skipped, unless `COAPT_REQUIRE_SNAKEMAKE=1`.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

use crate::common::*;

const SNAKEMAKE: &str = "snakemake==9.27.1";

fn skip(why: &str) -> Option<PathBuf> {
    if std::env::var("COAPT_REQUIRE_SNAKEMAKE").is_ok_and(|v| v == "1") {
        panic!("COAPT_REQUIRE_SNAKEMAKE=1 but {why}");
    }
    eprintln!("skipping the Snakemake workflow test: {why}");
    None
}

/// The snakemake executable, installing it into a cached venv if needed.
fn snakemake() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("COAPT_SNAKEMAKE") {
        return Some(p.into());
    }
    let Some(home) = std::env::var_os("HOME") else {
        return skip("HOME is not set");
    };
    let venv = Path::new(&home).join(".cache/coapt-snakemake");
    let exe = venv.join("bin/snakemake");
    if exe.is_file() {
        return Some(exe);
    }
    let ok = |c: &mut Command| c.output().is_ok_and(|o| o.status.success());
    if !ok(Command::new("python3").args(["-m", "venv"]).arg(&venv)) {
        return skip("python3 -m venv failed");
    }
    if !ok(Command::new(venv.join("bin/pip")).args(["install", "-q", SNAKEMAKE])) {
        let _ = std::fs::remove_dir_all(&venv);
        return skip(&format!("pip install {SNAKEMAKE} failed (no network?)"));
    }
    Some(exe)
}

fn metrics(v: &Value) -> Value {
    serde_json::json!({"verdict": v["verdict"], "criteria": v["criteria"], "metrics": v["metrics"], "conventions": v["conventions"]})
}

#[test]
fn cohort_workflow_runs_two_phantoms_and_matches_coapt_run() {
    let Some(smk) = snakemake() else { return };
    let d = tmpdir("snakemake");
    let r = repo();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let template = s(&r.join("pipelines/templates/ozaki_default.toml"));
    let close = s(&r.join("pipelines/close.toml"));
    let sample_ct = s(&r.join("sample_data/ct.nii.gz"));
    let nadirs = d.join("nadirs.mrk.json");
    some_points(
        &r.join("sample_data/landmarks.mrk.json"),
        &nadirs,
        &["N1", "N2", "N3"],
    );
    let nadirs = s(&nadirs);
    std::fs::write(
        d.join("cohort.yaml"),
        format!(
            "coapt: {}\nout: cohort\ncases:\n  p1: {{phantom: {{preset: sample, seed: 1}}}}\n  p2: {{phantom: {{preset: sample, seed: 2}}}}\n  p3: {{phantom: {{preset: sample, seed: 1}}, landmarks: detect}}\n  p4: {{ct: {sample_ct}, landmarks: {nadirs}}}\nvariants:\n  default: {{template: {template}, close: {close}}}\n",
            env!("CARGO_BIN_EXE_coapt")
        ),
    )
    .unwrap();
    let snakemake = |extra: &str| {
        Command::new(&smk)
            .arg("-s")
            .arg(r.join("pipelines/Snakefile"))
            .arg("--configfile")
            .arg(d.join("cohort.yaml"))
            .current_dir(&d)
            .args(["--cores", "2", extra])
            .output()
            .expect("snakemake starts")
    };
    let o = snakemake("--quiet");
    assert!(
        o.status.success(),
        "snakemake failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    for case in ["p1", "p2", "p3", "p4"] {
        let rep = json(&d.join(format!("cohort/{case}/default/report.json")));
        assert_eq!(rep["verdict"]["closed"], true, "{case}: {}", rep["verdict"]);
        assert!(
            d.join(format!("cohort/{case}/default/report.html"))
                .is_file()
        );
    }
    // The cohort's table: a header and a row per case, from its reports.
    let table = std::fs::read_to_string(d.join("cohort/cohort.csv")).unwrap();
    let lines: Vec<&str> = table.lines().collect();
    assert_eq!(lines.len(), 5, "{table}");
    assert_eq!(lines[0], coapt::report::cohort_summary::COLUMNS.join(","));
    assert!(lines[1].starts_with("p1/default,") && lines[2].starts_with("p2/default,"));
    assert!(lines[3].starts_with("p3/default,") && lines[4].starts_with("p4/default,"));
    // p3's points were found by `coapt landmarks`, and the report says so.
    let found = json(&d.join("cohort/p3/landmarks.json"));
    assert!(
        found["points"].is_array() || found["points"].is_object(),
        "{found}"
    );
    // Snakemake's own metadata lives under `out` (its log where it was
    // started), not in the clone.
    assert!(d.join("cohort/.snakemake").is_dir());
    assert!(!r.join(".snakemake").exists());
    // `coapt run` into `d/dir` with the cohort's template and mechanics;
    // `head` goes before [inputs], `inputs` into it.
    let coapt_run = |dir: &str, head: &str, inputs: &str| {
        let cfg = d.join(format!("{dir}.toml"));
        std::fs::write(
            &cfg,
            format!("[run]\ndir = \"{dir}\"\n{head}[inputs]\n{inputs}template = \"{template}\"\nconfig = \"{close}\"\n"),
        )
        .unwrap();
        let o = coapt(&["run", &s(&cfg), "--quiet"]);
        assert!(o.status.success(), "{}", stderr(&o));
    };
    // The same phantom through `coapt run`.
    coapt_run("run", "[phantom]\npreset = \"sample\"\nseed = 2\n", "");
    assert_eq!(
        metrics(&json(&d.join("cohort/p2/default/report.json"))),
        metrics(&json(&d.join("run/report.json")))
    );
    // A CT alone through `coapt run` finds the same landmarks and valve.
    coapt_run("detect", "", "ct = \"cohort/p3/input/ct.nii.gz\"\n");
    assert_eq!(
        std::fs::read(d.join("cohort/p3/landmarks.mrk.json")).unwrap(),
        std::fs::read(d.join("detect/landmarks.mrk.json")).unwrap()
    );
    assert_eq!(
        metrics(&json(&d.join("cohort/p3/default/report.json"))),
        metrics(&json(&d.join("detect/report.json")))
    );
    // A file of nadirs alone: `coapt run` completes it through the
    // landmarks stage, and so does the workflow, to the same points and
    // valve.
    coapt_run(
        "partial",
        "",
        &format!("ct = \"{sample_ct}\"\nlandmarks = \"{nadirs}\"\n"),
    );
    let completed = std::fs::read(d.join("cohort/p4/landmarks.mrk.json")).unwrap();
    assert_eq!(
        completed,
        std::fs::read(d.join("partial/landmarks.mrk.json")).unwrap()
    );
    let given = coapt::io::markups::read(Path::new(&nadirs)).unwrap();
    let completed = coapt::io::markups::read(&d.join("cohort/p4/landmarks.mrk.json")).unwrap();
    for l in ["N1", "N2", "N3"] {
        assert_eq!(completed.get(l), given.get(l), "{l} is the file's");
    }
    assert_eq!(
        metrics(&json(&d.join("cohort/p4/default/report.json"))),
        metrics(&json(&d.join("partial/report.json")))
    );
    // Nothing changed: a dry run has nothing to do.
    let o = snakemake("--dry-run");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && out.contains("Nothing to be done"),
        "{out}"
    );
}
