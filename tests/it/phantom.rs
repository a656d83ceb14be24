//! `coapt phantom`: files, determinism across thread counts, refusals.

use coapt::io::{markups, vtp};

use crate::common::*;

#[test]
fn bit_identical_with_one_or_two_threads() {
    let d = tmpdir("threads");
    let (a, b) = (d.join("t1"), d.join("t2"));
    for (dir, n) in [(&a, "1"), (&b, "2")] {
        sample_phantom(dir, &["--seed", "7", "--threads", n]);
    }
    for f in [
        "ct.nii.gz",
        "truth_mask.nii.gz",
        "landmarks.mrk.json",
        "truth.json",
        "truth_surface.vtp",
    ] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f} differs"
        );
    }
}

#[test]
fn outputs_are_consistent_and_readable() {
    let d = tmpdir("outputs");
    sample_phantom(&d, &["--seed", "3", "--tilt", "20 deg"]);
    let mean = mean_hu_in_truth_mask(&d);
    assert!(mean > 250.0, "mean HU inside the lumen {mean}");

    let lm = markups::read(&d.join("landmarks.mrk.json")).unwrap();
    let c = lm.require(&["C1", "C2", "C3", "N1", "N2", "N3"]).unwrap();
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("truth.json")).unwrap()).unwrap();
    assert_eq!(truth["frame"], "LPS");
    let tilt = truth["tilt_deg"].as_f64().unwrap();
    assert!((tilt - 20.0).abs() < 1e-9, "tilt {tilt}");

    let surface = vtp::read_mesh(&d.join("truth_surface.vtp")).unwrap();
    surface.sanity_check().unwrap();
    assert_eq!(surface.topology().euler_characteristic, 2);
    // The commissures lie on the truth surface (to the mesh's chord error).
    for p in &c[..3] {
        let nearest = surface
            .vertices
            .iter()
            .map(|v| (v - p).norm())
            .fold(f64::INFINITY, f64::min);
        assert!(
            nearest < 0.6,
            "commissure {p} is {nearest} mm from the surface"
        );
    }
    let m = coapt::pipeline::manifest::Manifest::load(&d).unwrap();
    assert_eq!(m.stage("phantom").unwrap().params["tilt"], "20 deg");
}

#[test]
fn no_contrast_phantom_is_dark() {
    let d = tmpdir("nocontrast");
    sample_phantom(&d, &["--no-contrast"]);
    let mean = mean_hu_in_truth_mask(&d);
    assert!(mean < 100.0, "non-contrast blood at {mean} HU");
}
