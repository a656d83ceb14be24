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
