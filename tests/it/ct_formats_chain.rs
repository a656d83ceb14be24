//! The whole `coapt run` chain from the sample CT as it may come: NIfTI,
//! a DICOM series, NRRD and MetaImage give the same report and the same
//! closed valve (issue 24's "done when").
//!
//! Only `segment` reads the CT; every later stage reads the mask and what
//! follows from it (the report records the CT's hash, no more). So the
//! chain runs in full twice, from NIfTI and from the DICOM series (the
//! reader with the most to get wrong), and the closed meshes and reports
//! are compared. NRRD and MetaImage run in copies of the NIfTI run
//! directory: segment runs again on the new CT, and the manifest must then
//! skip surface, valve, leaflets and close — which it does only when their
//! inputs hash the same as in the NIfTI run, i.e. the mask is byte-
//! identical — while the report runs again and must say the same. This
//! keeps the test at two closures (≈ 9 s each in release) instead of four.

use std::path::{Path, PathBuf};

use coapt::io::nifti;

use crate::common::*;
use crate::dicom::{Spec, write_series};
use crate::formats::{attached, le, mha_header, nrrd_header};

fn config(d: &Path, run: &Path, ct: &Path) -> PathBuf {
    let r = repo();
    let cfg = d.join(format!(
        "{}.toml",
        run.file_name().unwrap().to_string_lossy()
    ));
    std::fs::write(
        &cfg,
        format!(
            "[run]\ndir = \"{}\"\n\n[inputs]\nct = \"{}\"\nlandmarks = \"{}\"\n\
             template = \"{}\"\nconfig = \"{}\"\n",
            s(run),
            s(ct),
            s(&r.join("sample_data/landmarks.mrk.json")),
            s(&r.join("pipelines/templates/ozaki_default.toml")),
            s(&r.join("pipelines/close.toml")),
        ),
    )
    .unwrap();
    cfg
}

fn run(cfg: &Path) {
    let o = coapt(&["run", &s(cfg), "--quiet"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}: {}",
        cfg.display(),
        stderr(&o)
    );
}

/// report.json without what names the run rather than the valve: the
/// inputs' paths and hashes (the CT's differ by format), stage timings,
/// the run's name and the time it was computed.
fn report_numbers(run: &Path) -> serde_json::Value {
    let mut r = json(&run.join("report.json"));
    let o = r.as_object_mut().unwrap();
    o.remove("inputs").unwrap();
    o.remove("timing_s").unwrap();
    let case = o["case"].as_object_mut().unwrap();
    case.remove("name").unwrap();
    case.remove("computed_utc").unwrap();
    r
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

#[test]
fn the_chain_reports_the_same_valve_from_nifti_dicom_nrrd_and_metaimage() {
    let d = tmpdir("ct-formats-chain");
    let nii = repo().join("sample_data/ct.nii.gz");
    let v = nifti::read_i16(&nii).unwrap();
    let dicom = d.join("dicom");
    write_series(&dicom, &v, &Spec::new("1.2.826.0.1.3680043.2.1125.24", 2));
    let nrrd = attached(
        &d.join("ct.nrrd"),
        nrrd_header(&v, true, "raw", "\n"),
        &le(&v),
    );
    let mha = attached(&d.join("ct.mha"), mha_header(&v, false, "LOCAL"), &le(&v));

    let reference = d.join("nifti");
    run(&config(&d, &reference, &nii));
    let want = report_numbers(&reference);
    let closed = std::fs::read(reference.join("closed.vtp")).unwrap();
    assert!(want["metrics"].is_object(), "{want}");

    let from_dicom = d.join("dicom-run");
    run(&config(&d, &from_dicom, &dicom));
    assert!(
        stage_statuses(&from_dicom)
            .iter()
            .all(|(_, st)| st == "ran"),
        "{:?}",
        stage_statuses(&from_dicom)
    );
    assert!(
        std::fs::read(from_dicom.join("closed.vtp")).unwrap() == closed,
        "closed.vtp differs from the DICOM series"
    );
    assert_eq!(report_numbers(&from_dicom), want, "report from DICOM");

    for (name, ct) in [("nrrd", &nrrd), ("mha", &mha)] {
        let dir = d.join(format!("{name}-run"));
        copy_dir(&reference, &dir);
        run(&config(&d, &dir, ct));
        let st = stage_statuses(&dir);
        let expect: Vec<(String, String)> = [
            ("segment", "ran"),
            ("surface", "skipped"),
            ("valve", "skipped"),
            ("leaflets", "skipped"),
            ("close", "skipped"),
            ("report", "ran"),
        ]
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
        assert_eq!(st, expect, "{name}");
        assert!(
            std::fs::read(dir.join("mask.nii.gz")).unwrap()
                == std::fs::read(reference.join("mask.nii.gz")).unwrap(),
            "{name}: mask differs"
        );
        assert!(std::fs::read(dir.join("closed.vtp")).unwrap() == closed);
        assert_eq!(report_numbers(&dir), want, "report from {name}");
    }
}
