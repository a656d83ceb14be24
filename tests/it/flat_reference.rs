//! Resting the leaflets on their flat template (the cut pericardium) with
//! a membrane that wrinkles takes the placement out of the closed valve:
//! the same template closes to the same valve from the extruded and from
//! the hanging placement, where resting on the sutured state makes the two
//! placements two different valves.

use crate::common::*;
use coapt::io::vtp;
use std::path::Path;

const FLAT: &str = r#"
model = "neo-hookean"
mu = "900 kPa"
thickness = "0.5 mm"
pressure = "80 mmHg"
contact = "leaflets"
solver = "newton"
bending = true
reference = "flat"
wrinkling = true
# Full steps cycle at 3e-3 to 6e-3 N among 1e5 contact pairs on the sample
# at h 0.5 mm: 2.6e-4 of the 23 N pressure load, corrections of ~5e-3 mm.
# At h 1 mm from the extruded start as sewn since each sutured triangle
# shares its free vertex's wall normal (suture.rs `shared_normals`) they
# cycle at 1.09e-2 to 1.23e-2 N among 1.7e4 pairs (5e-4 of the load); at
# 1.5e-2 N the two placements close 0.064 mm apart (median node; 0.051 at
# 6e-3 N before), effective heights 17.37 / 17.49 mm.
tolerance = "1.5e-2 N"
"#;

/// Closed positions and (effective height, coaptation height) of the run.
fn closed(run: &Path) -> (Vec<[f64; 3]>, f64, f64) {
    let m = vtp::read_mesh(&run.join("closed.vtp")).unwrap();
    let r = json(&run.join("report.json"));
    assert!(
        json(&run.join("closure.json"))["solver"]["converged"]
            .as_bool()
            .unwrap()
    );
    let metric = |k: &str| r["metrics"][k].as_f64().unwrap();
    (
        m.vertices.iter().map(|p| [p.x, p.y, p.z]).collect(),
        metric("effective_height_closing_pressure_mm"),
        metric("coaptation_height_mm"),
    )
}

#[test]
fn the_flat_wrinkling_leaflet_closes_alike_from_either_placement_and_the_sutured_one_does_not() {
    let d = tmpdir("flat-reference");
    let template = d.join("measured.toml");
    std::fs::write(
        &template,
        "[template]\nkind = \"ozaki_size\"\nsize = \"measured\"\n",
    )
    .unwrap();
    let flat = d.join("flat.toml");
    std::fs::write(&flat, FLAT).unwrap();
    let sample = repo().join("sample_data");
    let inputs = [
        ("ct", sample.join("ct.nii.gz")),
        ("landmarks", sample.join("landmarks.mrk.json")),
    ];
    let inputs: Vec<(&str, &Path)> = inputs.iter().map(|(k, p)| (*k, p.as_path())).collect();
    let mut out = Vec::new();
    let sutured = repo().join("pipelines/close.toml");
    for (config, placement) in [
        (&flat, "hanging"),
        (&flat, "extruded"),
        (&sutured, "extruded"),
        (&sutured, "hanging"),
    ] {
        // The same run directory: only leaflets, close and report re-run.
        let extra = format!("[leaflets]\nplacement = \"{placement}\"\nh = \"1 mm\"\n");
        let run = run_chain_with(&d, &inputs, &template, config, &extra);
        out.push(closed(&run));
    }
    let median_distance = |a: &[[f64; 3]], b: &[[f64; 3]]| {
        assert_eq!(a.len(), b.len(), "one template mesh in every run");
        let mut d: Vec<f64> = a
            .iter()
            .zip(b)
            .map(|(p, q)| {
                ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
            })
            .collect();
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    };
    let (fh, fe) = (&out[0], &out[1]);
    let (se, sh) = (&out[2], &out[3]);
    // Measured at h 1 mm: median node distance 0.05 mm, effective heights
    // 17.37 / 17.50 mm, coaptation heights 16.22 / 16.19 mm.
    let flat_gap = median_distance(&fh.0, &fe.0);
    let sutured_gap = median_distance(&sh.0, &se.0);
    eprintln!(
        "flat: {flat_gap:.3} mm, heights {:.2}/{:.2}, {:.2}/{:.2}; sutured: {sutured_gap:.3} mm, {:.2}/{:.2}, {:.2}/{:.2}",
        fh.1, fe.1, fh.2, fe.2, sh.1, se.1, sh.2, se.2
    );
    assert!(
        flat_gap < 0.2,
        "flat: median node distance {flat_gap:.3} mm"
    );
    assert!(
        (fh.1 - fe.1).abs() < 0.5,
        "flat: effective heights {} / {}",
        fh.1,
        fe.1
    );
    assert!(
        (fh.2 - fe.2).abs() < 0.5,
        "flat: coaptation heights {} / {}",
        fh.2,
        fe.2
    );
    // Resting on the sutured state, the placement is the answer.
    assert!(
        sutured_gap > 10.0 * flat_gap && (sh.1 - se.1).abs() > 5.0,
        "sutured: median node distance {sutured_gap:.3} mm, effective heights {} / {}",
        sh.1,
        se.1
    );
}
