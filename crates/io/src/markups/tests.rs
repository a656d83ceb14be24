use std::path::{Path, PathBuf};

use super::*;
use crate::scratch::{Scratch, scratch};
use coapt_base::rng::SplitMix64;

fn tmpdir(tag: &str) -> Scratch {
    scratch(&format!("markups-{tag}"))
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/markups")
        .join(name)
}

/// Six landmarks with coordinates over many magnitudes (and a signed zero),
/// the values most likely to expose a lossy float path.
fn random_landmarks(seed: u64, frame: Frame) -> Landmarks {
    let mut r = SplitMix64::new(seed);
    let mut lm = Landmarks::new(frame);
    for (i, label) in ["C1", "C2", "C3", "N1", "N2", "N3"].iter().enumerate() {
        let mut c = || r.range(-400.0, 400.0) * 10f64.powi((r.uniform() * 9.0) as i32 - 6);
        let mut p = [c(), c(), c()];
        if i == 0 {
            p[1] = -0.0;
        }
        lm.push(*label, Point3::from(p));
    }
    lm
}

/// Bitwise equality: `==` would accept 0.0 for -0.0.
fn assert_same_bits(a: &Landmarks, b: &Landmarks) {
    assert_eq!(a.frame, b.frame);
    assert_eq!(a.points.len(), b.points.len());
    for ((la, pa), (lb, pb)) in a.points.iter().zip(&b.points) {
        assert_eq!(la, lb);
        for k in 0..3 {
            assert_eq!(
                pa[k].to_bits(),
                pb[k].to_bits(),
                "{la}[{k}]: {} vs {}",
                pa[k],
                pb[k]
            );
        }
    }
}

fn write_text(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn err_of(path: &Path) -> String {
    match read(path) {
        Ok(lm) => panic!("{} was accepted: {lm:?}", path.display()),
        Err(e) => e.to_string(),
    }
}

fn assert_err(path: &Path, words: &[&str]) {
    let msg = err_of(path);
    for w in words {
        assert!(msg.contains(w), "message lacks {w:?}: {msg}");
    }
    let name = path.file_name().unwrap().to_string_lossy();
    assert!(
        msg.contains(name.as_ref()),
        "message does not name the file: {msg}"
    );
}

/// The C1..C3 of every fixture, in LPS.
fn fixture_commissures() -> [[f64; 3]; 3] {
    [
        [12.25, -140.5, -310.0],
        [-3.1000000000000005, -152.75, -305.5],
        [-8.5, -131.0, -303.25],
    ]
}

fn assert_commissures(lm: &Landmarks) {
    assert_eq!(lm.frame, Frame::Lps);
    let c = lm.require(&["C1", "C2", "C3"]).unwrap();
    for (got, want) in c.iter().zip(fixture_commissures()) {
        assert_eq!([got.x, got.y, got.z], want);
    }
}

#[test]
fn mrk_json_round_trip_exact_in_both_frames() {
    let d = tmpdir("rt-mrk");
    for seed in 0..20 {
        let lm = random_landmarks(seed, Frame::Lps);
        for frame in [Frame::Lps, Frame::Ras] {
            let p = d.join(format!("lm-{seed}-{frame}.mrk.json"));
            write_mrk_json(&p, &lm, frame).unwrap();
            assert_same_bits(&read(&p).unwrap(), &lm);
            // The file really holds `frame` coordinates, labelled as such.
            let v: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
            let m = &v["markups"][0];
            assert_eq!(m["coordinateSystem"], frame.name());
            let x0 = m["controlPoints"][0]["position"][0].as_f64().unwrap();
            let want = if frame == Frame::Ras {
                -lm.points[0].1.x
            } else {
                lm.points[0].1.x
            };
            assert_eq!(x0, want);
        }
    }
    // Landmarks held in RAS come back in LPS, converted exactly.
    let ras = random_landmarks(99, Frame::Ras);
    let p = d.join("from-ras.mrk.json");
    write_mrk_json(&p, &ras, Frame::Lps).unwrap();
    assert_same_bits(&read_mrk_json(&p).unwrap(), &ras.to_frame(Frame::Lps));
}

#[test]
fn fcsv_round_trip_exact_in_both_frames() {
    let d = tmpdir("rt-fcsv");
    for seed in 0..20 {
        let mut lm = random_landmarks(seed, Frame::Lps);
        lm.points[3].0 = "N1, \"left\"".to_string(); // needs CSV quoting
        for frame in [Frame::Lps, Frame::Ras] {
            let p = d.join(format!("lm-{seed}-{frame}.fcsv"));
            write_fcsv(&p, &lm, frame).unwrap();
            let text = std::fs::read_to_string(&p).unwrap();
            assert!(text.contains(&format!("# CoordinateSystem = {}", frame.name())));
            assert_same_bits(&read(&p).unwrap(), &lm);
        }
    }
}

#[test]
fn plain_json_round_trip_exact() {
    let d = tmpdir("rt-plain");
    for seed in 0..20 {
        let lm = random_landmarks(seed, Frame::Lps);
        let p = d.join(format!("lm-{seed}.json"));
        write_plain_json(&p, &lm).unwrap();
        assert_same_bits(&read(&p).unwrap(), &lm);
        assert_same_bits(&read_plain_json(&p).unwrap(), &lm);
    }
    // RAS landmarks are written as LPS.
    let ras = random_landmarks(5, Frame::Ras);
    let p = d.join("ras.json");
    write_plain_json(&p, &ras).unwrap();
    assert!(
        std::fs::read_to_string(&p)
            .unwrap()
            .contains("\"coordinate_system\": \"LPS\"")
    );
    assert_same_bits(&read(&p).unwrap(), &ras.to_frame(Frame::Lps));
}

#[test]
fn written_mrk_json_has_what_slicer_expects() {
    let lm = random_landmarks(1, Frame::Lps);
    let v: Value = serde_json::from_str(&encode_mrk_json(&lm, Frame::Ras)).unwrap();
    assert_eq!(v["@schema"], mrk_json::SCHEMA);
    assert_eq!(v["markups"].as_array().unwrap().len(), 1);
    let m = &v["markups"][0];
    assert_eq!(m["type"], "Fiducial");
    assert_eq!(m["coordinateUnits"], "mm");
    assert_eq!(m["display"]["visibility"], true);
    let cps = m["controlPoints"].as_array().unwrap();
    assert_eq!(cps.len(), 6);
    let cp = &cps[2];
    assert_eq!(cp["id"], "3");
    assert_eq!(cp["label"], "C3");
    assert_eq!(cp["associatedNodeID"], "");
    assert_eq!(cp["orientation"].as_array().unwrap().len(), 9);
    assert_eq!(
        (&cp["selected"], &cp["locked"], &cp["visibility"]),
        (&Value::Bool(true), &Value::Bool(false), &Value::Bool(true))
    );
    assert_eq!(cp["positionStatus"], "defined");
}

#[test]
fn reads_slicer5_file_with_two_lists_and_placeholders() {
    let lm = read(&fixture("slicer5_two_lists_ras.mrk.json")).unwrap();
    assert_commissures(&lm);
    // The undefined C3 in the first list and the missing N3 are skipped;
    // labels are trimmed (" C2 ").
    let labels: Vec<&str> = lm.points.iter().map(|(l, _)| l.as_str()).collect();
    assert_eq!(labels, ["C1", "C2", "C3", "N1", "N2"]);
    assert_eq!(lm.get("N2").unwrap(), Point3::new(-6.0, -147.0, -320.5));
    // A caller needing all nadirs gets a message that says what is there.
    let e = lm
        .require(&["C1", "C2", "C3", "N1", "N2", "N3"])
        .unwrap_err()
        .to_string();
    assert_eq!(e, "missing landmark N3 (found: C1, C2, C3, N1, N2)");
}

#[test]
fn reads_fcsv_from_each_slicer_generation() {
    // 4.6: no CoordinateSystem line → RAS.
    assert_commissures(&read(&fixture("slicer4_6_no_cs.fcsv")).unwrap());
    // 4.10: numeric code 0 → RAS.
    assert_commissures(&read(&fixture("slicer4_10_code0.fcsv")).unwrap());
    // 4.11: LPS by name, a quoted description with a comma.
    let lm = read_fcsv(&fixture("slicer4_11_lps.fcsv")).unwrap();
    assert_commissures(&lm);
    assert_eq!(lm.get("N1").unwrap(), Point3::new(4.0, -138.0, -321.0));
}

#[test]
fn fcsv_columns_header_code_1_and_crlf() {
    let d = tmpdir("fcsv-cols");
    let text = "# CoordinateSystem = 1\r\n# columns = label,x,y,z,id\r\n\"C1\",12.25,-140.5,-310,1\r\n\
                \"C,2\",-3.1000000000000005,-152.75,-305.5,2\r\n\r\nC3 ,-8.5,-131,-303.25,3\r\n";
    let lm = read(&write_text(&d, "cols.fcsv", text)).unwrap();
    let labels: Vec<&str> = lm.points.iter().map(|(l, _)| l.as_str()).collect();
    assert_eq!(labels, ["C1", "C,2", "C3"]);
    assert_eq!(lm.get("C3").unwrap(), Point3::new(-8.5, -131.0, -303.25));
}

#[test]
fn mrk_json_defaults_and_frame_spelling() {
    let d = tmpdir("mrk-defaults");
    let doc = |cs: &str| {
        format!(
            r#"{{"markups": [{{"type": "Line", "controlPoints": [{{"label": "L", "position": [1, 1, 1]}}]}},
                {{"type": "Fiducial", {cs} "controlPoints": [{{"label": "C1", "position": [1, 2, 3]}}]}}]}}"#
        )
    };
    // No coordinateSystem: LPS, as Slicer assumes. Line markups are ignored.
    let lm = read(&write_text(&d, "a.mrk.json", &doc(""))).unwrap();
    assert_eq!(
        lm.points,
        vec![("C1".to_string(), Point3::new(1.0, 2.0, 3.0))]
    );
    // Lower-case "ras", and a .json sniffed as Slicer markups.
    let lm = read(&write_text(
        &d,
        "b.json",
        &doc(r#""coordinateSystem": "ras", "coordinateUnits": "mm","#),
    ))
    .unwrap();
    assert_eq!(lm.get("C1").unwrap(), Point3::new(-1.0, -2.0, 3.0));
}

#[test]
fn plain_json_object_form_and_ras() {
    let d = tmpdir("plain-obj");
    let p = write_text(
        &d,
        "lm.json",
        r#"{"coordinate_system": "RAS", "points": {"C2": [1, 2, 3], "C1": [-4.5, 0.25, 7]}}"#,
    );
    let lm = read_plain_json(&p).unwrap();
    assert_eq!(lm.get("C1").unwrap(), Point3::new(4.5, -0.25, 7.0));
    assert_eq!(lm.get("C2").unwrap(), Point3::new(-1.0, -2.0, 3.0));
}

#[test]
fn bad_input_is_refused_with_a_useful_message() {
    let d = tmpdir("bad");
    let mrk = |cps: &str| {
        format!(
            r#"{{"markups": [{{"type": "Fiducial", "coordinateSystem": "LPS", "controlPoints": [{cps}]}}]}}"#
        )
    };
    let c1 = r#"{"label": "C1", "position": [0, 0, 0]}"#;

    let p = write_text(
        &d,
        "nonnum.mrk.json",
        &mrk(&format!(
            r#"{c1}, {{"label": "C2", "position": [1.0, "abc", 3]}}"#
        )),
    );
    assert_err(
        &p,
        &[r#"control point 'C2': position [1.0, "abc", 3] is not three numbers"#],
    );

    let p = write_text(
        &d,
        "short.mrk.json",
        &mrk(r#"{"label": "C2", "position": [1.0, 2.0]}"#),
    );
    assert_err(
        &p,
        &[
            "control point 'C2'",
            "[1.0, 2.0] has 2 numbers, expected three",
        ],
    );

    let p = write_text(
        &d,
        "nan.mrk.json",
        &mrk("{\"label\": \"C2\",\n \"position\": [NaN, 2.0, 3]}"),
    );
    assert_err(&p, &["malformed JSON", "line 2", "NaN", "finite"]);

    let p = write_text(
        &d,
        "inf.json",
        r#"{"points": [{"label": "C1", "position_mm": [1e999, 0, 0]}]}"#,
    );
    assert_err(&p, &["out of range", "finite"]);

    let p = write_text(
        &d,
        "nan.fcsv",
        "# CoordinateSystem = LPS\n1,nan,0,0,0,0,0,1,1,1,0,C1,,\n",
    );
    assert_err(&p, &["control point 'C1' (line 2)", "non-finite"]);

    let p = write_text(
        &d,
        "inf.fcsv",
        "1,0,inf,0,0,0,0,1,1,1,0,C1,,\n2,0,1,x,0,0,0,1,1,1,0,C2,,\n",
    );
    assert_err(&p, &["control point 'C1'", "non-finite"]);

    let p = write_text(&d, "word.fcsv", "2,0,1,x,0,0,0,1,1,1,0,C2,,\n");
    assert_err(
        &p,
        &[
            "control point 'C2' (line 1)",
            "[0, 1, x] is not three numbers",
        ],
    );

    let p = write_text(
        &d,
        "dup.mrk.json",
        &format!(
            r#"{{"markups": [{{"type": "Fiducial", "controlPoints": [{c1}]}}, {{"type": "Fiducial", "controlPoints": [{c1}]}}]}}"#
        ),
    );
    assert_err(
        &p,
        &[
            "duplicate label 'C1'",
            "markup 1, control point 1",
            "markup 2, control point 1",
            "unique",
        ],
    );

    let p = write_text(
        &d,
        "dup.fcsv",
        "1,0,0,0,0,0,0,1,1,1,0,C1,,\n2,0,0,1,0,0,0,1,1,1,0, C1,,\n",
    );
    assert_err(&p, &["duplicate label 'C1'", "line 1", "line 2"]);

    let p = write_text(&d, "cs.mrk.json", &mrk(c1).replace("\"LPS\"", "\"XYZ\""));
    assert_err(
        &p,
        &[
            "markup 1: coordinateSystem",
            "unknown coordinate system \"XYZ\"",
            "\"LPS\" or \"RAS\"",
        ],
    );

    let p = write_text(
        &d,
        "cs.json",
        r#"{"coordinate_system": "RAI", "points": []}"#,
    );
    assert_err(&p, &["unknown coordinate system \"RAI\""]);

    let p = write_text(
        &d,
        "units.mrk.json",
        &mrk(c1).replace(
            "\"coordinateSystem\"",
            "\"coordinateUnits\": \"um\", \"coordinateSystem\"",
        ),
    );
    assert_err(&p, &["coordinateUnits \"um\" is not supported", "mm"]);

    let p = write_text(
        &d,
        "broken.mrk.json",
        "{\n  \"markups\": [\n    {\"type\": \"Fiducial\",,}\n]}",
    );
    assert_err(&p, &["malformed JSON", "line 3 column"]);

    let p = write_text(&d, "other.mrk.json", r#"{"nodes": []}"#);
    assert_err(&p, &["not a 3D Slicer markups file", "\"markups\""]);

    let p = write_text(&d, "other.json", r#"[1, 2, 3]"#);
    assert_err(&p, &["not a landmarks file", "position_mm"]);

    let p = write_text(
        &d,
        "lines.mrk.json",
        r#"{"markups": [{"type": "Line", "controlPoints": []}]}"#,
    );
    assert_err(&p, &["no point list", "Line"]);

    let p = write_text(
        &d,
        "nolabel.mrk.json",
        &mrk(r#"{"label": "  ", "position": [0, 0, 0]}"#),
    );
    assert_err(&p, &["markup 1, control point 1 has no label"]);

    let p = write_text(
        &d,
        "status.mrk.json",
        &mrk(r#"{"label": "C1", "position": [0, 0, 0], "positionStatus": "maybe"}"#),
    );
    assert_err(
        &p,
        &["control point 'C1'", "unknown positionStatus \"maybe\""],
    );

    let p = write_text(
        &d,
        "ijk.fcsv",
        "# CoordinateSystem = 2\n1,0,0,0,0,0,0,1,1,1,0,C1,,\n",
    );
    assert_err(&p, &["line 1", "IJK", "LPS or RAS"]);

    let p = write_text(&d, "few.fcsv", "1,0,0,0,0,0,0,1,1,1,0\n");
    assert_err(&p, &["line 1 has 11 fields", "at least 12"]);

    let p = write_text(&d, "cols.fcsv", "# columns = id,x,y,z\n1,0,0,0\n");
    assert_err(&p, &["no 'label' column"]);

    let p = write_text(&d, "lm.txt", "C1 0 0 0\n");
    assert_err(&p, &["unknown landmark file type", ".mrk.json"]);

    let missing = d.join("absent.mrk.json");
    assert!(err_of(&missing).contains("cannot read"));
}

#[test]
fn writers_refuse_what_they_cannot_write_faithfully() {
    let d = tmpdir("bad-write");
    let mut lm = random_landmarks(3, Frame::Lps);
    lm.points[1].1.x = f64::NAN;
    let p = d.join("nan.mrk.json");
    assert!(
        write_mrk_json(&p, &lm, Frame::Lps)
            .unwrap_err()
            .to_string()
            .contains("non-finite")
    );
    assert!(!p.exists());
    let mut lm = random_landmarks(3, Frame::Lps);
    lm.points[1].0 = "C1".to_string();
    assert!(
        write_fcsv(&d.join("dup.fcsv"), &lm, Frame::Ras)
            .unwrap_err()
            .to_string()
            .contains("more than once")
    );
    assert!(write_plain_json(&d.join("dup.json"), &lm).is_err());
}

/// Hands a landmarks file written by this writer to `tools/phantom_crosscheck.py`.
/// With COAPT_MRK_XCHECK_DIR set, converts `$DIR/landmarks_lps.json` (plain,
/// written by the test-directory builder) into `$DIR/landmarks.mrk.json`,
/// stored in RAS so that the Python side also checks the frame conversion.
/// Without it, does the same on a temporary directory.
#[test]
fn writes_landmarks_for_the_python_cross_check() {
    let scratch;
    let dir = match std::env::var_os("COAPT_MRK_XCHECK_DIR") {
        Some(d) => PathBuf::from(d),
        None => {
            scratch = tmpdir("xcheck");
            let d = scratch.to_path_buf();
            write_plain_json(
                &d.join("landmarks_lps.json"),
                &random_landmarks(7, Frame::Lps),
            )
            .unwrap();
            d
        }
    };
    let lm = read_plain_json(&dir.join("landmarks_lps.json")).unwrap();
    lm.require(&["C1", "C2", "C3"]).unwrap();
    let out = dir.join("landmarks.mrk.json");
    write_mrk_json(&out, &lm, Frame::Ras).unwrap();
    assert_same_bits(&read(&out).unwrap(), &lm);
}
