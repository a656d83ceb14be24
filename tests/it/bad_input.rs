//! Bad input never panics: one line naming the file and the problem, exit 2,
//! and nothing left behind.

use std::path::{Path, PathBuf};

use coapt::geom::volume::affine_from_parts;
use coapt::geom::{Matrix3, Point3, Volume};

use crate::common::*;

fn small_ct(dir: &Path, name: &str) -> PathBuf {
    let a = affine_from_parts(
        [0.5, 0.5, 0.8],
        &Matrix3::identity(),
        Point3::new(1.0, 2.0, 3.0),
    );
    let v = Volume::from_fortran_vec([6, 5, 4], a, (0..120).map(|x| x as i16).collect()).unwrap();
    let p = dir.join(name);
    coapt::io::nifti::write(&p, &v).unwrap();
    p
}

/// `coapt STAGE --flag value …` from (flag, value) pairs.
fn stage_args(stage: &str, pairs: &[(&str, String)]) -> Vec<String> {
    let mut a = vec![stage.to_string()];
    for (f, v) in pairs {
        a.push(format!("--{f}"));
        a.push(v.clone());
    }
    a
}

fn patch(path: &Path, offset: usize, bytes: &[u8]) {
    let mut b = std::fs::read(path).unwrap();
    b[offset..offset + bytes.len()].copy_from_slice(bytes);
    std::fs::write(path, b).unwrap();
}

/// `info` and `convert` both refuse the file; `convert` leaves no output.
fn refused(file: &Path, words: &[&str]) {
    let o = coapt(&["info", file.to_str().unwrap()]);
    assert_bad_input(&o, file, words);
    let dir = file.parent().unwrap();
    let before = entries(dir);
    let out = dir.join("converted.nii.gz");
    let o = coapt(&["convert", file.to_str().unwrap(), out.to_str().unwrap()]);
    assert_bad_input(&o, file, words);
    assert_eq!(entries(dir), before, "convert left something behind");
}

#[test]
fn truncated_nii_gz() {
    let d = tmpdir("trunc");
    let p = small_ct(&d, "ct.nii.gz");
    let b = std::fs::read(&p).unwrap();
    std::fs::write(&p, &b[..b.len() / 2]).unwrap();
    refused(&p, &["truncated"]);
}

#[test]
fn header_claiming_a_trillion_trillion_voxels() {
    // A NIfTI-2 header (64-bit dims) claiming 10^6 × 10^6 × 10^6 int16 voxels.
    let d = tmpdir("huge");
    let mut h = vec![0u8; 544];
    h[0..4].copy_from_slice(&540i32.to_le_bytes());
    h[4..12].copy_from_slice(b"n+2\0\r\n\x1a\n");
    h[12..14].copy_from_slice(&4i16.to_le_bytes());
    h[14..16].copy_from_slice(&16i16.to_le_bytes());
    let dims = [3i64, 1_000_000, 1_000_000, 1_000_000, 1, 1, 1, 1];
    for (i, v) in dims.iter().enumerate() {
        h[16 + 8 * i..24 + 8 * i].copy_from_slice(&v.to_le_bytes());
    }
    for i in 0..8 {
        h[104 + 8 * i..112 + 8 * i].copy_from_slice(&1f64.to_le_bytes());
    }
    h[168..176].copy_from_slice(&544i64.to_le_bytes());
    let p = d.join("huge.nii");
    std::fs::write(&p, h).unwrap();
    refused(&p, &["claims 1000000 voxels", "corrupt"]);
}

#[test]
fn nan_pixdim() {
    let d = tmpdir("nanpix");
    let p = small_ct(&d, "ct.nii");
    patch(&p, 80, &f32::NAN.to_le_bytes());
    refused(&p, &["pixdim"]);
}

#[test]
fn pixdim0_zero_with_qform_only() {
    let d = tmpdir("qfac");
    let p = small_ct(&d, "ct.nii");
    patch(&p, 254, &0i16.to_le_bytes()); // sform_code = 0: the qform decides
    patch(&p, 76, &0f32.to_le_bytes()); // pixdim[0] (qfac) = 0
    refused(&p, &["pixdim[0]"]);
}

#[test]
fn four_d_volume() {
    let d = tmpdir("4d");
    let p = small_ct(&d, "ct.nii");
    patch(&p, 40, &4i16.to_le_bytes());
    patch(&p, 48, &5i16.to_le_bytes());
    refused(&p, &["4-D"]);
}

#[test]
fn landmarks_without_commissures() {
    let d = tmpdir("nocomm");
    let p = d.join("lm.mrk.json");
    std::fs::write(
        &p,
        r#"{"@schema": "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/Schema/markups-schema-v1.0.3.json#",
            "markups": [{"type": "Fiducial", "coordinateSystem": "LPS", "controlPoints": [
              {"id": "1", "label": "N1", "position": [1.0, 2.0, 3.0]},
              {"id": "2", "label": "C2", "position": [4.0, 5.0, 6.0]}]}]}"#,
    )
    .unwrap();
    // `coapt run` completes such a file, so `check` lets it pass and says
    // so; the valve stage on its own needs the commissures.
    let o = coapt(&["check", "--landmarks", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("`coapt run` finds the others"),
        "{}",
        stdout(&o)
    );
    let surface = repo().join("sample_data/truth_surface.vtp");
    let o = coapt(&[
        "valve",
        "--surface",
        &s(&surface),
        "--landmarks",
        &s(&p),
        "--out",
        &s(&d.join("valve.json")),
        "--paths",
        &s(&d.join("paths.vtp")),
    ]);
    assert_bad_input(&o, &p, &["C1", "C3"]);
    assert!(!d.join("valve.json").exists());
}

#[test]
fn landmarks_with_non_numeric_position() {
    let d = tmpdir("nonnum");
    let p = d.join("lm.mrk.json");
    std::fs::write(
        &p,
        r#"{"markups": [{"type": "Fiducial", "coordinateSystem": "LPS", "controlPoints": [
              {"id": "1", "label": "C1", "position": [1.0, "abc", 3.0]}]}]}"#,
    )
    .unwrap();
    let o = coapt(&["check", "--landmarks", p.to_str().unwrap()]);
    assert_bad_input(&o, &p, &["C1", "position"]);
    let o = coapt(&["info", p.to_str().unwrap()]);
    assert_bad_input(&o, &p, &["C1", "position"]);
}

#[test]
fn vtp_with_triangles_indexing_missing_points() {
    let d = tmpdir("vtpidx");
    let p = d.join("bad.vtp");
    std::fs::write(
        &p,
        r#"<?xml version="1.0"?>
<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian">
<PolyData><Piece NumberOfPoints="3" NumberOfPolys="1">
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">0 0 0 1 0 0 0 1 0</DataArray></Points>
<Polys><DataArray type="Int64" Name="connectivity" format="ascii">0 1 7</DataArray>
<DataArray type="Int64" Name="offsets" format="ascii">3</DataArray></Polys>
</Piece></PolyData></VTKFile>
"#,
    )
    .unwrap();
    let o = coapt(&["info", p.to_str().unwrap()]);
    assert_bad_input(&o, &p, &["point 7"]);
    let before = entries(&d);
    let out = d.join("out.stl");
    let o = coapt(&["convert", p.to_str().unwrap(), out.to_str().unwrap()]);
    assert_bad_input(&o, &p, &["point 7"]);
    assert_eq!(entries(&d), before);
}

#[test]
fn config_with_a_bare_number_for_a_quantity() {
    let d = tmpdir("bare");
    let cfg = d.join("run.toml");
    std::fs::write(&cfg, "[phantom]\npreset = \"sample\"\ntilt = 35\n").unwrap();
    let out = d.join("run");
    let o = coapt(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_bad_input(
        &o,
        &cfg,
        &["phantom.tilt", "bare number 35", "angle", "deg"],
    );
    assert!(
        !out.exists(),
        "a refused config must not create the run directory"
    );
}

#[test]
fn cli_value_without_unit() {
    let d = tmpdir("cliunit");
    let o = coapt(&[
        "phantom",
        "--out",
        d.join("p").to_str().unwrap(),
        "--noise",
        "25",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("--noise 25") && err.contains("HU"), "{err}");
    assert!(!d.join("p").exists());
}

#[test]
fn missing_file_and_unknown_format() {
    let d = tmpdir("missing");
    let p = d.join("nope.nii.gz");
    let o = coapt(&["info", p.to_str().unwrap()]);
    assert_bad_input(&o, &p, &[]);
    let q = d.join("data.xyz");
    std::fs::write(&q, b"hello").unwrap();
    let o = coapt(&["info", q.to_str().unwrap()]);
    assert_bad_input(&o, &q, &["format"]);
}

#[test]
fn out_of_range_parameters_fail_before_any_work() {
    let d = tmpdir("range");
    let cfg = d.join("run.toml");
    std::fs::write(&cfg, "[phantom]\ntilt = \"70 deg\"\n").unwrap();
    let out = d.join("run");
    let o = coapt(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_bad_input(&o, &cfg, &["phantom", "tilt", "70 deg", "[0, 60] deg"]);
    assert!(!out.exists());

    let o = coapt(&[
        "phantom",
        "--out",
        out.to_str().unwrap(),
        "--spacing",
        "0.1, 0.1, 0.1 mm",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("spacing") && !err.contains("running"), "{err}");
    assert!(!out.exists());
}

/// A reader that stops early (`coapt info … | head -1`) ends coapt quietly,
/// never with a panic about the closed pipe. The read end is closed as soon
/// as coapt starts, long before it has read its input and printed.
#[test]
fn a_closed_stdout_is_not_a_panic() {
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_coapt"))
        .arg("info")
        .arg(repo().join("sample_data/ct.nii.gz"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
}

/// No stage writes over its own input, whether the output names the same
/// path, a symlink to it or a hard link: exit 2 before any work, the input
/// byte for byte as it was, nothing new beside it.
#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let d = tmpdir("no-overwrite");
    let ct = d.join("ct.nii.gz");
    std::fs::copy(repo().join("sample_data/ct.nii.gz"), &ct).unwrap();
    std::os::unix::fs::symlink(&ct, d.join("sym.nii.gz")).unwrap();
    std::fs::hard_link(&ct, d.join("hard.nii.gz")).unwrap();
    let before = std::fs::read(&ct).unwrap();
    let listing = entries(&d);
    let lm = repo().join("sample_data/landmarks.mrk.json");
    for out in ["ct.nii.gz", "sym.nii.gz", "hard.nii.gz"] {
        let o = coapt(&[
            "segment",
            "--ct",
            ct.to_str().unwrap(),
            "--landmarks",
            lm.to_str().unwrap(),
            "--out",
            d.join(out).to_str().unwrap(),
        ]);
        assert_bad_input(
            &o,
            &d.join(out),
            &["--out", "--ct", "never writes over an input"],
        );
        assert_eq!(
            std::fs::read(&ct).unwrap(),
            before,
            "--out {out} changed the CT"
        );
        assert_eq!(entries(&d), listing, "--out {out} left something behind");
    }
}

/// Sizes that imply absurd work are refused before it, naming the option,
/// what it would cost and the bound: the leaflet mesh size (8 GiB before),
/// the suture paths' spacing (568 GB) and the report's column width (past
/// 120 s).
#[test]
fn sizes_that_imply_absurd_work_are_refused_before_it() {
    let d = tmpdir("absurd-sizes");
    let surface = sample_valve_and_leaflets(&d, "pipelines/templates/ozaki_default.toml", &[]);
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let template = s(&repo().join("pipelines/templates/ozaki_default.toml"));
    let landmarks = s(&repo().join("sample_data/landmarks.mrk.json"));
    let (valve, paths, leaflets) = (
        s(&d.join("valve.json")),
        s(&d.join("paths.vtp")),
        s(&d.join("leaflets.vtp")),
    );
    let cases: [(Vec<String>, &[&str]); 3] = [
        (
            stage_args(
                "leaflets",
                &[
                    ("valve", valve.clone()),
                    ("paths", paths),
                    ("surface", s(&surface)),
                    ("template", template),
                    ("out", s(&d.join("fine/leaflets.vtp"))),
                    ("h", "0.001 mm".into()),
                ],
            ),
            &["--h 0.001 mm", "nodes", "1e6"],
        ),
        (
            stage_args(
                "valve",
                &[
                    ("surface", s(&surface)),
                    ("landmarks", landmarks),
                    ("out", s(&d.join("fine/valve.json"))),
                    ("spacing", "1e-9 mm".into()),
                ],
            ),
            &["--spacing", "points", "0.01–5 mm"],
        ),
        (
            stage_args(
                "report",
                &[
                    ("closed", leaflets.clone()),
                    ("leaflets", leaflets),
                    ("valve", valve),
                    ("out", s(&d.join("fine"))),
                    ("column-width", "1e-6 mm".into()),
                ],
            ),
            &["--column-width", "columns", "0.01 mm"],
        ),
    ];
    for (args, words) in cases {
        let o = coapt(&args.iter().map(String::as_str).collect::<Vec<_>>());
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{}: {err}", args[0]);
        for w in words {
            assert!(err.contains(w), "{}: no {w:?} in {err}", args[0]);
        }
        assert!(!d.join("fine").exists(), "{} wrote output", args[0]);
    }
}

/// Counts and sizes on the command line that set the work are bounded:
/// a million threads (a hang), 1e12 stress cases (an 8 TB allocation),
/// a 1e-6 mm benchmark mesh, a 1 km coaptation margin (every point
/// "coapting", exit 0) and a close.toml asking for 1e12 s are refused with
/// exit 2 and the range, before any output.
#[test]
fn counts_limits_and_margins_out_of_range_are_refused() {
    let d = tmpdir("absurd-counts");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let ct = s(&repo().join("sample_data/ct.nii.gz"));
    let out = d.join("out");
    let cases: [(Vec<String>, &[&str]); 7] = [
        (
            stage_args(
                "surface",
                &[
                    ("mask", s(&repo().join("sample_data/truth_mask.nii.gz"))),
                    ("out", s(&out.join("aorta.vtp"))),
                    ("target-edge", "0.05 mm".into()),
                ],
            ),
            &["--target-edge 0.05 mm", "triangles, more than 4e6"],
        ),
        (
            stage_args("phantom", &[("out", s(&out)), ("noise", "1e300 HU".into())]),
            &["--noise (phantom noise) = 1e300 HU is outside [0, 200] HU"],
        ),
        (
            stage_args(
                "segment",
                &[
                    ("ct", ct),
                    ("out", s(&out.join("m.nii.gz"))),
                    ("threads", "1000000".into()),
                ],
            ),
            &["--threads 1000000", "at most 1024"],
        ),
        (
            [
                "bench",
                "stress-close",
                "--cases",
                "1000000000000",
                "--csv",
                &s(&out.join("x.csv")),
            ]
            .map(String::from)
            .to_vec(),
            &["--cases", "1 to 100000"],
        ),
        (
            ["bench", "close", "--h", "1e-6"].map(String::from).to_vec(),
            &["--h", "0.05 to 10 mm"],
        ),
        (
            stage_args(
                "report",
                &[
                    ("closed", s(&repo().join("sample_data/ct.nii.gz"))),
                    ("leaflets", s(&repo().join("sample_data/ct.nii.gz"))),
                    ("valve", s(&repo().join("sample_data/landmarks.mrk.json"))),
                    ("out", s(&out)),
                    ("margin", "1e6 mm".into()),
                ],
            ),
            &["--margin 1000000 mm", "0.01 mm to 5 mm"],
        ),
        (
            {
                let cfg = d.join("close.toml");
                std::fs::write(
                    &cfg,
                    "model = \"neo-hookean\"\nmu = \"900 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\ntime_limit = \"1e12 s\"\n",
                )
                .unwrap();
                // Any triangle mesh passes the meshes' check; the config is refused.
                let mesh = s(&repo().join("sample_data/truth_surface.vtp"));
                stage_args(
                    "close",
                    &[
                        ("leaflets", mesh.clone()),
                        ("surface", mesh),
                        ("config", s(&cfg)),
                        ("out", s(&out.join("closed.vtp"))),
                    ],
                )
            },
            &["time_limit 1e12 s", "0–86400 s"],
        ),
    ];
    for (args, words) in cases {
        let o = coapt(&args.iter().map(String::as_str).collect::<Vec<_>>());
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{}: {err}", args.join(" "));
        for w in words {
            assert!(err.contains(w), "{}: no {w:?} in {err}", args.join(" "));
        }
        assert!(!err.contains("panicked"), "{err}");
        assert!(!out.exists(), "{} wrote output", args.join(" "));
    }
}

/// Absurd voxel spacings are refused at read, by `info` and `convert` and
/// so by every stage: 1e-6 mm sent the segmentation after 160 GB.
#[test]
fn absurd_voxel_spacings_are_refused_at_read() {
    let d = tmpdir("absurd-spacing");
    for (name, sp) in [
        ("tiny.nii.gz", [1e-6, 1e-6, 1e-6]),
        ("thin.nii.gz", [0.8, 0.8, 1e-5]),
        ("huge.nii.gz", [0.8, 80.0, 0.8]),
    ] {
        let a = affine_from_parts(sp, &Matrix3::identity(), Point3::new(1.0, 2.0, 3.0));
        let v =
            Volume::from_fortran_vec([6, 5, 4], a, (0..120).map(|x| x as i16).collect()).unwrap();
        let p = d.join(name);
        coapt::io::nifti::write(&p, &v).unwrap();
        refused(&p, &["voxel spacing", "0.01–50 mm"]);
        let out = d.join("mask.nii.gz");
        let o = coapt(&[
            "segment",
            "--ct",
            p.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_bad_input(&o, &p, &["voxel spacing"]);
        assert!(!out.exists());
    }
}

/// `leaflets`, `close` and `report` on the sample's files in `d` with
/// `valve` as their valve.json, every output under `d/out`.
fn stages_reading_valve(d: &Path, surface: &Path, valve: &Path) -> [Vec<String>; 3] {
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let leaflets = s(&d.join("leaflets.vtp"));
    [
        stage_args(
            "leaflets",
            &[
                ("valve", s(valve)),
                ("paths", s(&d.join("paths.vtp"))),
                ("surface", s(surface)),
                (
                    "template",
                    s(&repo().join("pipelines/templates/ozaki_default.toml")),
                ),
                ("out", s(&d.join("out/leaflets.vtp"))),
            ],
        ),
        stage_args(
            "close",
            &[
                ("leaflets", leaflets.clone()),
                ("surface", s(surface)),
                ("config", s(&repo().join("pipelines/close.toml"))),
                ("valve", s(valve)),
                ("out", s(&d.join("out/closed.vtp"))),
            ],
        ),
        stage_args(
            "report",
            &[
                ("closed", leaflets.clone()),
                ("leaflets", leaflets),
                ("valve", s(valve)),
                ("out", s(&d.join("out"))),
            ],
        ),
    ]
}

/// One reading of valve.json for every stage: a zero axis (leaflets moved
/// them 7.45 mm with exit 0 where the report refused) is refused by
/// leaflets, close and report alike; and `valve --hc 1000 mm` (72–90 mm
/// paths before) is refused before any work.
#[test]
fn a_zero_valve_axis_and_an_absurd_hc_are_refused_everywhere() {
    let d = tmpdir("zero-axis");
    let surface = sample_valve_and_leaflets(&d, "pipelines/templates/ozaki_default.toml", &[]);
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let mut v = json(&d.join("valve.json"));
    v["valve_frame"]["axis"] = serde_json::json!([0.0, 0.0, 0.0]);
    let bad = d.join("zero.json");
    std::fs::write(&bad, serde_json::to_string(&v).unwrap()).unwrap();
    let runs = stages_reading_valve(&d, &surface, &bad);
    for mut args in runs {
        args.push("--quiet".into());
        let o = coapt(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert_bad_input(&o, &bad, &["axis", "unit"]);
        assert!(!d.join("out").exists(), "{} wrote output", args[0]);
    }
    let args = stage_args(
        "valve",
        &[
            ("surface", s(&surface)),
            (
                "landmarks",
                s(&repo().join("sample_data/landmarks.mrk.json")),
            ),
            ("out", s(&d.join("out/valve.json"))),
            ("hc", "1000 mm".into()),
        ],
    );
    let o = coapt(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--hc 1000 mm"), "{}", stderr(&o));
    assert!(!d.join("out").exists());
}

/// One reading of the leaflet mesh for every stage: a leaflets.vtp whose
/// arrays are wrong (close took `boundary` 7 and `leaflet` 0 that the report
/// refused) is refused by close and report alike, naming the file and the
/// array, with nothing written.
#[test]
fn a_wrong_leaflet_mesh_is_refused_by_close_and_report_alike() {
    use coapt::geom::attributes::DataArray;
    let d = tmpdir("wrong-leaflets");
    let surface = sample_valve_and_leaflets(&d, "pipelines/templates/ozaki_default.toml", &[]);
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let good = coapt::io::vtp::read_mesh(&d.join("leaflets.vtp")).unwrap();
    let n = good.vertices.len();
    let breaks: [(&str, Box<dyn Fn(&mut coapt::geom::TriMesh)>, &str); 3] = [
        (
            "boundary7.vtp",
            Box::new(move |m| {
                let mut b = vec![0.0; n];
                b[5] = 7.0;
                m.point_data.insert(DataArray::scalars_f64("boundary", b));
            }),
            "'boundary' of point 5 is 7",
        ),
        (
            "leaflet0.vtp",
            Box::new(|m| {
                let k = vec![0.0; m.triangles.len()];
                m.cell_data.insert(DataArray::scalars_f64("leaflet", k));
            }),
            "'leaflet' of triangle 0 is 0",
        ),
        (
            "onefibre.vtp",
            Box::new(|m| {
                let f = vec![[1.0, 0.0, 0.0]; m.triangles.len()];
                m.cell_data.insert(DataArray::vectors_f64("fiber1", &f));
                m.cell_data.remove("fiber2");
            }),
            "'fiber1' and 'fiber2' come together",
        ),
    ];
    for (name, f, words) in breaks {
        let mut m = good.clone();
        f(&mut m);
        let bad = d.join(name);
        coapt::io::vtp::write_mesh(&bad, &m).unwrap();
        let out = d.join("out");
        let runs = [
            stage_args(
                "close",
                &[
                    ("leaflets", s(&bad)),
                    ("surface", s(&surface)),
                    ("config", s(&repo().join("pipelines/close.toml"))),
                    ("out", s(&out.join("closed.vtp"))),
                ],
            ),
            stage_args(
                "report",
                &[
                    ("closed", s(&d.join("leaflets.vtp"))),
                    ("leaflets", s(&bad)),
                    ("valve", s(&d.join("valve.json"))),
                    ("out", s(&out)),
                ],
            ),
        ];
        for mut args in runs {
            args.push("--quiet".into());
            let o = coapt(&args.iter().map(String::as_str).collect::<Vec<_>>());
            assert_bad_input(&o, &bad, &[words]);
            assert!(!out.exists(), "{} {name} wrote output", args[0]);
        }
    }
}

/// Landmarks that cannot belong to the scan are the bad input, named, with
/// exit 2 (segment said exit 1, "the computation failed"; ×1e300 reached
/// the valve stage's anatomy checks): off the CT by 300 mm, two commissures
/// coinciding, coordinates of 1e300 mm.
#[test]
fn landmarks_that_cannot_belong_to_the_scan_are_refused_by_name() {
    let d = tmpdir("foreign-landmarks");
    let text = std::fs::read_to_string(repo().join("sample_data/landmarks.mrk.json")).unwrap();
    let mut j: serde_json::Value = serde_json::from_str(&text).unwrap();
    fn points(j: &mut serde_json::Value) -> Vec<(String, &mut serde_json::Value)> {
        j["markups"][0]["controlPoints"]
            .as_array_mut()
            .unwrap()
            .iter_mut()
            .map(|c| (c["label"].as_str().unwrap().to_string(), c))
            .collect()
    }
    let c1 = points(&mut j)
        .into_iter()
        .find(|(l, _)| l == "C1")
        .map(|(_, c)| c["position"].clone())
        .unwrap();
    let mut cases = Vec::new();
    for (name, words) in [
        (
            "far.mrk.json",
            &["C1 at", "outside the CT's field of view"][..],
        ),
        ("same.mrk.json", &["collinear (or two coincide)"]),
        (
            "huge.mrk.json",
            &["more than 100 m from the scanner's origin"],
        ),
    ] {
        let mut v = j.clone();
        for (label, c) in points(&mut v) {
            let p: Vec<f64> = serde_json::from_value(c["position"].clone()).unwrap();
            c["position"] = match name {
                "far.mrk.json" => serde_json::json!([p[0] + 300.0, p[1] + 300.0, p[2]]),
                "same.mrk.json" if label == "C2" => c1.clone(),
                "huge.mrk.json" => serde_json::json!([p[0] * 1e300, p[1], p[2]]),
                _ => c["position"].clone(),
            };
        }
        let p = d.join(name);
        std::fs::write(&p, serde_json::to_string(&v).unwrap()).unwrap();
        cases.push((p, words));
    }
    for (p, words) in cases {
        let out = d.join("out/mask.nii.gz");
        let o = coapt(&[
            "segment",
            "--ct",
            repo().join("sample_data/ct.nii.gz").to_str().unwrap(),
            "--landmarks",
            p.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert_bad_input(&o, &p, words);
        assert!(!d.join("out").exists());
    }
}

/// A valve.json whose commissure lies below the annulus or far off the axis
/// describes no root: leaflets, close and report refuse it alike, naming the
/// commissure, its height and its distance.
#[test]
fn a_valve_frame_with_a_commissure_off_the_root_is_refused() {
    let d = tmpdir("commissure-off");
    let surface = sample_valve_and_leaflets(&d, "pipelines/templates/ozaki_default.toml", &[]);
    let v = json(&d.join("valve.json"));
    let f = &v["valve_frame"];
    let get = |j: &serde_json::Value| -> [f64; 3] { serde_json::from_value(j.clone()).unwrap() };
    let (o, a) = (get(&f["origin_mm"]), get(&f["axis"]));
    for (name, c2, words) in [
        // 5 mm below the annulus plane, on the axis's side.
        (
            "below.json",
            [o[0] - 5.0 * a[0], o[1] - 5.0 * a[1], o[2] - 5.0 * a[2]],
            "C2 stands -5 mm",
        ),
        ("far.json", [o[0] + 500.0, o[1], o[2]], "C2 stands"),
    ] {
        let mut bad_v = v.clone();
        bad_v["valve_frame"]["commissures_mm"][1] = serde_json::json!(c2);
        let bad = d.join(name);
        std::fs::write(&bad, serde_json::to_string(&bad_v).unwrap()).unwrap();
        for mut args in stages_reading_valve(&d, &surface, &bad) {
            args.push("--quiet".into());
            let o = coapt(&args.iter().map(String::as_str).collect::<Vec<_>>());
            assert_bad_input(&o, &bad, &[words, "a root's commissures stand"]);
            assert!(!d.join("out").exists(), "{} wrote output", args[0]);
        }
    }
}

/// A scan too thin to hold a root (a 112 × 112 × 1 image made a one-slice
/// "aorta" with exit 0) is refused as bad input, with its extent.
#[test]
fn a_scan_too_thin_for_a_root_is_refused() {
    let d = tmpdir("one-slice");
    let a = affine_from_parts(
        [0.8, 0.8, 0.8],
        &Matrix3::identity(),
        Point3::new(0.0, 0.0, 0.0),
    );
    let v = Volume::from_fortran_vec([112, 112, 1], a, vec![300i16; 112 * 112]).unwrap();
    let p = d.join("one.nii.gz");
    coapt::io::nifti::write(&p, &v).unwrap();
    let out = d.join("mask.nii.gz");
    let o = coapt(&[
        "segment",
        "--quiet",
        "--ct",
        p.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_bad_input(&o, &p, &["0.8 mm", "axis 3", "20 mm"]);
    assert!(!out.exists());
}

/// A stage without parameters says where its settings live rather than
/// listing nothing ("stage close takes: ").
#[test]
fn a_parameter_for_a_stage_without_any_says_where_settings_live() {
    let d = tmpdir("no-params");
    let cfg = d.join("run.toml");
    std::fs::write(&cfg, "[run]\ndir = \"x\"\n[close]\nfoo = 1\n").unwrap();
    let o = coapt(&["run", cfg.to_str().unwrap()]);
    assert_bad_input(&o, &cfg, &["close.foo", "takes none", "config ="]);
}

/// A run killed between writing and renaming leaves `.NAME.tmp-PID-N`
/// beside its output; the next run of that stage removes those of dead
/// processes and nothing else.
#[test]
fn temporaries_a_killed_run_left_are_removed_by_the_next() {
    let d = tmpdir("stale-tmp");
    let surface = sample_valve_and_leaflets(&d, "pipelines/templates/ozaki_default.toml", &[]);
    // A pid above the kernel's limit (2^22) belongs to no process.
    let stale = d.join(".valve2.json.tmp-4999999-0");
    let other = d.join(".valve2.json.tmp-notes");
    std::fs::write(&stale, b"half a file").unwrap();
    std::fs::write(&other, b"not ours").unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let args = stage_args(
        "valve",
        &[
            ("surface", s(&surface)),
            (
                "landmarks",
                s(&repo().join("sample_data/landmarks.mrk.json")),
            ),
            ("out", s(&d.join("valve2.json"))),
        ],
    );
    let o = coapt(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stale.exists(), "the dead run's temporary is still there");
    assert!(
        other.exists(),
        "a file that is not a coapt temporary was removed"
    );
}

/// docs/commands.md writes negative quantities with a space (`--omega "-40 deg"`):
/// clap used to take "-40 deg" for a flag. And a bare number in a closure
/// config names its line and key and says how to write it.
#[test]
fn negative_quantities_are_values_and_bare_numbers_say_how_to_write_them() {
    let d = tmpdir("cli-words");
    sample_valve_and_leaflets(
        &d,
        "pipelines/templates/ozaki_default.toml",
        &["--omega", "-30 deg"],
    );
    let sum = json(&d.join("leaflets.json"));
    // The lean is the one asked for (the placement adjusts it by a little
    // to keep the leaflet inside the wall), not the default −40°.
    let om = sum["leaflets"][0]["omega_used_deg"].as_f64().unwrap();
    assert!((om + 30.0).abs() < 1.0, "{om}");

    let text = std::fs::read_to_string(repo().join("pipelines/close.toml"))
        .unwrap()
        .replace("pressure = \"80 mmHg\"", "pressure = 80");
    let line = 1 + text
        .lines()
        .position(|l| l.starts_with("pressure = 80"))
        .expect("close.toml sets the pressure");
    let cfg = d.join("close.toml");
    std::fs::write(&cfg, text).unwrap();
    let out = d.join("closed.vtp");
    let o = coapt(&[
        "close",
        "--leaflets",
        &s(&d.join("leaflets.vtp")),
        "--surface",
        &s(&repo().join("sample_data/truth_surface.vtp")),
        "--config",
        &s(&cfg),
        "--out",
        &s(&out),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!(
            "line {line}, `pressure`: invalid type: integer `80`"
        )) && err.contains("pressure = \"80 mmHg\""),
        "{err}"
    );
    assert!(!out.exists());
}

/// Found by fuzzing: a DICOM element with no valid VR, read by the parser as
/// UN with a 2 GB length, took 2.1 GB to refuse a 1 kB file. It is refused
/// from its element headers, naming the file and the element.
#[test]
fn a_dicom_element_with_an_unknown_vr_is_refused_before_the_parser() {
    let dir = repo().join("tests/data/dicom/damaged");
    for (file, words) in [
        ("unknown_vr.dcm", "(0028,1053) claims 2145394737 bytes"),
        // The same walk: an FL of 2 bytes made the parser lose its place
        // and reserve 1.3 GB.
        ("fl_two_bytes.dcm", "(0028,0002) (FL) holds 2 bytes"),
    ] {
        let o = coapt(&["info", dir.join(file).to_str().unwrap()]);
        assert_bad_input(&o, &dir.join(file), &[words]);
    }
}
