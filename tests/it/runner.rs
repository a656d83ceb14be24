//! `coapt run`: the manifest, skipping unchanged stages, re-running changed ones.

use std::path::Path;

use coapt::pipeline::manifest::{Manifest, Status};

use crate::common::*;

fn run(cfg: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    let o = coapt(&args);
    assert_eq!(o.status.code(), Some(0), "coapt run failed: {}", stderr(&o));
    o
}

fn phantom_record(out: &Path) -> coapt::pipeline::manifest::StageRecord {
    Manifest::load(out)
        .unwrap()
        .stage("phantom")
        .cloned()
        .expect("phantom recorded")
}

#[test]
fn second_run_skips_and_a_new_seed_reruns() {
    let d = tmpdir("skip");
    let cfg = repo().join("pipelines/phantom.toml");
    let out = d.join("run");

    let first = run(&cfg, &out, &[]);
    let rec = phantom_record(&out);
    assert_eq!(rec.status, Status::Ran, "{}", stderr(&first));
    assert_eq!(rec.outputs.len(), 5);
    assert_eq!(rec.params.get("seed").map(String::as_str), Some("1"));
    assert!(rec.seconds > 0.0 && rec.threads >= 1);
    assert!(rec.command_line.iter().any(|a| a == "run"));
    for f in [
        "report.html",
        "ct.nii.gz",
        "truth_mask.nii.gz",
        "landmarks.mrk.json",
        "truth.json",
        "truth_surface.vtp",
        "manifest.json",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let ct_before = std::fs::read(out.join("ct.nii.gz")).unwrap();
    // The run ends with its answer on stdout: report.json's verdict, each
    // criterion as judged there, and where the report is.
    let report = json(&out.join("report.json"));
    let said = String::from_utf8_lossy(&first.stdout).into_owned();
    let lines: Vec<&str> = said.lines().collect();
    assert_eq!(
        lines[0],
        format!(
            "verdict: {}",
            report["verdict"]["summary"].as_str().unwrap()
        ),
        "{said}"
    );
    for c in report["criteria"].as_array().unwrap() {
        let mark = match c["pass"].as_bool() {
            Some(true) => "pass",
            Some(false) => "FAIL",
            None => "n/a ",
        };
        let name = c["name"].as_str().unwrap();
        assert!(
            lines
                .iter()
                .any(|l| l.starts_with(&format!("  {mark}  {name} "))),
            "{name}: {said}"
        );
    }
    assert_eq!(
        *lines.last().unwrap(),
        format!("report: {}", out.join("report.html").display())
    );

    let second = run(&cfg, &out, &["--log-json"]);
    let rec2 = phantom_record(&out);
    assert_eq!(rec2.status, Status::Skipped);
    assert!(rec2.reason.contains("unchanged"), "{}", rec2.reason);
    let log = stderr(&second);
    let skipped: Vec<serde_json::Value> = log
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|e| e["event"] == "skipped" && e["stage"] == "phantom")
        .collect();
    assert_eq!(skipped.len(), 1, "log: {log}");
    assert_eq!(std::fs::read(out.join("ct.nii.gz")).unwrap(), ct_before);
    // The record of the run that made the outputs is kept.
    assert_eq!(rec2.started, rec.started);

    // A different seed re-runs the stage and says why.
    let cfg2 = d.join("phantom-seed2.toml");
    // The copy lives elsewhere: point its relative input paths back home.
    let template = repo().join("pipelines/templates/ozaki_default.toml");
    let close = repo().join("pipelines/close.toml");
    let text = std::fs::read_to_string(&cfg)
        .unwrap()
        .replace("seed = 1", "seed = 2")
        .replace(
            "\"templates/ozaki_default.toml\"",
            &format!("{:?}", template.to_str().unwrap()),
        )
        .replace("\"close.toml\"", &format!("{:?}", close.to_str().unwrap()));
    assert!(text.contains("seed = 2"));
    std::fs::write(&cfg2, text).unwrap();
    let third = run(&cfg2, &out, &[]);
    let rec3 = phantom_record(&out);
    assert_eq!(rec3.status, Status::Ran);
    assert!(
        rec3.reason.contains("seed changed (1 → 2)"),
        "{}",
        rec3.reason
    );
    assert!(stderr(&third).contains("seed changed"));
    assert_ne!(std::fs::read(out.join("ct.nii.gz")).unwrap(), ct_before);

    // A damaged output re-runs; --force re-runs.
    std::fs::write(out.join("truth.json"), b"{}").unwrap();
    run(&cfg2, &out, &[]);
    assert!(
        phantom_record(&out)
            .reason
            .contains("truth.json was modified")
    );
    run(&cfg2, &out, &["--force"]);
    assert_eq!(phantom_record(&out).reason, "--force");
}

#[test]
fn unknown_stage_and_sections_are_refused() {
    let d = tmpdir("unknown");
    let cfg = d.join("c.toml");
    std::fs::write(&cfg, "[phantom]\npreset = \"sample\"\n[segmnt]\n").unwrap();
    let o = coapt(&[
        "run",
        cfg.to_str().unwrap(),
        "--out",
        d.join("r").to_str().unwrap(),
    ]);
    assert_bad_input(&o, &cfg, &["segmnt", "phantom"]);

    std::fs::write(&cfg, "[phantom]\npreset = \"sample\"\nnoize = \"3 HU\"\n").unwrap();
    let o = coapt(&[
        "run",
        cfg.to_str().unwrap(),
        "--out",
        d.join("r").to_str().unwrap(),
    ]);
    assert_bad_input(&o, &cfg, &["phantom.noize", "noise"]);

    let cfg_ok = repo().join("pipelines/phantom.toml");
    let o = coapt(&[
        "run",
        cfg_ok.to_str().unwrap(),
        "--out",
        d.join("r").to_str().unwrap(),
        "--from",
        "close",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--from close"), "{}", stderr(&o));
}

/// A config that cannot reach the report (no closure settings) runs what it
/// can and says which stage stopped the chain and what it needs; exit 0, no
/// verdict. Without landmarks the chain no longer stops after the surface:
/// the landmarks stage finds them and the valve and leaflets follow.
#[test]
fn a_chain_without_close_settings_says_why_it_stops() {
    let d = tmpdir("no-landmarks");
    let cfg = d.join("ct-only.toml");
    std::fs::write(
        &cfg,
        format!(
            "[inputs]\nct = {:?}\ntemplate = {:?}\n",
            repo().join("sample_data/ct.nii.gz"),
            repo().join("pipelines/templates/ozaki_default.toml")
        ),
    )
    .unwrap();
    let out = d.join("run");
    let o = run(&cfg, &out, &["--quiet"]);
    let err = stderr(&o);
    assert!(
        err.contains("the chain stops after leaflets: stage close needs config (give `config = \"…\"` under [inputs])"),
        "{err}"
    );
    assert!(out.join("landmarks.mrk.json").exists() && out.join("leaflets.vtp").exists());
    assert!(!out.join("closed.vtp").exists());
    assert!(
        o.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
}
