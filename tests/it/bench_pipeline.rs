//! `coapt bench pipeline`: one measured row per stage of the chain, each
//! from its own child process; no timing is judged here (benchmarks hold
//! the targets), only that every number is a measurement.

use serde_json::Value;

use crate::common::*;

/// A run's stage rows, checked to be the chain after any phantom, in order.
fn chain_stages(r: &Value) -> &Vec<Value> {
    let stages = r["stages"].as_array().unwrap();
    let names: Vec<&str> = stages
        .iter()
        .map(|s| s["stage"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        ["segment", "surface", "valve", "leaflets", "close", "report"]
    );
    stages
}

#[test]
fn sample_chain_gives_one_measured_row_per_stage() {
    let d = tmpdir("bench-pipeline");
    let (j, c) = (d.join("b.json"), d.join("b.csv"));
    let o = coapt(&[
        "bench",
        "pipeline",
        "--preset",
        "sample",
        "--work",
        d.join("work").to_str().unwrap(),
        "--json",
        j.to_str().unwrap(),
        "--csv",
        c.to_str().unwrap(),
        "--threads",
        "2",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let table = String::from_utf8_lossy(&o.stdout);
    // The closure (its suturing pre-stage or its solve) leads.
    assert!(
        table.contains("where time goes: close.suture")
            || table.contains("where time goes: close.solve"),
        "{table}"
    );

    let v: Value = serde_json::from_slice(&std::fs::read(&j).unwrap()).unwrap();
    let runs = v.as_array().unwrap();
    assert_eq!(runs.len(), 1);
    let r = &runs[0];
    assert_eq!(r["dims"], serde_json::json!([112, 112, 112]));
    assert_eq!(r["threads"], 2);
    let stages = chain_stages(r);
    let pos = |x: &Value| x.as_f64().is_some_and(|x| x.is_finite() && x > 0.0);
    for s in stages.iter().chain([&r["phantom"]]) {
        assert!(pos(&s["seconds"]) && pos(&s["wall_s"]), "{s}");
        assert!(pos(&s["peak_rss_mb"]), "{s}");
        assert_eq!(s["ran"], true, "{s}");
    }
    // Every stage had its own process: the peaks differ (in one `coapt run`
    // every stage after close would repeat close's).
    let peak = |n: usize| stages[n]["peak_rss_mb"].as_f64().unwrap();
    assert!(
        peak(5) < peak(4),
        "report {} MB vs close {} MB",
        peak(5),
        peak(4)
    );
    let total: f64 = stages.iter().map(|s| s["seconds"].as_f64().unwrap()).sum();
    assert_eq!(r["total_s"].as_f64().unwrap(), total);
    assert!(
        stages[5]["notes"].as_str().unwrap().starts_with("closed"),
        "{}",
        stages[5]
    );

    let csv = std::fs::read_to_string(&c).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 1 + 1 + 6 + 1, "{csv}");
    assert!(rows[8].starts_with("sample,2,0.5,total,"), "{csv}");
    // The run directory is kept under --work: the chain's report is there.
    assert!(d.join("work/sample/run/report.html").is_file());
}

#[test]
fn a_bare_mesh_size_is_refused() {
    let o = coapt(&["bench", "pipeline", "--h", "0.5"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("no unit"), "{}", stderr(&o));
}

/// `--ct` (and `--landmarks`) run the chain from a given scan, as `coapt
/// run` would: no phantom row, the CT's own dimensions, one measured row
/// per stage (here the committed sample's CT; the real CT's close is
/// measured this way for the 5 s target).
#[test]
fn a_given_ct_is_benchmarked_without_a_phantom() {
    let d = tmpdir("bench-pipeline-ct");
    let j = d.join("b.json");
    let data = repo().join("sample_data");
    let o = coapt(&[
        "bench",
        "pipeline",
        "--ct",
        data.join("ct.nii.gz").to_str().unwrap(),
        "--landmarks",
        data.join("landmarks.mrk.json").to_str().unwrap(),
        "--work",
        d.join("work").to_str().unwrap(),
        "--json",
        j.to_str().unwrap(),
        "--threads",
        "2",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&std::fs::read(&j).unwrap()).unwrap();
    let runs = v.as_array().unwrap();
    assert_eq!(runs.len(), 1, "only the CT, no default preset: {v}");
    let r = &runs[0];
    assert_eq!(r["preset"], "ct:ct.nii.gz");
    assert_eq!(r["dims"], serde_json::json!([112, 112, 112]));
    assert!(r["phantom"].is_null(), "{}", r["phantom"]);
    let stages = chain_stages(r);
    for s in stages {
        let pos = |x: &Value| x.as_f64().is_some_and(|x| x.is_finite() && x > 0.0);
        assert!(pos(&s["seconds"]) && pos(&s["wall_s"]), "{s}");
        assert_eq!(s["ran"], true, "{s}");
    }
    assert!(d.join("work/ct/run/report.html").is_file());
    // Landmarks without a CT are refused by the command line.
    let o = coapt(&["bench", "pipeline", "--landmarks", "x.mrk.json"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
