//! `coapt bench close --grid`: the run-time-against-error grid on the
//! committed sample, on coarse meshes only (the full grid is a benchmark).

use std::collections::BTreeMap;

use crate::common::*;

/// The CSV as one map per row, keyed by the header.
fn rows(text: &str) -> Vec<BTreeMap<String, String>> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| {
            // The last column (reason) is quoted and may hold commas.
            let (head, reason) = l.split_once(",\"").unwrap();
            let mut cells: Vec<String> = head.split(',').map(str::to_string).collect();
            cells.push(reason.trim_end_matches('"').to_string());
            assert_eq!(cells.len(), header.len(), "{l}");
            header.iter().map(|h| h.to_string()).zip(cells).collect()
        })
        .collect()
}

fn num(r: &BTreeMap<String, String>, k: &str) -> f64 {
    r[k].parse()
        .unwrap_or_else(|_| panic!("{k} = '{}' is not a number", r[k]))
}

#[test]
fn bench_close_grid_on_coarse_sample_meshes() {
    let dir = tmpdir("close-grid");
    let (csv, png) = (dir.join("grid.csv"), dir.join("grid.png"));
    let o = coapt(&[
        "bench",
        "close",
        "--grid",
        "--sample",
        &s(&repo().join("sample_data")),
        "--hs",
        "3,2",
        "--models",
        "goh",
        "--solvers",
        "newton,combined",
        "--time-limit",
        "60",
        "--csv",
        &s(&csv),
        "--png",
        &s(&png),
        "--work",
        &s(&dir.join("work")),
        "--threads",
        "2",
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let rows = rows(&std::fs::read_to_string(&csv).unwrap());
    assert_eq!(rows.len(), 4);
    for r in &rows {
        assert_eq!(
            (
                r["case"].as_str(),
                r["model"].as_str(),
                r["contact"].as_str()
            ),
            ("sample", "goh", "planes")
        );
        assert_eq!(r["status"], "converged", "{r:?}");
        // Three leaflets at h = 3 mm have a few hundred nodes.
        assert!(num(r, "nodes") > 100.0 && num(r, "nodes") < 1000.0, "{r:?}");
        // The reference is the finest converged Newton closure.
        assert_eq!(r["reference"], "newton planes h 2 mm");
        let h = num(r, "coaptation_height_mm");
        let central = num(r, "central_coaptation_height_mm");
        assert!(
            h > 1.0 && h < 20.0 && central > 0.0 && central <= h,
            "{r:?}"
        );
        assert!(num(r, "coaptation_area_mm2") > 10.0);
    }
    let is_ref: Vec<&BTreeMap<String, String>> = rows
        .iter()
        .filter(|r| r["is_reference"] == "true")
        .collect();
    assert_eq!(is_ref.len(), 1);
    let r = is_ref[0];
    assert_eq!((r["solver"].as_str(), num(r, "h_mm")), ("newton", 2.0));
    for k in [
        "err_coaptation_height_mm",
        "err_central_coaptation_height_mm",
        "err_coaptation_area_mm2",
        "disp_err_rms_mm",
        "disp_err_max_mm",
    ] {
        assert_eq!(num(r, k), 0.0, "reference row {k}");
    }
    // The coarse mesh closes differently: a real displacement error, and
    // bounded (a node that moved to a different place would show cm).
    // Suturing turns a first row of triangles h wide, so h 3 and h 2
    // differ by millimetres next to the suture line (3.4 mm measured).
    let coarse = rows
        .iter()
        .find(|r| r["solver"] == "newton" && r["h_mm"] == "3")
        .unwrap();
    let (rms, max) = (
        num(coarse, "disp_err_rms_mm"),
        num(coarse, "disp_err_max_mm"),
    );
    assert!(rms > 0.0 && rms <= max && max < 5.0, "{rms} {max}");
    // Two converged solvers on one mesh: from the sutured (bellied) start
    // relaxation and Newton settle into nearby but different folds at
    // h 2 mm (bending length ≈ 1 mm < h): 1.7 mm apart at most, 0.16 mm
    // RMS, coaptation heights within 0.04 mm. Before suturing they met to
    // 1e-3 mm. The grid measures both; this pins that they stay close.
    let same = rows
        .iter()
        .find(|r| r["solver"] == "combined" && r["h_mm"] == "2")
        .unwrap();
    assert!(num(same, "disp_err_rms_mm") < 0.5, "{same:?}");
    assert!(num(same, "disp_err_max_mm") < 3.0, "{same:?}");
    assert!(
        num(same, "err_coaptation_height_mm").abs() < 0.2,
        "{same:?}"
    );

    // A PNG: signature, then IHDR with the chart's size.
    let b = std::fs::read(&png).unwrap();
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&b[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes(b[i..i + 4].try_into().unwrap());
    assert_eq!((be(16), be(20)), (960, 640));
    assert!(b.len() > 10_000, "a chart, not an empty picture");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bench_close_grid_refuses_bad_flags_with_exit_2() {
    let dir = tmpdir("close-grid-bad");
    let (csv, png) = (s(&dir.join("g.csv")), s(&dir.join("g.png")));
    let out = ["--csv", csv.as_str(), "--png", png.as_str()];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--grid", "--csv", &csv], "--png"),
        (vec!["--grid", "--hs", "3,-1"], "0.05 to 10 mm"),
        (vec!["--grid", "--hs", "3,x"], "x"),
        (vec!["--grid", "--models", "svk"], "svk"),
        (vec!["--grid", "--solvers", "euler"], "euler"),
        (vec!["--grid", "--time-limit", "0"], "time-limit"),
        (vec!["--hs", "3"], "--grid"),
        (vec!["--case", "sample"], "--grid"),
        (vec!["--grid", "--h", "1"], "--hs"),
        (
            vec![
                "--grid",
                "--case",
                "ozaki-cylinder",
                "--contacts",
                "leaflets",
            ],
            "leaflet",
        ),
        (
            vec!["--grid", "--sample", "/nonexistent/sample"],
            "/nonexistent/sample",
        ),
    ];
    for (args, word) in cases {
        let mut a = vec!["bench", "close"];
        a.extend(&args);
        if args.contains(&"--grid") && !args.contains(&"--csv") {
            a.extend(out);
        }
        let o = coapt(&a);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{a:?}: {err}");
        assert!(err.contains(word), "{a:?}: error lacks '{word}': {err}");
    }
    assert!(!dir.join("g.csv").exists() && !dir.join("g.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
