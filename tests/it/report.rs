//! `coapt report` and the chain CT → report: the document meets its schema,
//! the page opens clean in a browser, measurement failures are findings,
//! bad inputs are refused, the metrics do not depend on the thread count,
//! and a run re-does only what an edit touches.

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::common::*;
use crate::report_html::{browser, check, errors, strings};

/// A run config like pipelines/sample.toml with every input absolute and
/// the closure settings in `dir/close.toml` (a copy), so a test can edit them.
fn sample_config(dir: &Path) -> PathBuf {
    let r = repo();
    std::fs::copy(r.join("pipelines/close.toml"), dir.join("close.toml")).unwrap();
    let cfg = dir.join("run.toml");
    std::fs::write(
        &cfg,
        format!(
            "[run]\ndir = \"run\"\n[inputs]\nct = \"{}\"\nlandmarks = \"{}\"\ntemplate = \"{}\"\nconfig = \"close.toml\"\n",
            s(&r.join("sample_data/ct.nii.gz")),
            s(&r.join("sample_data/landmarks.mrk.json")),
            s(&r.join("pipelines/templates/ozaki_default.toml")),
        ),
    )
    .unwrap();
    cfg
}

/// The report.json numbers that must not depend on anything but the inputs.
fn measured(v: &Value) -> Value {
    serde_json::json!({
        "verdict": v["verdict"], "criteria": v["criteria"], "metrics": v["metrics"],
        "leaflets": v["leaflets"], "conventions": v["conventions"], "findings": v["findings"],
    })
}

#[test]
fn ct_to_report_in_one_command_and_an_edit_reruns_only_what_it_touches() {
    let d = tmpdir("report-chain");
    let cfg = sample_config(&d);
    let run = d.join("run");
    let o = coapt(&["run", &s(&cfg), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let st = stage_statuses(&run);
    let names: Vec<&str> = st.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        ["segment", "surface", "valve", "leaflets", "close", "report"]
    );
    assert!(st.iter().all(|(_, s)| s == "ran"), "{st:?}");

    let rep = json(&run.join("report.json"));
    let errs = errors(&rep);
    assert!(errs.is_empty(), "report.json breaks its schema: {errs:#?}");
    // The sample valve closes with all three leaflets meeting.
    assert_eq!(rep["verdict"]["closed"], true, "{}", rep["verdict"]);
    let m = &rep["metrics"];
    let num = |k: &str| m[k].as_f64().unwrap_or_else(|| panic!("{k}: {}", m[k]));
    for k in [
        "coaptation_height_mm",
        "central_coaptation_height_mm",
        "effective_height_mm",
        "h_cc_mm",
        "h_avr_mm",
        "ncca",
        "regurgitant_orifice_area_mm2",
    ] {
        assert!(num(k).is_finite() && num(k) >= 0.0, "{k} = {}", num(k));
    }
    // Central coaptation lies within the coaptation zone; the effective
    // height is above both the annulus and the lowest coaptation.
    assert!(num("central_coaptation_height_mm") <= num("coaptation_height_mm") + 1e-9);
    assert!(num("effective_height_mm") > m["lowest_coaptation_above_annulus_mm"].as_f64().unwrap());
    assert!(num("ncca") > 0.0 && num("ncca") < 1.0);
    let ids: Vec<&str> = rep["criteria"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["id"].as_str().unwrap())
        .collect();
    assert_eq!(
        ids,
        [
            "central_coaptation",
            "effective_height",
            "coaptation_below_commissures",
            "coaptation_above_vaj",
            "leaflets_below_stj",
            "no_billowing",
            "no_prolapse",
            "no_residual_regurgitation",
            "closed"
        ]
    );
    let crit = |id: &str| {
        rep["criteria"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["id"] == id)
            .unwrap()
            .clone()
    };
    // The anatomical bounds come from valve.json: every commissure lies at
    // h_comm above the annulus in the valve frame (the frame's axis is the
    // commissure cylinder's), and the STJ section's height is measured from
    // the cylinder's centre, on the commissures' plane.
    let valve = json(&run.join("valve.json"));
    let comm = num("lowest_commissure_above_annulus_mm");
    let h_comm = valve["h_comm_mm"].as_f64().unwrap();
    assert!((comm - h_comm).abs() < 1e-9, "{comm} vs {h_comm}");
    let stj = num("stj_above_annulus_mm") - comm;
    let want = valve["sections"]["stj"]["height_mm"].as_f64().unwrap();
    assert!((stj - want).abs() < 1e-9, "{stj} vs {want}");
    // Each new criterion's value is the difference its note describes.
    let meet = num("effective_height_mm").max(num("central_coaptation_top_above_annulus_mm"));
    let below = crit("coaptation_below_commissures")["value"]
        .as_f64()
        .unwrap();
    assert!((below - (comm - meet)).abs() < 1e-9);
    assert_eq!(crit("coaptation_below_commissures")["pass"], below > 0.0);
    let stj_margin = crit("leaflets_below_stj")["value"].as_f64().unwrap();
    assert!(
        (stj_margin - (num("stj_above_annulus_mm") - num("highest_leaflet_above_annulus_mm")))
            .abs()
            < 1e-9
    );
    let orifice = crit("no_residual_regurgitation");
    assert_eq!(orifice["value"], m["regurgitant_orifice_area_mm2"]);
    assert_eq!(
        (orifice["unit"].as_str(), orifice["threshold"].as_f64()),
        (Some("mm2"), Some(1.0))
    );
    assert_eq!(orifice["pass"], num("regurgitant_orifice_area_mm2") <= 1.0);
    let deepest = m["billowing_mm"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b.as_f64().unwrap())
        .fold(f64::NEG_INFINITY, f64::max);
    assert_eq!(crit("no_billowing")["value"].as_f64(), Some(deepest));
    // The verdict: with leaflets crossing each other in closure.json the
    // sample is not assessable, whatever its criteria say (the count is in
    // the reason); without crossings it is its criteria's conjunction.
    let log = json(&run.join("closure.json"));
    let crossing = log["intersecting_triangle_pairs"].as_u64().unwrap();
    let v = &rep["verdict"];
    eprintln!("report chain: sample verdict {v}");
    if crossing > 0 {
        assert_eq!(v["status"], "not_assessable", "{v}");
        assert_eq!(v["meets_all_criteria"], false);
        assert!(
            v["not_assessable_reasons"][0]
                .as_str()
                .unwrap()
                .starts_with(&format!("{crossing} pairs of triangles")),
            "{v}"
        );
    } else {
        let all = rep["criteria"]
            .as_array()
            .unwrap()
            .iter()
            .all(|c| c["pass"] == true);
        assert_eq!(v["meets_all_criteria"], all, "{v}");
    }
    // The default template's free edges (24.3 mm) cannot meet in the
    // sample's root (26.8 mm from commissure to the meeting point and on):
    // the closure meets only on the placement's stretch, so it is not a
    // prediction, and the page says what Ozaki's rule would cut.
    if v["closed"] == true {
        assert_eq!(v["status"], "not_assessable", "{v}");
        let reasons = v["not_assessable_reasons"].to_string();
        assert!(
            reasons.contains("the free edges are too short to meet (leaflet 1: 24.3 mm against 26.8 mm needed (10.2 % short)"),
            "{reasons}"
        );
    }
    let findings = rep["findings"].to_string();
    assert!(
        findings.contains("The free edges are too short to meet"),
        "{findings}"
    );
    assert!(
        findings.contains(
            "Ozaki's rule (the sizer size nearest each intercommissural distance) cuts 23 / 23 / 23"
        ),
        "{findings}"
    );
    for k in ["segment", "surface", "valve", "leaflets", "close", "report"] {
        assert!(
            rep["timing_s"][k].as_f64().is_some(),
            "timing of {k}: {}",
            rep["timing_s"]
        );
    }
    assert_eq!(rep["solver"]["converged"], true);

    let page = run.join("report.html");
    let html = std::fs::read_to_string(&page).unwrap();
    for id in [
        "valve_top",
        "valve_side",
        "coaptation_map",
        "ct_check",
        "convergence",
    ] {
        assert!(
            html.contains(&format!("id=\"fig-{id}\"")),
            "figure {id} missing"
        );
    }
    // The interactive view, with the run's aorta.vtp around the leaflets.
    assert!(html.contains("<figure id=\"view3d\""));
    assert!(html.contains(",\"wall\":{\"vertices\":"));
    assert!(
        rep["inputs"]["surface"]["path"]
            .as_str()
            .is_some_and(|p| p.ends_with("aorta.vtp"))
    );
    if let Some(b) = browser() {
        let (v, code) = check(&b, &page);
        assert!(strings(&v["console_errors"]).is_empty(), "{v}");
        assert!(strings(&v["external_requests"]).is_empty(), "{v}");
        assert_eq!(v["images"]["total"], v["images"]["decoded"], "{v}");
        assert_eq!(v["screenshot"]["blank"], false, "{v}");
        assert_eq!(code, 0, "{v}");
    }

    // Unchanged: everything is skipped.
    let o = coapt(&["run", &s(&cfg), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stage_statuses(&run).iter().all(|(_, s)| s == "skipped"),
        "{:?}",
        stage_statuses(&run)
    );

    // An edit of the closure settings re-runs close and report only.
    let text = std::fs::read_to_string(d.join("close.toml")).unwrap();
    std::fs::write(d.join("close.toml"), text.replace("80 mmHg", "90 mmHg")).unwrap();
    let o = coapt(&["run", &s(&cfg), "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let st = stage_statuses(&run);
    for (stage, status) in &st {
        let want = if stage == "close" || stage == "report" {
            "ran"
        } else {
            "skipped"
        };
        assert_eq!(status, want, "{stage}: {st:?}");
    }
    let again = json(&run.join("report.json"));
    assert_eq!(again["parameters"]["closure"]["pressure_mmhg"], 90.0);

    // `coapt report` by hand on the run's artifacts gives the runner's numbers.
    let by_hand = d.join("by-hand");
    let o = coapt(&[
        "report",
        "--closed",
        &s(&run.join("closed.vtp")),
        "--leaflets",
        &s(&run.join("leaflets.vtp")),
        "--valve",
        &s(&run.join("valve.json")),
        "--log",
        &s(&run.join("closure.json")),
        "--ct",
        &s(&repo().join("sample_data/ct.nii.gz")),
        "--mask",
        &s(&run.join("mask.nii.gz")),
        "--landmarks",
        &s(&repo().join("sample_data/landmarks.mrk.json")),
        "--paths",
        &s(&run.join("paths.vtp")),
        "--out",
        &s(&by_hand),
        "--quiet",
        "--threads",
        "1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        measured(&json(&by_hand.join("report.json"))),
        measured(&again)
    );
}

/// Leaflets pushed apart: nothing touches. The report says so; no crash.
#[test]
fn leaflets_that_do_not_touch_are_a_finding_not_a_crash() {
    use coapt::io::vtp;
    let d = tmpdir("report-apart");
    sample_valve_and_leaflets(
        &d,
        "pipelines/templates/ozaki_default.toml",
        &["--h", "1 mm"],
    );
    let mut m = vtp::read_mesh(&d.join("leaflets.vtp")).unwrap();
    let valve = json(&d.join("valve.json"));
    let f: coapt::geom::ValveFrame = serde_json::from_value(valve["valve_frame"].clone()).unwrap();
    // Each leaflet moves 4 mm away from the axis along its centroid's direction.
    let leaflet = m.cell_data.get("leaflet").unwrap().values.to_f64().unwrap();
    let mut node_leaflet = vec![0usize; m.vertices.len()];
    for (t, tri) in m.triangles.iter().enumerate() {
        for &k in tri {
            node_leaflet[k as usize] = leaflet[t] as usize;
        }
    }
    for l in 1..=3 {
        let pts: Vec<_> = (0..m.vertices.len())
            .filter(|&k| node_leaflet[k] == l)
            .collect();
        let c = pts
            .iter()
            .map(|&k| m.vertices[k].coords)
            .sum::<coapt::geom::Vector3>()
            / pts.len() as f64;
        let r = c - f.origin_mm.coords;
        let dir = (r - f.axis * r.dot(&f.axis)).normalize();
        for k in pts {
            m.vertices[k] += dir * 4.0;
        }
    }
    let apart = d.join("apart.vtp");
    vtp::write(&apart, &m.to_polydata(), &vtp::WriteOptions::default()).unwrap();
    let out = d.join("report");
    let o = coapt(&[
        "report",
        "--closed",
        &s(&apart),
        "--leaflets",
        &s(&d.join("leaflets.vtp")),
        "--valve",
        &s(&d.join("valve.json")),
        "--margin",
        "0.9 mm",
        "--out",
        &s(&out),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rep = json(&out.join("report.json"));
    assert!(errors(&rep).is_empty(), "{:#?}", errors(&rep));
    assert_eq!(rep["verdict"]["closed"], false);
    assert_eq!(rep["metrics"]["coaptation_height_mm"], Value::Null);
    assert_eq!(rep["metrics"]["coaptation_area_mm2"]["max"], 0.0);
    let crit = &rep["criteria"][0];
    assert_eq!(
        (crit["id"].as_str(), &crit["value"], &crit["pass"]),
        (
            Some("central_coaptation"),
            &Value::Null,
            &Value::Bool(false)
        )
    );
    let messages: Vec<String> = rep["findings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["message"].as_str().unwrap().to_string())
        .collect();
    assert!(
        messages.iter().any(|m| m.contains("do not touch")),
        "{messages:?}"
    );
    assert!(
        std::fs::read_to_string(out.join("report.html"))
            .unwrap()
            .contains("do not touch")
    );
}

#[test]
fn report_refuses_bad_inputs_and_writes_nothing() {
    let d = tmpdir("report-bad");
    let surface = sample_valve_and_leaflets(
        &d,
        "pipelines/templates/ozaki_default.toml",
        &["--h", "1 mm"],
    );
    let out = d.join("report");
    let leaflets = d.join("leaflets.vtp");
    let run = |closed: &Path, valve: &Path, extra: &[&str]| {
        let mut a = vec![
            "report".to_string(),
            "--closed".into(),
            s(closed),
            "--leaflets".into(),
            s(&leaflets),
            "--valve".into(),
            s(valve),
            "--out".into(),
            s(&out),
            "--quiet".into(),
        ];
        a.extend(extra.iter().map(|x| x.to_string()));
        coapt(&a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    // The wall is not the closed leaflets: different points and triangles.
    let o = run(&surface, &d.join("valve.json"), &[]);
    assert_bad_input(&o, &leaflets, &["does not match"]);
    // A valve file without a frame.
    let bad_valve = d.join("bad-valve.json");
    std::fs::write(&bad_valve, "{\"frame\": \"LPS\"}").unwrap();
    let o = run(&leaflets, &bad_valve, &[]);
    assert_bad_input(&o, &bad_valve, &["valve_frame"]);
    // Parameters out of range.
    let o = run(&leaflets, &d.join("valve.json"), &["--refine", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = run(&leaflets, &d.join("valve.json"), &["--margin", "-1 mm"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!out.join("report.json").exists() && !out.join("report.html").exists());
}

/// With `effective_height_pressure` the close stage also closes at 3 mmHg;
/// the report reads the effective height there, and its numbers do not
/// depend on the thread count.
#[test]
fn report_numbers_do_not_depend_on_the_thread_count() {
    let d = tmpdir("report-threads");
    sample_valve_and_leaflets(
        &d,
        "pipelines/templates/ozaki_default.toml",
        &["--h", "1 mm"],
    );
    let cfg = d.join("close.toml");
    let text = std::fs::read_to_string(repo().join("pipelines/close.toml")).unwrap();
    let text = if text.contains("effective_height_pressure") {
        text
    } else {
        format!("{text}effective_height_pressure = \"3 mmHg\"\n")
    };
    std::fs::write(&cfg, text).unwrap();
    let o = coapt(&[
        "close",
        "--leaflets",
        &s(&d.join("leaflets.vtp")),
        "--surface",
        &s(&repo().join("sample_data/truth_surface.vtp")),
        "--config",
        &s(&cfg),
        "--valve",
        &s(&d.join("valve.json")),
        "--out",
        &s(&d.join("closed.vtp")),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let log = json(&d.join("closure.json"));
    assert_eq!(
        log["low_pressure"]["converged"], true,
        "{}",
        log["low_pressure"]
    );
    let report = |threads: &str| {
        let out = d.join(format!("report-{threads}"));
        let o = coapt(&[
            "report",
            "--closed",
            &s(&d.join("closed.vtp")),
            "--leaflets",
            &s(&d.join("leaflets.vtp")),
            "--valve",
            &s(&d.join("valve.json")),
            "--surface",
            &s(&repo().join("sample_data/truth_surface.vtp")),
            "--out",
            &s(&out),
            "--threads",
            threads,
            "--quiet",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let page = std::fs::read_to_string(out.join("report.html")).unwrap();
        let at = page.find("<figure id=\"view3d\"").expect("the 3-D view");
        let view = page[at..at + page[at..].find("</figure>").unwrap()].to_string();
        (json(&out.join("report.json")), view)
    };
    let ((a, view_a), (b, view_b)) = (report("1"), report("2"));
    assert_eq!(measured(&a), measured(&b));
    // The view's bytes too (the page as a whole holds timings).
    assert!(
        view_a == view_b,
        "the 3-D view differs with the thread count"
    );
    assert!(view_a.contains(",\"wall\":{\"vertices\":"));
    assert_eq!(a["verdict"]["closed"], true);
    // Both effective heights are reported; the criterion judges the seeds'
    // (3 mmHg), which the unloaded leaflets hold higher than 80 mmHg does.
    let m = &a["metrics"];
    assert_eq!(m["effective_height_pressure_mmhg"], 3.0);
    assert_eq!(m["low_pressure_mmhg"], 3.0);
    assert_eq!(m["closing_pressure_mmhg"], 80.0);
    assert_eq!(
        m["effective_height_mm"],
        m["effective_height_low_pressure_mm"]
    );
    let (low, loaded) = (
        m["effective_height_low_pressure_mm"].as_f64().unwrap(),
        m["effective_height_closing_pressure_mm"].as_f64().unwrap(),
    );
    assert!(
        low > loaded,
        "h_E {low} mm at 3 mmHg, {loaded} mm at 80 mmHg"
    );
    assert_eq!(a["criteria"][1]["value"].as_f64(), Some(low));
    let note = a["criteria"][1]["note"].as_str().unwrap();
    assert!(
        note.contains("at 3 mmHg") && note.contains("(80 mmHg)"),
        "{note}"
    );
}
