//! `coapt close` with `wall_contact = true`: the leaflets kept off the
//! aortic wall, its record in closure.json, and nothing changed when it
//! is off.

use std::path::Path;

use crate::common::*;

/// Close `d/leaflets.vtp` with `cfg_text` into `d/NAME.vtp` (+ `.json`).
fn close(
    d: &Path,
    surface: &Path,
    name: &str,
    cfg_text: &str,
    threads: &str,
) -> std::process::Output {
    let cfg = d.join(format!("{name}.toml"));
    std::fs::write(&cfg, cfg_text).unwrap();
    coapt(&[
        "close",
        "--leaflets",
        &s(&d.join("leaflets.vtp")),
        "--surface",
        &s(surface),
        "--valve",
        &s(&d.join("valve.json")),
        "--config",
        &s(&cfg),
        "--out",
        &s(&d.join(format!("{name}.vtp"))),
        "--log",
        &s(&d.join(format!("{name}.json"))),
        "--threads",
        threads,
        "--quiet",
    ])
}

fn bytes(d: &Path, name: &str) -> Vec<u8> {
    std::fs::read(d.join(format!("{name}.vtp"))).unwrap()
}

/// The sample valve (h = 1 mm, GOH, contact planes, diastole): with the
/// wall on, the closure converges, no free node comes within half the
/// thickness of the wall, the same bytes on 1 and 2 threads, and the
/// leaflets close where they close without it (they move away from the
/// wall); off, the key changes nothing.
#[test]
fn wall_contact_keeps_the_sample_off_the_wall_and_off_changes_nothing() {
    use coapt::io::vtp;
    let d = tmpdir("close-wall");
    let surface = sample_valve_and_leaflets(
        &d,
        "pipelines/templates/ozaki_default.toml",
        &["--h", "1 mm"],
    );
    let base = std::fs::read_to_string(repo().join("pipelines/close.toml")).unwrap();
    for (name, text, threads) in [
        ("plain", base.clone(), "2"),
        ("off", format!("{base}wall_contact = false\n"), "2"),
        ("on1", format!("{base}wall_contact = true\n"), "1"),
        ("on2", format!("{base}wall_contact = true\n"), "2"),
    ] {
        let o = close(&d, &surface, name, &text, threads);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
    }
    assert_eq!(bytes(&d, "plain"), bytes(&d, "off"));
    assert_eq!(bytes(&d, "on1"), bytes(&d, "on2"));
    let off = json(&d.join("off.json"));
    let on = json(&d.join("on1.json"));
    assert_eq!(off["config"]["wall_contact"], false);
    assert!(off.get("wall_contact").is_none());
    assert_eq!(on["config"]["wall_contact"], true);
    assert_eq!(on["solver"]["converged"], true);
    let w = &on["wall_contact"];
    assert_eq!(w["wall"], "mesh");
    assert_eq!(w["offset_mm"], 0.25);
    assert!(w["acting_nodes"].as_u64().unwrap() > 100, "{w}");
    // Next to the suture line nodes start within the margin.
    assert!(w["started_within_margin"].as_u64().unwrap() > 0, "{w}");
    let least = w["min_distance_full_offset_mm"].as_f64().unwrap();
    assert!(least >= 0.25, "{w}");
    assert!(w["min_distance_mm"].as_f64().unwrap() > 0.0, "{w}");
    assert_eq!(on["nodes_in_contact"], off["nodes_in_contact"]);
    // In diastole the leaflets leave the wall: the closure is where it was.
    let a = vtp::read_mesh(&d.join("off.vtp")).unwrap();
    let b = vtp::read_mesh(&d.join("on1.vtp")).unwrap();
    let moved = a
        .vertices
        .iter()
        .zip(&b.vertices)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    assert!(moved < 0.01, "the wall moved a node {moved} mm");
}

#[test]
fn wall_contact_needs_newton() {
    let d = tmpdir("close-wall-relax");
    let surface = sample_valve_and_leaflets(
        &d,
        "pipelines/templates/ozaki_default.toml",
        &["--h", "1 mm"],
    );
    let text = "model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\ncontact = \"none\"\nsolver = \"relax\"\nwall_contact = true\n";
    let o = close(&d, &surface, "relax", text, "2");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("wall_contact") && e.contains("newton"), "{e}");
    assert!(!d.join("relax.vtp").exists());
}
