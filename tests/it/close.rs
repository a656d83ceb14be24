//! `coapt close`: refusals, and the record a run that does not converge leaves.

use crate::common::*;

fn s(p: &std::path::Path) -> String {
    p.to_str().unwrap().to_string()
}

/// Valve + leaflets on the committed sample's truth surface (h = 1 mm).
fn sample_leaflets(d: &std::path::Path) -> std::path::PathBuf {
    let data = repo().join("sample_data");
    let surface = data.join("truth_surface.vtp");
    let o = coapt(&[
        "valve",
        "--surface",
        &s(&surface),
        "--landmarks",
        &s(&data.join("landmarks.mrk.json")),
        "--out",
        &s(&d.join("valve.json")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = coapt(&[
        "leaflets",
        "--valve",
        &s(&d.join("valve.json")),
        "--paths",
        &s(&d.join("paths.vtp")),
        "--surface",
        &s(&surface),
        "--template",
        &s(&repo().join("pipelines/templates/ozaki_default.toml")),
        "--h",
        "1 mm",
        "--out",
        &s(&d.join("leaflets.vtp")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    surface
}

#[test]
fn close_refuses_bad_configs_and_meshes_without_boundary_labels() {
    let d = tmpdir("close-bad");
    let surface = sample_leaflets(&d);
    let cfg = d.join("close.toml");
    std::fs::write(
        &cfg,
        "model = \"neo-hookean\"\nmu = \"300\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\n",
    )
    .unwrap();
    let out = d.join("closed.vtp");
    let o = coapt(&[
        "close",
        "--leaflets",
        &s(&d.join("leaflets.vtp")),
        "--surface",
        &s(&surface),
        "--config",
        &s(&cfg),
        "--out",
        &s(&out),
    ]);
    assert_bad_input(&o, &cfg, &["mu", "unit"]);
    std::fs::write(
        &cfg,
        "model = \"rubber\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\n",
    )
    .unwrap();
    let o = coapt(&[
        "close",
        "--leaflets",
        &s(&d.join("leaflets.vtp")),
        "--surface",
        &s(&surface),
        "--config",
        &s(&cfg),
        "--out",
        &s(&out),
    ]);
    assert_bad_input(&o, &cfg, &["rubber", "neo-hookean"]);
    // The wall has no boundary labels: it is not a leaflets mesh.
    std::fs::write(&cfg, "model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\n").unwrap();
    let o = coapt(&[
        "close",
        "--leaflets",
        &s(&surface),
        "--surface",
        &s(&surface),
        "--config",
        &s(&cfg),
        "--out",
        &s(&out),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let last = stderr(&o).lines().last().unwrap_or_default().to_string();
    assert!(
        last.starts_with("error: ")
            && last.contains("truth_surface.vtp")
            && last.contains("boundary"),
        "{last}"
    );
    assert!(!out.exists());
}

#[test]
fn a_closure_that_does_not_converge_exits_1_with_its_history_and_no_mesh() {
    let d = tmpdir("close-limit");
    let surface = sample_leaflets(&d);
    let cfg = d.join("close.toml");
    std::fs::write(
        &cfg,
        "model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\ncontact = \"none\"\nmax_iterations = 2\n",
    )
    .unwrap();
    let out = d.join("closed.vtp");
    let log = d.join("closure.json");
    let o = coapt(&[
        "close",
        "--leaflets",
        &s(&d.join("leaflets.vtp")),
        "--surface",
        &s(&surface),
        "--config",
        &s(&cfg),
        "--valve",
        &s(&d.join("valve.json")),
        "--out",
        &s(&out),
        "--log",
        &s(&log),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("did not converge"), "{}", stderr(&o));
    assert!(!out.exists());
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&log).unwrap()).unwrap();
    assert_eq!(v["solver"]["converged"], false);
    let h = v["solver"]["history"].as_array().unwrap();
    assert_eq!(h.len(), 2, "one record per iteration");
    for r in h {
        let x = r["residual_n"].as_f64().unwrap();
        assert!(x.is_finite() && x > 0.0);
    }
    // The placed leaflets hang from the sutures: those nodes lie on the wall.
    assert!(v["sutured_to_wall_mm"]["max"].as_f64().unwrap() < 0.05);
}
