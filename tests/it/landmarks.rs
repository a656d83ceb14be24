//! `coapt landmarks`: the commissures and nadirs found in the segmented root
//! against the truth of the phantoms and the hand-placed points of the real
//! CT, and `coapt run` on a CT alone reaching a report through them.

use std::path::{Path, PathBuf};

use coapt::geom::{Landmarks, Point3};
use coapt::io::markups;

use crate::common::*;
use crate::real_segment::real_dir;

/// The whole chain when the landmarks stage runs in it.
const DETECTING_CHAIN: [&str; 7] = [
    "segment",
    "surface",
    "landmarks",
    "valve",
    "leaflets",
    "close",
    "report",
];

const LABELS: [&str; 6] = ["C1", "C2", "C3", "N1", "N2", "N3"];

/// Distance of each found point to the truth, labels taken as they are.
fn distances(truth: &Landmarks, found: &Landmarks) -> Vec<(String, f64)> {
    LABELS
        .iter()
        .map(|l| {
            let t = truth.get(l).unwrap_or_else(|| panic!("truth has no {l}"));
            let f = found.get(l).unwrap_or_else(|| panic!("found no {l}"));
            (l.to_string(), (t - f).norm())
        })
        .collect()
}

/// The found points renamed by the cyclic shift of labels (C_k → C_k+s,
/// N_k → N_k+s: the same order around the axis) that brings them nearest
/// the truth: a user's file may start its numbering at any sinus.
fn cyclic_match(truth: &Landmarks, found: &Landmarks) -> (usize, Vec<(String, f64)>) {
    (0..3)
        .map(|s| {
            let mut renamed = Landmarks::new(found.frame);
            for pre in ["C", "N"] {
                for k in 0..3 {
                    let p: Point3 = found.get(&format!("{pre}{}", (k + s) % 3 + 1)).unwrap();
                    renamed.push(format!("{pre}{}", k + 1), p);
                }
            }
            (s, distances(truth, &renamed))
        })
        .min_by(|a, b| worst(&a.1).total_cmp(&worst(&b.1)))
        .unwrap()
}

fn worst(d: &[(String, f64)]) -> f64 {
    d.iter().map(|x| x.1).fold(0.0, f64::max)
}

/// `coapt segment` and `coapt surface` of `ct` into `d`: (mask, segment.json, wall).
fn segment_and_surface(d: &Path, ct: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let (mask, seg, surf) = (
        d.join("mask.nii.gz"),
        d.join("segment.json"),
        d.join("aorta.vtp"),
    );
    let o = coapt(&[
        "segment",
        "--ct",
        &s(ct),
        "--out",
        &s(&mask),
        "--report",
        &s(&seg),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = coapt(&[
        "surface",
        "--mask",
        &s(&mask),
        "--out",
        &s(&surf),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    (mask, seg, surf)
}

/// A phantom made with `args` in `d/ph`, its CT segmented and surfaced,
/// and the landmarks found there with segment's VAJ plane:
/// (the phantom's folder, found, truth).
fn from_phantom_ct(d: &Path, args: &[&str]) -> (PathBuf, Landmarks, Landmarks) {
    let ph = phantom_in(d, args);
    let (mask, seg, surf) = segment_and_surface(d, &ph.join("ct.nii.gz"));
    let found = detect(d, &mask, &surf, Some(&seg));
    let truth = markups::read(&ph.join("landmarks.mrk.json")).unwrap();
    (ph, found, truth)
}

/// `coapt phantom args` written to `d/ph`.
fn phantom_in(d: &Path, args: &[&str]) -> PathBuf {
    let ph = d.join("ph");
    let mut a = vec!["phantom", "--out", ph.to_str().unwrap(), "--quiet"];
    a.extend_from_slice(args);
    let o = coapt(&a);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    ph
}

fn detect(d: &Path, mask: &Path, surface: &Path, report: Option<&Path>) -> Landmarks {
    let out = d.join("found.mrk.json");
    let mut args = vec![
        "landmarks".to_string(),
        "--mask".into(),
        s(mask),
        "--surface".into(),
        s(surface),
        "--out".into(),
        s(&out),
        "--quiet".into(),
    ];
    if let Some(r) = report {
        args.push("--segment-report".into());
        args.push(s(r));
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = coapt(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // Every point carries a confidence in 0–1 and its evidence.
    let rep = json(&d.join("landmarks.json"));
    let pts = rep["points"].as_array().unwrap();
    assert_eq!(pts.len(), 6, "{rep}");
    for p in pts {
        let c = p["confidence"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&c), "{p}");
        assert!(p["evidence"].is_object(), "{p}");
    }
    markups::read(&out).unwrap()
}

/// The committed sample's truth mask and analytic surface (its VAJ cap is
/// region 1): the detector alone, without segmentation error, is within
/// 1.5 mm of every true point (measured 0.01–0.82 mm), labels as the
/// phantom names them; and the same bytes on one and two threads.
#[test]
fn sample_truth_mask_within_1_5_mm() {
    let d = tmpdir("lm-truth");
    let sd = repo().join("sample_data");
    let found = detect(
        &d,
        &sd.join("truth_mask.nii.gz"),
        &sd.join("truth_surface.vtp"),
        None,
    );
    let truth = markups::read(&sd.join("landmarks.mrk.json")).unwrap();
    let dist = distances(&truth, &found);
    eprintln!("sample truth mask: {dist:?}");
    assert!(worst(&dist) <= 1.5, "{dist:?}");
    let one = std::fs::read(d.join("found.mrk.json")).unwrap();
    let o = coapt(&[
        "--threads",
        "1",
        "landmarks",
        "--mask",
        &s(&sd.join("truth_mask.nii.gz")),
        "--surface",
        &s(&sd.join("truth_surface.vtp")),
        "--out",
        &s(&d.join("one.mrk.json")),
        "--report",
        &s(&d.join("one.json")),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(one, std::fs::read(d.join("one.mrk.json")).unwrap());
}

/// The standard phantom, seed 2, from its CT: segment, surface, landmarks
/// (with segment's VAJ plane). Every point within 1.5 mm of the truth
/// (measured 0.53–0.84 mm).
#[test]
fn standard_phantom_from_its_ct_within_1_5_mm() {
    let d = tmpdir("lm-standard");
    let (_, found, truth) = from_phantom_ct(&d, &["--preset", "standard", "--seed", "2"]);
    let dist = distances(&truth, &found);
    eprintln!("standard seed 2 from its CT: {dist:?}");
    assert!(worst(&dist) <= 1.5, "{dist:?}");
}

/// Sample seed 1 drawn with its closed native cusps, from its CT: the mask
/// loses a dent along each cusp's hinge line up to the commissures, which
/// held the knee of the narrowing, read over every ray, 1 mm low (the
/// commissures 0.86–1.33 mm under the truth; without cusps 0.02–0.16).
/// Read on the sinus sectors' middle half, their heights along the valve
/// axis are within 0.5 mm of the truth (measured −0.31 to +0.13 mm) and
/// every commissure within 1.5 mm (0.42–1.38).
#[test]
fn commissures_under_closed_cusps_keep_their_height() {
    let d = tmpdir("lm-cusps");
    let (ph, found, truth) = from_phantom_ct(&d, &["--seed", "1", "--native-cusps"]);
    let axis = point(&json(&ph.join("truth.json"))["valve_frame"]["axis"]).coords;
    for l in ["C1", "C2", "C3"] {
        let off = found.get(l).unwrap() - truth.get(l).unwrap();
        let (dh, dist) = (off.dot(&axis), off.norm());
        eprintln!("{l}: {dist:.2} mm off, {dh:+.2} mm in height");
        assert!(dh.abs() <= 0.5, "{l}: {dh:+.2} mm in height");
        assert!(dist <= 1.5, "{l}: {dist:.2} mm");
    }
}

/// Sample seed 8 from its CT: a coronary ostium pulls its sinus' radius
/// maximum 23° off the nadir, which lies where the cusp's hinge line is
/// lowest, midway between its commissures. Every nadir lies within 1.5 mm
/// of the truth (measured 0.60–1.23 mm; N2 was 2.56 mm off when read
/// halfway between the maximum and the middle).
#[test]
fn a_coronary_ostium_does_not_pull_its_nadir_aside() {
    let d = tmpdir("lm-ostium");
    let (_, found, truth) = from_phantom_ct(&d, &["--preset", "sample", "--seed", "8"]);
    let dist = distances(&truth, &found);
    eprintln!("sample seed 8 from its CT: {dist:?}");
    for (l, e) in dist.iter().filter(|(l, _)| l.starts_with('N')) {
        assert!(*e <= 1.5, "{l}: {e:.2} mm ({dist:?})");
    }
}

/// `coapt run` on the sample CT alone (no landmarks under [inputs]): the
/// landmarks stage runs after the surface and feeds `valve`, the chain
/// reaches `report.json`, segment ran without landmarks, and the found
/// points lie within 1.5 mm of the truth (measured: commissures
/// 0.08–0.84, nadirs 1.05–1.44 mm; the nadirs inherit segment's VAJ
/// plane, 0.6–1.2 mm above the true nadir plane on this phantom; on the
/// truth mask they are within 0.40 mm, see above).
#[test]
fn run_on_a_ct_alone_reaches_a_report() {
    let d = tmpdir("lm-run");
    let sd = repo().join("sample_data");
    let run = run_default_chain(&d, &[("ct", &sd.join("ct.nii.gz"))], "");
    assert!(run.join("report.json").is_file());
    assert_honest_verdict(&run);
    let (manifest, stages) = manifest_stages(&run);
    assert_eq!(stages, DETECTING_CHAIN, "{manifest}");
    let seg = manifest["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["stage"] == "segment")
        .unwrap();
    assert!(seg["inputs"].get("landmarks").is_none(), "{seg}");
    let found = markups::read(&run.join("landmarks.mrk.json")).unwrap();
    let truth = markups::read(&sd.join("landmarks.mrk.json")).unwrap();
    let dist = distances(&truth, &found);
    eprintln!("sample CT alone: {dist:?}");
    for (l, e) in &dist {
        assert!(*e <= 1.5, "{l}: {e:.2} mm > 1.5 mm ({dist:?})");
    }
    // The valve frame is built from the detected points.
    let valve = json(&run.join("valve.json"));
    let c1 = &valve["landmarks_snapped"]["C1"]["moved_mm"];
    assert!(c1.as_f64().unwrap() < 0.5, "{valve}");
    // The report says the points were detected, each with its confidence,
    // and draws them (the CT figure reads landmarks.mrk.json).
    let report = json(&run.join("report.json"));
    let lm = &report["case"]["landmarks"];
    assert_eq!(lm["source"], "detected", "{lm}");
    let labels: Vec<&str> = lm["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["label"].as_str().unwrap())
        .collect();
    assert_eq!(labels, ["C1", "C2", "C3", "N1", "N2", "N3"], "{lm}");
    assert!(lm["points"].as_array().unwrap().iter().all(|p| {
        let c = p["confidence"].as_f64().unwrap();
        (0.0..=1.0).contains(&c)
    }));
    assert!(
        report["inputs"]["landmarks"].is_object(),
        "{}",
        report["inputs"]
    );
    let page = std::fs::read_to_string(run.join("report.html")).unwrap();
    assert!(page.contains("<dt>Landmarks</dt><dd>detected by coapt"));
    // The run's CT reached the stage, its coronary ostia named the
    // sinuses (measured 0.28 / 0.58 mm from the phantom's), and the
    // report says so.
    let found = json(&run.join("landmarks.json"));
    let truth = json(&sd.join("truth.json"));
    ostia_match_truth(&found, &truth, 1.0);
    // Every nadir sits on a sinus floor (the wall widens 2.0–2.1 mm in the
    // first 3 mm above it): no point is flagged.
    assert!(
        !found["findings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|f| f.as_str().unwrap().contains("low confidence")),
        "{}",
        found["findings"]
    );
    assert!(page.contains("<dt>Sinuses</dt><dd>N1 right-coronary (ostium "));
    assert!(page.contains("N2 left-coronary (ostium "));
    assert!(page.contains("N3 non-coronary;"));
    assert!(page.contains(
        "leaflets 1 / 2 / 3 sewn in the right-coronary / left-coronary / non-coronary sinuses"
    ));
    assert!(page.contains("named by the coronary ostia seen in the CT"));
    // 3D Slicer shows each point's sinus beside it; the file still reads.
    let mrk = std::fs::read_to_string(run.join("landmarks.mrk.json")).unwrap();
    assert!(mrk.contains(
        "\"description\": \"nadir of the right-coronary sinus (detected; sinuses named by the coronary ostia)\""
    ));
    assert!(mrk.contains("commissure between the right-coronary and left-coronary sinuses"));
}

/// The sinuses were named by the CT's coronary ostia, each ostium lies
/// within `bound` mm of the phantom's of the same name, and the
/// non-coronary sinus has none.
fn ostia_match_truth(found: &serde_json::Value, truth: &serde_json::Value, bound: f64) {
    assert_eq!(
        found["sinus_naming"]["by"], "coronary_ostia",
        "{}",
        found["sinus_naming"]
    );
    let sinuses = found["sinuses"].as_array().unwrap();
    let names: Vec<&str> = sinuses
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["right_coronary", "left_coronary", "non_coronary"]);
    assert!(sinuses[2]["ostium"].is_null(), "{}", sinuses[2]);
    for c in truth["coronaries"].as_array().unwrap() {
        let s = sinuses.iter().find(|s| s["name"] == c["sinus"]).unwrap();
        let p = point(&s["ostium"]["point_mm"]);
        let e = (p - point(&c["ostium_mm"])).norm();
        eprintln!("{} ostium {e:.2} mm from the truth", c["name"]);
        assert!(e <= bound, "{}: {e:.2} mm > {bound} mm", c["name"]);
    }
}

fn point(v: &serde_json::Value) -> Point3 {
    let a: Vec<f64> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    Point3::new(a[0], a[1], a[2])
}

/// `coapt landmarks --ct` on a phantom's truth mask (segmentation out of
/// the question): `args` are the phantom's.
fn landmarks_of_phantom(d: &Path, args: &[&str]) -> (serde_json::Value, serde_json::Value) {
    let ph = d.join("ph");
    let mut a = vec!["phantom", "--out", ph.to_str().unwrap(), "--quiet"];
    a.extend_from_slice(args);
    let o = coapt(&a);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = coapt(&[
        "landmarks",
        "--ct",
        &s(&ph.join("ct.nii.gz")),
        "--mask",
        &s(&ph.join("truth_mask.nii.gz")),
        "--surface",
        &s(&ph.join("truth_surface.vtp")),
        "--out",
        &s(&d.join("found.mrk.json")),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    (
        json(&d.join("landmarks.json")),
        json(&ph.join("truth.json")),
    )
}

/// The clinical phantom of seed 1 (1.5 mm; arch, descending aorta and
/// spine in view, native cusps, annulus tilted 20°) from its CT alone:
/// segment finds the root, cuts off the arch and the descending aorta, and
/// the chain reaches an honest report. Segment's VAJ plane turns onto the
/// LVOT's axis (measured: 1.4° from the nadirs' plane, 20.3° from the
/// marched centreline; 3.7° onto the least section searched 4 mm below
/// the knee), so every nadir is read on the annulus (measured 0.65–1.33
/// mm; 0.65–1.41 with the rays' origins off the axis, 0.85–1.41 with the
/// least section, 1.10–1.41 before each nadir's ray kept its angle about
/// the root axis; 1.38–3.30 mm when the plane stayed square to the
/// marched centreline, 20° off the nadirs' plane: the nadir below it
/// was read on the cut and N1, 5 mm above it, was lifted onto its sinus
/// floor). Commissures 0.78–0.84 mm, read on the sinus sectors' middle
/// half (1.43–1.71 mm on every ray, where the cusps' hinge dents below
/// the commissures held the narrowing's knee 1.5 mm low). No nadir needs
/// lifting now.
#[test]
fn clinical_phantom_ct_alone_reaches_a_report() {
    let d = tmpdir("lm-run-clinical");
    let ph = phantom_in(&d, &["--preset", "clinical", "--seed", "1"]);
    let run = run_default_chain(&d, &[("ct", &ph.join("ct.nii.gz"))], "");
    assert!(run.join("report.json").is_file());
    assert_honest_verdict(&run);
    let (manifest, stages) = manifest_stages(&run);
    assert_eq!(
        stages[..3],
        ["segment", "surface", "landmarks"],
        "{manifest}"
    );
    let seg = json(&run.join("segment.json"));
    assert!(
        seg["topology"]["cut_above_z_mm"].is_f64(),
        "{}",
        seg["topology"]
    );
    let floor = &seg["vaj"]["profile"]["floor"];
    let turn = floor["lvot_turn_deg"].as_f64().unwrap_or(0.0);
    assert!((10.0..=30.0).contains(&turn), "{floor}");
    let found = markups::read(&run.join("landmarks.mrk.json")).unwrap();
    let truth = markups::read(&ph.join("landmarks.mrk.json")).unwrap();
    let dist = distances(&truth, &found);
    eprintln!("clinical CT alone: {dist:?}");
    for (l, e) in &dist {
        let bound = if l.starts_with('C') { 1.0 } else { 1.5 };
        assert!(*e <= bound, "{l}: {e:.2} mm > {bound} mm ({dist:?})");
    }
    let lm = json(&run.join("landmarks.json"));
    for p in lm["points"].as_array().unwrap() {
        assert!(p["evidence"]["lifted_mm"].is_null(), "{p}");
    }
}

/// Clinical seed 1 with its annulus tilted 35° to the commissures (the
/// issue's widest tilt), from its CT alone: segment's VAJ plane lies within
/// 5° of the nadirs' plane (measured 2.6°; 14.7° when it turned onto the
/// least section 4 mm below the knee, which at this tilt cut the sinus on
/// the high side) and every nadir within 1.5 mm (measured 0.78–0.84 mm;
/// 2.93 / 3.49 mm before), every commissure within 1.5 mm (0.37–0.75).
/// The lowest nadir is no finding: its wall, read from the root axis,
/// widens 1.7 mm over 3 mm (confidence 0.95; read from the plane's normal,
/// which leaves the axis by 0.57 mm per mm up, −0.2 mm and 0.00).
#[test]
fn an_annulus_tilted_35_degrees_from_its_ct_alone() {
    let d = tmpdir("lm-tilt35");
    let (ph, found, truth) = from_phantom_ct(
        &d,
        &[
            "--preset",
            "clinical",
            "--seed",
            "1",
            "--annulus-tilt",
            "35 deg",
        ],
    );
    let plane = &json(&d.join("segment.json"))["vaj"]["plane"]["normal"];
    let truth_plane = &json(&ph.join("truth.json"))["annulus_plane"]["normal"];
    let (a, b) = (point(plane).coords, point(truth_plane).coords);
    let off = a.dot(&b).abs().min(1.0).acos().to_degrees();
    eprintln!("VAJ plane {off:.2}° off the nadirs' plane");
    assert!(off <= 5.0, "VAJ plane {off:.2}° off the nadirs' plane");
    let dist = distances(&truth, &found);
    eprintln!("clinical seed 1, annulus tilted 35°, from its CT: {dist:?}");
    assert!(worst(&dist) <= 1.5, "{dist:?}");
    for p in json(&d.join("landmarks.json"))["points"]
        .as_array()
        .unwrap()
    {
        assert!(p["confidence"].as_f64().unwrap() >= 0.5, "{p}");
    }
}

/// The clinical phantom (arch, native cusps, tilted annulus) of seed 2,
/// whose right coronary is the thinnest of the phantoms' (1.38 mm): both
/// ostia are found (measured 0.29 and 0.23 mm off) and name the sinuses.
#[test]
fn clinical_phantoms_coronary_ostia_name_its_sinuses() {
    let d = tmpdir("lm-ostia-clinical");
    let (found, truth) = landmarks_of_phantom(&d, &["--preset", "clinical", "--seed", "2"]);
    ostia_match_truth(&found, &truth, 1.0);
    assert_eq!(found["findings"].as_array().unwrap().len(), 0, "{found}");
}

/// A root turned 120° about its axis, so that the non-coronary sinus faces
/// anterior: the position rule would name every sinus wrong; the coronary
/// ostia name them right (each point within 1.5 mm of the phantom's of
/// its label; measured 0.28–0.70 mm), and the disagreement is a finding
/// with less confidence.
#[test]
fn on_a_turned_root_the_coronary_ostia_overrule_the_position() {
    let d = tmpdir("lm-ostia-turned");
    let (found, truth) = landmarks_of_phantom(
        &d,
        &[
            "--preset",
            "sample",
            "--seed",
            "1",
            "--root-rotation",
            "120 deg",
        ],
    );
    assert_eq!(
        truth["root_rotation_deg"].as_f64().map(f64::round),
        Some(120.0)
    );
    ostia_match_truth(&found, &truth, 1.0);
    let naming = &found["sinus_naming"];
    assert_eq!(naming["agrees_with_position"], false, "{naming}");
    assert_eq!(naming["confidence"], 0.7, "{naming}");
    let findings = found["findings"].as_array().unwrap();
    assert!(
        findings
            .iter()
            .any(|f| f.as_str().unwrap().contains("the ostia were followed")),
        "{findings:?}"
    );
    let truth_points = markups::read(&d.join("ph/landmarks.mrk.json")).unwrap();
    let points = markups::read(&d.join("found.mrk.json")).unwrap();
    let dist = distances(&truth_points, &points);
    assert!(worst(&dist) <= 1.5, "{dist:?}");
}

/// A CT without coronaries: no ostium is seen, the sinuses are named by
/// position (the anterior one is the right-coronary sinus, as before), and
/// that is a finding, not a silent guess.
#[test]
fn without_visible_ostia_the_sinuses_are_named_by_position_and_said_so() {
    let d = tmpdir("lm-ostia-none");
    let (found, _) = landmarks_of_phantom(
        &d,
        &["--preset", "sample", "--seed", "1", "--no-coronaries"],
    );
    let naming = &found["sinus_naming"];
    assert_eq!(naming["by"], "position", "{naming}");
    assert_eq!(naming["ct_searched"], true, "{naming}");
    assert!(naming["confidence"].as_f64().unwrap() < 1.0, "{naming}");
    assert!(
        found["sinuses"]
            .as_array()
            .unwrap()
            .iter()
            .all(|s| s["ostium"].is_null())
    );
    let findings = found["findings"].as_array().unwrap();
    assert!(
        findings.iter().any(|f| f
            .as_str()
            .unwrap()
            .contains("coronary ostia seen in 0 sinuses")),
        "{findings:?}"
    );
    // The truth's N1 is the right-coronary sinus's, and so is the found N1.
    let truth = markups::read(&d.join("ph/landmarks.mrk.json")).unwrap();
    let n1 = markups::read(&d.join("found.mrk.json")).unwrap();
    assert!((truth.get("N1").unwrap() - n1.get("N1").unwrap()).norm() < 1.5);
}

/// With landmarks given, the chain uses them and does not detect any.
#[test]
fn given_landmarks_are_used_as_before() {
    let d = tmpdir("lm-given");
    let sd = repo().join("sample_data");
    let cfg = d.join("c.toml");
    std::fs::write(
        &cfg,
        format!(
            "[run]\ndir = \"{}\"\n[inputs]\nct = \"{}\"\nlandmarks = \"{}\"\n",
            d.join("run").display(),
            sd.join("ct.nii.gz").display(),
            sd.join("landmarks.mrk.json").display()
        ),
    )
    .unwrap();
    let o = coapt(&["run", &s(&cfg), "--until", "valve", "--quiet"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (manifest, stages) = manifest_stages(&d.join("run"));
    assert_eq!(stages, ["segment", "surface", "valve"], "{manifest}");
    assert!(!d.join("run/landmarks.mrk.json").exists());
}

/// The CT of `case` (a folder with `ct.nii.gz` and `landmarks.mrk.json`:
/// the sample, a phantom, the real CT), its landmarks, and a file in `d` of
/// only `labels` of them: what a user who placed some of the points gives.
fn given_only(d: &Path, case: &Path, labels: &[&str]) -> (PathBuf, Landmarks, PathBuf) {
    let truth = markups::read(&case.join("landmarks.mrk.json")).unwrap();
    let given = d.join("given.mrk.json");
    some_points(&case.join("landmarks.mrk.json"), &given, labels);
    (case.join("ct.nii.gz"), truth, given)
}

/// Every point of `found` within `bound(label)` of `truth`'s (labels as they are).
fn assert_within(truth: &Landmarks, found: &Landmarks, bound: impl Fn(&str) -> f64) {
    let dist = distances(truth, found);
    eprintln!("distances to the truth: {dist:?}");
    for (l, e) in &dist {
        let b = bound(l);
        assert!(*e <= b, "{l}: {e:.2} mm > {b} mm ({dist:?})");
    }
}

/// A `landmarks` input with the commissures and no nadirs (what a user who
/// placed C1–C3 gives): the landmarks stage runs with it as the given
/// points and detects N1–N3; segment, before it, is seeded from the file;
/// the valve and the report read the completed landmarks. Before, the
/// landmarks stage was left out and the valve ran without nadirs.
#[test]
fn commissures_alone_are_completed_by_detected_nadirs() {
    let d = tmpdir("lm-commissures");
    let (ct, truth, given_path) = given_only(&d, &repo().join("sample_data"), &["C1", "C2", "C3"]);
    let run = run_default_chain(&d, &[("ct", &ct), ("landmarks", &given_path)], "");
    let (manifest, stages) = manifest_stages(&run);
    assert_eq!(stages, DETECTING_CHAIN, "{manifest}");
    let input = |stage: &str, name: &str| stage_input(&manifest, stage, name);
    assert_eq!(input("segment", "landmarks"), s(&given_path));
    assert_eq!(input("landmarks", "given_landmarks"), s(&given_path));
    assert!(input("valve", "landmarks").ends_with("landmarks.mrk.json"));
    assert_ne!(input("valve", "landmarks"), s(&given_path));
    let found = markups::read(&run.join("landmarks.mrk.json")).unwrap();
    let rep = json(&run.join("landmarks.json"));
    for p in rep["points"].as_array().unwrap() {
        let l = p["label"].as_str().unwrap();
        let want = if l.starts_with('C') {
            "given"
        } else {
            "detected"
        };
        assert_eq!(p["source"], want, "{p}");
        let off = (found.get(l).unwrap() - truth.get(l).unwrap()).norm();
        assert!(off <= 1.5, "{l} {off:.2} mm from the truth");
    }
    assert!(run.join("report.json").is_file());
    // `coapt design` on the same config: its sizes' reports read the
    // completed landmarks too, not the file given.
    let o = coapt(&["design", &s(&d.join("chain.toml")), "--sizes", "19", "-q"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let sized = json(&run.join("design/size-19/manifest.json"));
    assert_eq!(
        stage_input(&sized, "report", "landmarks"),
        s(&run.join("landmarks.mrk.json"))
    );
}

/// `coapt run` of `inputs` with the default template, up to the valve: all
/// a landmarks file given in part needs to be completed and used.
fn run_until_valve(d: &Path, inputs: &[(&str, &Path)]) -> PathBuf {
    let cfg = chain_config(
        d,
        inputs,
        &repo().join("pipelines/templates/ozaki_default.toml"),
        &repo().join("pipelines/close.toml"),
        "",
    );
    let o = coapt(&["run", &s(&cfg), "--until", "valve", "--quiet"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    d.join("run")
}

/// A user who placed only the nadirs: `segment` cuts at their plane, the
/// landmarks stage finds the commissures, and the valve reads the whole
/// set. Before, the file was refused ("missing landmarks C1, C2, C3"), by
/// `coapt run` and by `coapt segment --landmarks` alike. The same file
/// given as `landmarks` beside a `given_landmarks` is refused: the stage
/// takes one file of the user's points.
#[test]
fn nadirs_alone_are_completed_by_detected_commissures() {
    let d = tmpdir("lm-nadirs");
    let (ct, truth, given_path) = given_only(&d, &repo().join("sample_data"), &["N1", "N2", "N3"]);
    let run = run_until_valve(&d, &[("ct", &ct), ("landmarks", &given_path)]);
    let (manifest, stages) = manifest_stages(&run);
    assert_eq!(stages, DETECTING_CHAIN[..4], "{manifest}");
    assert_eq!(
        stage_input(&manifest, "segment", "landmarks"),
        s(&given_path)
    );
    let seg = json(&run.join("segment.json"));
    assert!(
        seg["vaj"]["method"]
            .as_str()
            .unwrap()
            .contains("nadir landmarks"),
        "{}",
        seg["vaj"]
    );
    let found = markups::read(&run.join("landmarks.mrk.json")).unwrap();
    assert_within(
        &truth,
        &found,
        |l| if l.starts_with('N') { 0.0 } else { 1.5 },
    );
    assert!(run.join("valve.json").is_file());

    let cfg = d.join("chain.toml");
    let text = std::fs::read_to_string(&cfg).unwrap()
        + &format!("given_landmarks = \"{}\"\n", given_path.display());
    std::fs::write(&cfg, text).unwrap();
    run_refused(&cfg, &["inputs.given_landmarks", "into one file"]);
}

/// The real CT with only its hand-placed nadirs. That file numbers the
/// sinuses from the left-coronary one, the detector from the right: the
/// commissures found take the file's numbering (C_k, N_k, C_k+1 bound one
/// sinus), so each lies within 3 mm of the hand-placed point of its label
/// (measured 2.21 / 2.03 / 1.54 mm) and the valve needs no renaming.
/// Before, the detector's C1–C3 came back beside the user's N1–N3, a
/// sinus apart (21–26 mm from the hand's C1–C3).
#[test]
fn real_ct_nadirs_alone_take_the_files_numbering() {
    let Some(real) = real_dir() else { return };
    let d = tmpdir("lm-real-nadirs");
    let (ct, hand, given_path) = given_only(&d, &real, &["N1", "N2", "N3"]);
    let run = run_until_valve(&d, &[("ct", &ct), ("landmarks", &given_path)]);
    let rep = json(&run.join("landmarks.json"));
    assert_eq!(rep["numbering_turn"], 2, "{}", rep["sinuses"]);
    assert_commissures_in_the_nadirs_numbering(&run, &hand, 3.0);
}

/// The completed file of a run given nadirs alone: the nadirs as given,
/// each commissure within `bound` mm of `reference`'s point of its label,
/// and a valve that needs no renaming of nadirs to leaflets.
fn assert_commissures_in_the_nadirs_numbering(run: &Path, reference: &Landmarks, bound: f64) {
    let found = markups::read(&run.join("landmarks.mrk.json")).unwrap();
    assert_within(reference, &found, |l| {
        if l.starts_with('N') { 0.0 } else { bound }
    });
    let valve = json(&run.join("valve.json"));
    assert!(
        valve.get("nadir_of_leaflet").is_none(),
        "{}",
        valve["nadir_of_leaflet"]
    );
}

/// The sample's nadirs given numbered the other way round the valve (N2
/// and N3 swapped): the commissures found are numbered that way too, so
/// that N_k still lies between C_k and C_k+1 (the truth's C1 and C2 swap
/// labels, C3 keeps its own), each within 1.5 mm of the truth's point of
/// its new label. Before, the detector's counter-clockwise C1–C3 came back
/// beside the clockwise nadirs.
#[test]
fn nadirs_numbered_clockwise_number_the_commissures_so() {
    let d = tmpdir("lm-mirrored");
    let case = repo().join("sample_data");
    let truth = markups::read(&case.join("landmarks.mrk.json")).unwrap();
    let relabel = |l: &str| {
        match l {
            "N2" => "N3",
            "N3" => "N2",
            "C1" => "C2",
            "C2" => "C1",
            other => other,
        }
        .to_string()
    };
    let mut mirrored = Landmarks::new(truth.frame);
    for (l, p) in &truth.points {
        mirrored.push(relabel(l), *p);
    }
    let mut nadirs = Landmarks::new(truth.frame);
    for (l, p) in mirrored.points.iter().filter(|(l, _)| l.starts_with('N')) {
        nadirs.push(l.clone(), *p);
    }
    let given = d.join("given.mrk.json");
    markups::write_mrk_json(&given, &nadirs, truth.frame).unwrap();
    let run = run_until_valve(
        &d,
        &[("ct", &case.join("ct.nii.gz")), ("landmarks", &given)],
    );
    let rep = json(&run.join("landmarks.json"));
    assert_eq!(rep["numbering_mirrored"], true, "{}", rep["sinuses"]);
    assert_commissures_in_the_nadirs_numbering(&run, &mirrored, 1.5);
}

/// Clinical seed 2 from its commissures alone: the march along the track
/// began in the arch, and its plane lay far above the commissures. Marched
/// down the commissures' axis instead (the fallback before), the plane was
/// 7.3 mm low at N1, and N1 was found 7.51 mm from the truth; with the CT's
/// own plane (segmented without landmarks) the nadirs lie within 1.5 mm
/// (measured 0.58 / 0.88 / 0.92 mm; seeds 1 and 3 went from 1.70 and 4.29
/// mm at worst to 0.90 and 1.43).
#[test]
fn clinical_phantom_from_its_commissures_alone_within_1_5_mm() {
    let d = tmpdir("lm-clinical-commissures");
    let ph = phantom_in(&d, &["--preset", "clinical", "--seed", "2"]);
    let (ct, truth, given_path) = given_only(&d, &ph, &["C1", "C2", "C3"]);
    let run = run_until_valve(&d, &[("ct", &ct), ("landmarks", &given_path)]);
    let seg = json(&run.join("segment.json"));
    let method = seg["vaj"]["method"].as_str().unwrap();
    assert!(method.contains("segmented without landmarks"), "{method}");
    let found = markups::read(&run.join("landmarks.mrk.json")).unwrap();
    assert_within(
        &truth,
        &found,
        |l| if l.starts_with('C') { 0.0 } else { 1.5 },
    );
}

/// The path a run's `manifest` records for `stage`'s input `name`.
fn stage_input(manifest: &serde_json::Value, stage: &str, name: &str) -> String {
    let rec = manifest["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["stage"] == stage)
        .unwrap();
    rec["inputs"][name]["path"].as_str().unwrap().to_string()
}

/// A user's file holding some of the points (here C1, moved 1.5 mm along
/// the wall's tangent, and N2) corrects the detection point by point: the
/// written landmarks are the user's where given and the detector's
/// elsewhere, landmarks.json says which is which and how far the user's
/// point lies from the detected one, and the report's case header lists
/// them.
#[test]
fn given_points_override_detected_ones_point_by_point() {
    let d = tmpdir("lm-merge");
    let sd = repo().join("sample_data");
    for sub in ["alone", "merged"] {
        std::fs::create_dir_all(d.join(sub)).unwrap();
    }
    let alone = run_default_chain(&d.join("alone"), &[("ct", &sd.join("ct.nii.gz"))], "");
    let detected = markups::read(&alone.join("landmarks.mrk.json")).unwrap();
    let c1 = detected.get("C1").unwrap() + coapt::geom::Vector3::new(0.0, 0.0, 1.5);
    let n2 = markups::read(&sd.join("landmarks.mrk.json"))
        .unwrap()
        .get("N2")
        .unwrap();
    let mut given = Landmarks::new(coapt::geom::Frame::Lps);
    given.push("N2", n2);
    given.push("C1", c1);
    let given_path = d.join("mine.mrk.json");
    markups::write_mrk_json(&given_path, &given, coapt::geom::Frame::Lps).unwrap();
    let run = run_default_chain(
        &d.join("merged"),
        &[
            ("ct", &sd.join("ct.nii.gz")),
            ("given_landmarks", &given_path),
        ],
        "",
    );
    let merged = markups::read(&run.join("landmarks.mrk.json")).unwrap();
    for l in LABELS {
        let want = match l {
            "C1" => c1,
            "N2" => n2,
            _ => detected.get(l).unwrap(),
        };
        assert_eq!(merged.get(l).unwrap(), want, "{l}");
    }
    let rep = json(&run.join("landmarks.json"));
    for p in rep["points"].as_array().unwrap() {
        let l = p["label"].as_str().unwrap();
        let given = l == "C1" || l == "N2";
        assert_eq!(p["source"], if given { "given" } else { "detected" }, "{p}");
        if l == "C1" {
            let moved = p["given_to_detected_mm"].as_f64().unwrap();
            assert!((moved - 1.5).abs() < 1e-9, "{p}");
        }
    }
    let page = std::fs::read_to_string(run.join("report.html")).unwrap();
    assert!(
        page.contains("C1 given (1.5 mm from where coapt found it)"),
        "the case header names the given points"
    );
    // A file holding none of the six points is refused before any work.
    std::fs::write(
        &given_path,
        markups::encode_mrk_json(
            &{
                let mut l = Landmarks::new(coapt::geom::Frame::Lps);
                l.push("STJ", n2);
                l
            },
            coapt::geom::Frame::Lps,
        ),
    )
    .unwrap();
    run_refused(
        &d.join("merged/chain.toml"),
        &["holds none of C1, C2, C3, N1, N2, N3"],
    );
}

/// `coapt run cfg` refuses before any work (exit 2), saying `words`.
fn run_refused(cfg: &Path, words: &[&str]) {
    let o = coapt(&["run", &s(cfg), "--quiet"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    for w in words {
        assert!(stderr(&o).contains(w), "no {w:?} in: {}", stderr(&o));
    }
}

/// The real CT, segmented without landmarks: the found points against the
/// hand-placed ones of `../shared/real/`, matched by their order around the
/// axis (that file numbers the sinuses from another one than the
/// phantom's anterior right-coronary sinus). The commissures and two
/// nadirs lie within 3 mm (measured 1.81–2.47 and 1.47–1.82 mm). The
/// third hand-placed nadir (N3) lies inside the lumen: 1.7 mm from
/// TotalSegmentator's wall (the folder's README) and 8.4 mm from our
/// annulus centre where the wall is 13 mm away; ours, on the wall, is
/// 5.5 mm from it, and the test holds it to 7 mm.
#[test]
fn real_ct_within_3_mm_of_the_hand_placed_points() {
    let Some(real) = real_dir() else { return };
    let d = tmpdir("lm-real");
    let (mask, seg, surf) = segment_and_surface(&d, &real.join("ct.nii.gz"));
    let found = detect(&d, &mask, &surf, Some(&seg));
    let truth = markups::read(&real.join("landmarks.mrk.json")).unwrap();
    let (shift, dist) = cyclic_match(&truth, &found);
    eprintln!("real CT (labels shifted by {shift}): {dist:?}");
    for (l, e) in &dist {
        let bound = if l == "N3" { 7.0 } else { 3.0 };
        assert!(*e <= bound, "{l}: {e:.2} mm > {bound} mm ({dist:?})");
    }
    // With its CT, the real root's coronary ostia name the sinuses. No
    // truth is at hand for them; anatomy is: the right coronary leaves the
    // anterior sinus, the left main the left-posterior one (in LPS, −y is
    // anterior, +x the patient's left). Measured: the right ostium 13.4 mm
    // anterior of the axis, 20.7 mm above the annulus; the left 10.7 mm
    // left and 11.5 mm posterior, 13.3 mm above.
    let with_ct = |name: &str, more: &[&str]| {
        let (ct, mask, surf, seg) = (s(&real.join("ct.nii.gz")), s(&mask), s(&surf), s(&seg));
        let (out, report) = (
            s(&d.join(format!("{name}.mrk.json"))),
            s(&d.join(format!("{name}.json"))),
        );
        let mut args = vec![
            "landmarks",
            "--ct",
            &ct,
            "--mask",
            &mask,
            "--surface",
            &surf,
            "--segment-report",
            &seg,
            "--out",
            &out,
            "--report",
            &report,
            "--quiet",
        ];
        args.extend_from_slice(more);
        let o = coapt(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    };
    with_ct("with-ct", &[]);
    let rep = json(&d.join("with-ct.json"));
    assert_eq!(
        rep["sinus_naming"]["by"], "coronary_ostia",
        "{}",
        rep["sinus_naming"]
    );
    let (origin, axis) = (point(&rep["origin_mm"]), point(&rep["axis"]).coords);
    let off_axis = |name: &str| {
        let s = rep["sinuses"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["name"] == name)
            .unwrap();
        let r = point(&s["ostium"]["point_mm"]) - origin;
        r - axis * r.dot(&axis)
    };
    let (right, left) = (off_axis("right_coronary"), off_axis("left_coronary"));
    eprintln!("real CT ostia off the axis: right {right:?}, left {left:?}");
    assert!(
        right.y < -0.8 * right.norm(),
        "right ostium not anterior: {right:?}"
    );
    assert!(
        left.x > 0.0 && left.y > 0.0,
        "left ostium not left-posterior: {left:?}"
    );
    // The hand-placed file numbers from the posterior sinus: its points,
    // given back, are described by where they lie, not by their labels
    // (its N1 lies in the left-coronary sinus, its N3 in the right).
    with_ct("given", &["--given", &s(&real.join("landmarks.mrk.json"))]);
    let mrk = json(&d.join("given.mrk.json"));
    let description = |label: &str| {
        mrk["markups"][0]["controlPoints"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["label"] == label)
            .unwrap()["description"]
            .as_str()
            .unwrap()
            .to_string()
    };
    assert!(description("N1").starts_with("nadir of the left-coronary sinus (given"));
    assert!(description("N2").starts_with("nadir of the non-coronary sinus (given"));
    assert!(description("N3").starts_with("nadir of the right-coronary sinus (given"));
    assert!(description("C1").contains("between the right-coronary and left-coronary"));
    // Leaflet k is sewn between that file's C_k and C_k+1: its sinus by
    // where they lie (with the detected points: right, left, non).
    assert_eq!(
        json(&d.join("given.json"))["leaflet_sinuses"],
        serde_json::json!(["left_coronary", "non_coronary", "right_coronary"])
    );
    assert_eq!(
        rep["leaflet_sinuses"],
        serde_json::json!(["right_coronary", "left_coronary", "non_coronary"])
    );
}
