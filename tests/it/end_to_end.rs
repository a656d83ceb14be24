//! The whole chain from the `sample` phantom to the report, judged against
//! the phantom's truth: segmentation Dice, suture paths on the true wall
//! through the true commissures and nadirs, a closed valve with finite
//! metrics, and those metrics converged between two leaflet meshes.

use std::path::{Path, PathBuf};
use std::time::Instant;

use coapt::geom::Point3;
use coapt::geom::wall::Wall;
use coapt::io::{nifti, vtp};
use serde_json::Value;

use crate::common::*;

/// Segmentation: the design target on 25–40 HU phantoms.
const MIN_DICE: f64 = 0.97;
/// The paths are built on the segmented surface, which stands off the true
/// wall by a fraction of a voxel (0.9 × 0.9 × 1 mm): a path end or nadir
/// more than half a voxel from the true landmark, or a path point more than
/// that from the true wall, means the chain lost the valve's geometry.
const LANDMARK_TOL_MM: f64 = 0.5;
const WALL_TOL_MM: f64 = 0.5;
/// Mesh convergence between h = 0.7 and 0.5 mm. The design asks 0.1 mm
/// between h and h/2; h/√2 apart, 0.15 mm leaves room for the report's
/// column discretisation (0.5 mm columns) without hiding a real drift.
const HEIGHT_TOL_MM: f64 = 0.15;
const AREA_TOL: f64 = 0.03;

fn p3(v: &Value) -> Point3 {
    Point3::new(
        v[0].as_f64().unwrap(),
        v[1].as_f64().unwrap(),
        v[2].as_f64().unwrap(),
    )
}

/// pipelines/phantom.toml with its inputs made absolute and [leaflets] h set.
fn write_config(dir: &Path, h: &str) -> PathBuf {
    let r = repo();
    let text = std::fs::read_to_string(r.join("pipelines/phantom.toml"))
        .unwrap()
        .replace("../runs/phantom", "run")
        .replace(
            "\"templates/ozaki_default.toml\"",
            &format!("{:?}", s(&r.join("pipelines/templates/ozaki_default.toml"))),
        )
        .replace(
            "\"close.toml\"",
            &format!("{:?}", s(&r.join("pipelines/close.toml"))),
        );
    assert!(text.contains("preset = \"sample\"") && text.contains("dir = \"run\""));
    let cfg = dir.join("phantom.toml");
    std::fs::write(&cfg, format!("{text}\n[leaflets]\nh = \"{h}\"\n")).unwrap();
    cfg
}

fn run_chain(cfg: &Path) {
    let o = coapt(&["run", &s(cfg), "--quiet"]);
    assert_eq!(o.status.code(), Some(0), "coapt run: {}", stderr(&o));
}

/// Every leaf of the metrics block: a null is a metric the report could not
/// give (serde_json also writes NaN and ±∞ as null).
fn leaves<'a>(path: String, v: &'a Value, out: &mut Vec<(String, &'a Value)>) {
    match v {
        Value::Object(m) => m
            .iter()
            .for_each(|(k, x)| leaves(format!("{path}.{k}"), x, out)),
        Value::Array(a) => a
            .iter()
            .enumerate()
            .for_each(|(i, x)| leaves(format!("{path}[{i}]"), x, out)),
        _ => out.push((path, v)),
    }
}

/// Distance from `q` to the polyline.
fn to_line(q: &Point3, line: &[Point3]) -> f64 {
    line.windows(2)
        .map(|w| {
            let ab = w[1] - w[0];
            let t = ((q - w[0]).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
            (q - (w[0] + ab * t)).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

fn check_segmentation(run: &Path) {
    let mask = nifti::read_u8(&run.join("mask.nii.gz")).unwrap();
    let truth = nifti::read_u8(&run.join("truth_mask.nii.gz")).unwrap();
    let dc = dice(&mask, &truth);
    eprintln!("end_to_end: Dice {dc:.4}");
    assert!(dc >= MIN_DICE, "Dice {dc:.4} < {MIN_DICE}");
}

fn check_paths(run: &Path) {
    let truth = json(&run.join("truth.json"));
    let wall = Wall::new(&vtp::read_mesh(&run.join("truth_surface.vtp")).unwrap()).unwrap();
    let pd = vtp::read(&run.join("paths.vtp")).unwrap();
    assert_eq!(pd.lines.len(), 3, "one suture path per leaflet");
    let c = |k: usize| p3(&truth["commissures_mm"][k % 3]);
    for k in 0..3 {
        let line: Vec<Point3> = pd.lines[k].iter().map(|&i| pd.points[i as usize]).collect();
        // Leaflet k is sutured from C_k to C_k+1 through N_k, in either direction.
        let (first, last) = (line[0], *line.last().unwrap());
        let ends = [(first - c(k)).norm(), (last - c(k + 1)).norm()];
        let swapped = [(first - c(k + 1)).norm(), (last - c(k)).norm()];
        let ends = if ends[0].max(ends[1]) <= swapped[0].max(swapped[1]) {
            ends
        } else {
            swapped
        };
        let nadir = to_line(&p3(&truth["nadirs_mm"][k]), &line);
        let off_wall = line
            .iter()
            .map(|q| (wall.closest(q).0 - q).norm())
            .fold(0.0, f64::max);
        eprintln!(
            "end_to_end: path {}: ends {:.3} / {:.3} mm from C{} / C{}, N{} {nadir:.3} mm from the path, max {off_wall:.3} mm off the true wall",
            k + 1,
            ends[0],
            ends[1],
            k + 1,
            (k + 1) % 3 + 1,
            k + 1
        );
        for e in ends {
            assert!(
                e <= LANDMARK_TOL_MM,
                "path {}: an end {e:.3} mm from its true commissure",
                k + 1
            );
        }
        assert!(
            nadir <= LANDMARK_TOL_MM,
            "path {}: true nadir {nadir:.3} mm away",
            k + 1
        );
        assert!(
            off_wall <= WALL_TOL_MM,
            "path {}: {off_wall:.3} mm off the true wall",
            k + 1
        );
    }
}

/// report.json's metrics; asserts the valve closed and every metric is a number.
fn closed_metrics(run: &Path) -> Value {
    let rep = json(&run.join("report.json"));
    assert_eq!(rep["verdict"]["closed"], true, "{}", rep["verdict"]);
    assert_eq!(rep["solver"]["converged"], true, "{}", rep["solver"]);
    let mut all = Vec::new();
    leaves("metrics".into(), &rep["metrics"], &mut all);
    assert!(all.len() > 10, "{all:?}");
    for (k, v) in all {
        let ok = v.as_f64().is_some_and(f64::is_finite) || v.is_boolean();
        assert!(ok, "{k} = {v}");
    }
    rep["metrics"].clone()
}

#[test]
fn sample_phantom_to_report_matches_truth_and_is_mesh_converged() {
    let t0 = Instant::now();
    let d = tmpdir("end-to-end");
    let run = d.join("run");
    run_chain(&write_config(&d, "0.5 mm"));
    assert_eq!(
        stage_statuses(&run)
            .iter()
            .map(|s| s.0.as_str())
            .collect::<Vec<_>>(),
        [
            "phantom", "segment", "surface", "valve", "leaflets", "close", "report"
        ]
    );
    check_segmentation(&run);
    check_paths(&run);
    let fine = closed_metrics(&run);

    // A coarser leaflet mesh re-runs the leaflets and what follows only.
    run_chain(&write_config(&d, "0.7 mm"));
    for (stage, status) in stage_statuses(&run) {
        let rerun = ["leaflets", "close", "report"].contains(&stage.as_str());
        assert_eq!(status, if rerun { "ran" } else { "skipped" }, "{stage}");
    }
    let coarse = closed_metrics(&run);
    for k in [
        "coaptation_height_mm",
        "central_coaptation_height_mm",
        "effective_height_mm",
    ] {
        let (a, b) = (coarse[k].as_f64().unwrap(), fine[k].as_f64().unwrap());
        eprintln!(
            "end_to_end: {k}: h 0.7 → {a:.3}, h 0.5 → {b:.3} (Δ {:.3})",
            b - a
        );
        assert!(
            (a - b).abs() <= HEIGHT_TOL_MM,
            "{k}: {a} (h 0.7) vs {b} (h 0.5)"
        );
    }
    let area = |m: &Value, k: &str| -> Vec<f64> {
        let a = &m["coaptation_area_mm2"];
        match k {
            "per_leaflet" => a[k]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect(),
            _ => vec![a[k].as_f64().unwrap()],
        }
    };
    for k in ["per_leaflet", "max", "min"] {
        for (a, b) in area(&coarse, k).into_iter().zip(area(&fine, k)) {
            let rel = (a - b).abs() / b;
            eprintln!(
                "end_to_end: coaptation area {k}: {a:.1} → {b:.1} mm² ({:.2} %)",
                100.0 * rel
            );
            assert!(
                rel <= AREA_TOL,
                "coaptation area {k}: {a} (h 0.7) vs {b} (h 0.5)"
            );
        }
    }
    eprintln!("end_to_end: {:.1} s", t0.elapsed().as_secs_f64());
}

/// The whole chain on the clinical phantom, the one with what real scans
/// show (1.5 mm, arch and descending aorta in view, native cusps closed,
/// annulus tilted 20° to the commissures): it completes, the wall is one
/// closed genus-0 surface, the valve frame sees the tilt, and the report's
/// verdict is its criteria's conjunction.
#[test]
fn clinical_phantom_runs_the_whole_chain() {
    let d = tmpdir("e2e-clinical");
    let run = run_default_chain(&d, &[], "\n[phantom]\npreset = \"clinical\"\nseed = 1\n");
    assert_eq!(
        json(&run.join("surface.json"))["euler_characteristic"].as_i64(),
        Some(2)
    );
    let valve = json(&run.join("valve.json"));
    let tilt = valve["annulus_plane_tilt_deg"].as_f64().unwrap();
    assert!(
        (tilt - 20.0).abs() <= 2.0,
        "annulus plane tilted {tilt:.1}° (truth 20°)"
    );
    assert_honest_verdict(&run);
}
