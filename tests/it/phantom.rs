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

#[test]
fn clinical_preset_is_1_5_mm_with_arch_cusps_and_tilted_annulus() {
    let d = tmpdir("clinical");
    let o = coapt(&[
        "phantom",
        "--preset",
        "clinical",
        "--out",
        &s(&d),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let ct = coapt::io::nifti::read_i16(&d.join("ct.nii.gz")).unwrap();
    assert_eq!(ct.spacing(), [1.5, 1.5, 1.5]);
    assert_eq!(ct.dims(), [128, 128, 160]);
    let t = json(&d.join("truth.json"));
    assert_eq!(t["annulus_tilt_deg"].as_f64(), Some(20.0));
    assert_eq!(t["noise_hu"].as_f64(), Some(28.0));
    assert_eq!(t["blood_hu"].as_f64(), Some(480.0));
    let end = t["arch"]["truth_region_end_z_mm"].as_f64().unwrap();
    assert_eq!(t["top_cap_z_mm"].as_f64(), Some(end));
    assert!(t["native_cusps"]["thickness_mm"].as_f64().unwrap() <= 1.0);
    // The nadir plane of the landmarks file is 20° from its commissure plane.
    let lm = markups::read(&d.join("landmarks.mrk.json")).unwrap();
    let p = lm.require(&["C1", "C2", "C3", "N1", "N2", "N3"]).unwrap();
    let normal = |a: usize| (p[a + 1] - p[a]).cross(&(p[a + 2] - p[a])).normalize();
    let tilt = normal(0).dot(&normal(3)).abs().min(1.0).acos().to_degrees();
    assert!((tilt - 20.0).abs() < 0.5, "nadir plane tilt {tilt}");
    // The mean over the mask is the blood, the cusps barely lowering it.
    let mean = mean_hu_in_truth_mask(&d);
    assert!(
        (400.0..=490.0).contains(&mean),
        "mean HU in the mask {mean}"
    );
}

#[test]
fn annulus_tilt_out_of_range_is_refused() {
    let d = tmpdir("annulus-tilt");
    let o = coapt(&[
        "phantom",
        "--annulus-tilt",
        "50 deg",
        "--out",
        &s(&d),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("annulus tilt"), "{}", stderr(&o));
    assert!(!d.join("ct.nii.gz").exists());
    let o = coapt(&[
        "phantom",
        "--root-rotation",
        "200 deg",
        "--out",
        &s(&d),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "--root-rotation (phantom root rotation) = 200 deg is outside [-180, 180] deg"
        ),
        "{}",
        stderr(&o)
    );
    assert!(!d.join("ct.nii.gz").exists());
}
