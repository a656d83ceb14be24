//! `coapt surface`: files, topology, labels, determinism, refusals.

use coapt::geom::{DataValues, Matrix3, Point3, Volume, volume::affine_from_parts};
use coapt::io::vtp;

use crate::common::*;

fn sample_mask() -> std::path::PathBuf {
    repo().join("sample_data/truth_mask.nii.gz")
}

fn run_surface(out: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let mask = sample_mask();
    let (m, o) = (mask.to_str().unwrap(), out.to_str().unwrap());
    let mut args = vec!["surface", "--mask", m, "--out", o, "--quiet"];
    args.extend_from_slice(extra);
    coapt(&args)
}

#[test]
fn sample_mask_gives_a_closed_labelled_wall() {
    let d = tmpdir("surface-sample");
    let out = d.join("aorta.vtp");
    let o = run_surface(&out, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(entries(&d), ["aorta.vtp", "surface.json"]);
    let mesh = vtp::read_mesh(&out).unwrap();
    mesh.sanity_check().unwrap();
    let topo = mesh.topology();
    assert_eq!(
        (
            topo.boundary_edges,
            topo.components,
            topo.euler_characteristic
        ),
        (0, 1, 2)
    );
    assert_eq!(mesh.frame, coapt::geom::Frame::Lps);
    let DataValues::I32(region) = &mesh.cell_data.get("region").unwrap().values else {
        panic!("region is not Int32")
    };
    for r in 0..3 {
        assert!(region.contains(&r), "no region {r}");
    }
    let rep: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("surface.json")).unwrap()).unwrap();
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(repo().join("sample_data/truth.json")).unwrap())
            .unwrap();
    let v = rep["enclosed_volume_mm3"].as_f64().unwrap();
    let v_true = truth["truth_surface_volume_mm3"].as_f64().unwrap();
    assert!((v - mesh.signed_volume()).abs() < 1e-6 * v);
    assert!((v - v_true).abs() < 0.02 * v_true, "{v} vs {v_true}");
    assert!(rep["smoothing_volume_change_pct"].as_f64().unwrap().abs() < 1.0);
    assert_eq!(
        rep["triangles"].as_u64().unwrap() as usize,
        mesh.triangles.len()
    );
}

#[test]
fn unsmoothed_output_is_the_raw_marching_cubes() {
    let d = tmpdir("surface-raw");
    let out = d.join("raw.vtp");
    let o = run_surface(&out, &["--smooth", "0", "--keep-all"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mask = coapt::io::nifti::read_u8(&sample_mask()).unwrap();
    let direct = coapt::surface::extract(&mask, 0.5);
    let mesh = vtp::read_mesh(&out).unwrap();
    assert_eq!(mesh.triangles, direct.triangles);
    assert_eq!(mesh.vertices, direct.vertices);
}

#[test]
fn surface_is_bit_identical_with_one_or_two_threads() {
    let d = tmpdir("surface-threads");
    let (a, b) = (d.join("t1/aorta.vtp"), d.join("t2/aorta.vtp"));
    for (p, n) in [(&a, "1"), (&b, "2")] {
        let o = run_surface(p, &["--threads", n]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

#[test]
fn bad_or_empty_masks_are_refused_and_nothing_is_written() {
    let d = tmpdir("surface-bad");
    let garbage = d.join("mask.nii.gz");
    std::fs::write(&garbage, b"not a nifti file at all").unwrap();
    let out = d.join("out/aorta.vtp");
    let o = coapt(&[
        "surface",
        "--mask",
        garbage.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_bad_input(&o, &garbage, &[]);
    assert!(!d.join("out").exists() || entries(&d.join("out")).is_empty());

    let a = affine_from_parts([0.5; 3], &Matrix3::identity(), Point3::origin());
    let empty = d.join("empty.nii.gz");
    coapt::io::nifti::write(&empty, &Volume::filled([8, 8, 8], a, 0u8).unwrap()).unwrap();
    let o = coapt(&[
        "surface",
        "--mask",
        empty.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("empty"), "{}", stderr(&o));
    assert!(!out.exists() && !d.join("out/surface.json").exists());
}
