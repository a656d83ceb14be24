//! `coapt valve` on the committed phantom: paths through the true
//! commissures and nadirs, on the wall; frame and radii against truth.

use std::path::Path;

use coapt::geom::wall::Wall;
use coapt::geom::{Frame, Point3};
use coapt::io::{markups, vtp};
use serde_json::Value;

use crate::common::{coapt, repo, stderr, tmpdir};

fn p3(v: &Value) -> Point3 {
    Point3::new(
        v[0].as_f64().unwrap(),
        v[1].as_f64().unwrap(),
        v[2].as_f64().unwrap(),
    )
}

fn seg_dist(p: &Point3, a: &Point3, b: &Point3) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
    (p - (a + ab * t)).norm()
}

#[test]
fn phantom_paths_pass_the_true_landmarks_on_the_wall() {
    let d = tmpdir("valve-phantom");
    let data = repo().join("sample_data");
    let surface = data.join("truth_surface.vtp");
    let out = d.join("valve.json");
    let o = coapt(&[
        "valve",
        "--surface",
        surface.to_str().unwrap(),
        "--landmarks",
        data.join("landmarks.mrk.json").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let truth: Value =
        serde_json::from_slice(&std::fs::read(data.join("truth.json")).unwrap()).unwrap();
    let valve: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let pd = vtp::read(&d.join("paths.vtp")).unwrap();
    assert_eq!(pd.lines.len(), 3);
    let wall = Wall::new(&vtp::read_mesh(&surface).unwrap()).unwrap();
    let tf = &truth["valve_frame"];
    for k in 0..3 {
        let line: Vec<Point3> = pd.lines[k].iter().map(|&i| pd.points[i as usize]).collect();
        let near = |q: &Point3| {
            line.windows(2)
                .map(|w| seg_dist(q, &w[0], &w[1]))
                .fold(f64::INFINITY, f64::min)
        };
        for (what, q) in [
            ("C_k", p3(&tf["commissures_mm"][k])),
            ("C_k+1", p3(&tf["commissures_mm"][(k + 1) % 3])),
            ("N_k", p3(&tf["nadirs_mm"][k])),
        ] {
            let e = near(&q);
            assert!(e < 0.1, "leaflet {}: {what} missed by {e} mm", k + 1);
        }
        for q in &line {
            let e = (wall.closest(q).0 - q).norm();
            assert!(e < 0.05, "path point {e} mm off the wall");
        }
    }
    // Frame and radii against the analytic truth.
    let r = &valve["radii"];
    let tr = &truth["radii"];
    let close =
        |a: &Value, b: &Value, tol: f64| (a.as_f64().unwrap() - b.as_f64().unwrap()).abs() < tol;
    assert!(close(&r["annulus_mm"], &tr["annulus_mean_mm"], 0.05));
    assert!(close(&r["stj_mm"], &tr["stj_mm"], 0.1));
    for k in 0..3 {
        assert!(close(
            &r["sinus_mm"][k],
            &tr["sinus"][k]["max_radius_mm"],
            0.1
        ));
        assert!(close(
            &valve["commissure_angles_deg"][k],
            &truth["commissure_angles_deg"][k],
            0.05
        ));
    }
    assert!(close(&valve["h_comm_mm"], &truth["h_comm_mm"], 0.05));
    let o1 = p3(&valve["valve_frame"]["origin_mm"]);
    assert!((o1 - p3(&tf["origin_mm"])).norm() < 0.05);
    assert!(
        p3(&valve["valve_frame"]["axis"])
            .coords
            .dot(&p3(&tf["axis"]).coords)
            > 0.999
    );
}

#[test]
fn a_landmark_off_the_wall_is_named() {
    let d = tmpdir("valve-off-wall");
    let data = repo().join("sample_data");
    let mut lm = markups::read(&data.join("landmarks.mrk.json")).unwrap();
    for (label, p) in lm.points.iter_mut() {
        if label == "C2" {
            p.x += 6.0;
            p.y += 6.0;
        }
    }
    let bad = d.join("moved.mrk.json");
    markups::write_mrk_json(&bad, &lm, Frame::Lps).unwrap();
    let o = coapt(&[
        "valve",
        "--surface",
        data.join("truth_surface.vtp").to_str().unwrap(),
        "--landmarks",
        bad.to_str().unwrap(),
        "--out",
        d.join("valve.json").to_str().unwrap(),
    ]);
    // Judged while running (the wall is needed), so after the progress line.
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let line = err.lines().find(|l| l.starts_with("error: ")).unwrap();
    assert!(
        line.contains("moved.mrk.json") && line.contains("C2") && line.contains("from the wall"),
        "{err}"
    );
}

/// Nadir labels are names: the same points numbered N2, N3, N1 give the
/// same suture paths (leaflet k's nadir is the one between C_k and
/// C_k+1), and valve.json says which file label each leaflet took. Two
/// nadirs in one sector are refused, naming them (exit 2).
#[test]
fn nadirs_are_matched_to_leaflets_by_where_they_lie() {
    let d = tmpdir("valve-nadir-order");
    let data = repo().join("sample_data");
    let surface = data.join("truth_surface.vtp");
    let run = |lm: &Path, out: &str| {
        let dir = d.join(out);
        std::fs::create_dir_all(&dir).unwrap();
        let o = coapt(&[
            "valve",
            "--surface",
            surface.to_str().unwrap(),
            "--landmarks",
            lm.to_str().unwrap(),
            "--out",
            dir.join("valve.json").to_str().unwrap(),
        ]);
        (o, dir)
    };
    let original = data.join("landmarks.mrk.json");
    let (o, a) = run(&original, "a");
    assert!(o.status.success(), "{}", stderr(&o));
    let lm = markups::read(&original).unwrap();
    let relabel = |map: [(&str, &str); 3], name: &str| {
        let mut l = lm.clone();
        for (label, _) in l.points.iter_mut() {
            if let Some((_, to)) = map.iter().find(|(from, _)| from == label) {
                *label = to.to_string();
            }
        }
        let p = d.join(name);
        markups::write_mrk_json(&p, &l, Frame::Lps).unwrap();
        p
    };
    let rotated = relabel(
        [("N1", "N2"), ("N2", "N3"), ("N3", "N1")],
        "rotated.mrk.json",
    );
    let (o, b) = run(&rotated, "b");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(a.join("paths.vtp")).unwrap(),
        std::fs::read(b.join("paths.vtp")).unwrap()
    );
    let vb: Value = serde_json::from_slice(&std::fs::read(b.join("valve.json")).unwrap()).unwrap();
    assert_eq!(
        vb["nadir_of_leaflet"],
        serde_json::json!(["N2", "N3", "N1"])
    );
    let va: Value = serde_json::from_slice(&std::fs::read(a.join("valve.json")).unwrap()).unwrap();
    assert!(va.get("nadir_of_leaflet").is_none());
    assert_eq!(va["valve_frame"], vb["valve_frame"]);
    // Two nadirs between C1 and C2.
    let mut two = lm.clone();
    let n1 = lm.get("N1").unwrap();
    for (label, p) in two.points.iter_mut() {
        if label == "N2" {
            *p = n1 + (*p - n1) * 0.02;
        }
    }
    let bad = d.join("two.mrk.json");
    markups::write_mrk_json(&bad, &two, Frame::Lps).unwrap();
    let (o, _) = run(&bad, "c");
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("two.mrk.json") && err.contains("N1 and N2 both lie between C1 and C2"),
        "{err}"
    );
}
