//! `coapt close`: refusals, the record a run that does not converge leaves,
//! and a converged, thread-independent closure of the sample valve.

use std::path::Path;

use crate::common::*;

/// Valve + leaflets on the committed sample's truth surface (h = 1 mm).
fn sample_leaflets(d: &Path) -> std::path::PathBuf {
    sample_valve_and_leaflets(
        d,
        "pipelines/templates/ozaki_default.toml",
        &["--h", "1 mm"],
    )
}

fn close(
    leaflets: &Path,
    surface: &Path,
    cfg: &Path,
    out: &Path,
    extra: &[&str],
) -> std::process::Output {
    let mut a = vec![
        "close".to_string(),
        "--leaflets".into(),
        s(leaflets),
        "--surface".into(),
        s(surface),
        "--config".into(),
        s(cfg),
        "--out".into(),
        s(out),
    ];
    a.extend(extra.iter().map(|x| x.to_string()));
    coapt(&a.iter().map(String::as_str).collect::<Vec<_>>())
}

/// Close `d/leaflets.vtp` with `cfg` on one and on two threads
/// (`closed1.vtp`, `closed2.vtp`); the two must be the same bytes. The
/// one-thread closure.json.
fn close_on_one_and_two_threads(d: &Path, surface: &Path, cfg: &Path) -> serde_json::Value {
    for threads in ["1", "2"] {
        let out = format!("closed{threads}.vtp");
        let o = close(
            &d.join("leaflets.vtp"),
            surface,
            cfg,
            &d.join(&out),
            &[
                "--valve",
                &s(&d.join("valve.json")),
                "--log",
                &s(&d.join(format!("{out}.json"))),
                "--threads",
                threads,
                "--quiet",
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_eq!(
        std::fs::read(d.join("closed1.vtp")).unwrap(),
        std::fs::read(d.join("closed2.vtp")).unwrap()
    );
    json(&d.join("closed1.vtp.json"))
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
    let o = close(&d.join("leaflets.vtp"), &surface, &cfg, &out, &[]);
    assert_bad_input(&o, &cfg, &["mu", "unit"]);
    std::fs::write(
        &cfg,
        "model = \"rubber\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\n",
    )
    .unwrap();
    let o = close(&d.join("leaflets.vtp"), &surface, &cfg, &out, &[]);
    assert_bad_input(&o, &cfg, &["rubber", "neo-hookean"]);
    // The wall has no boundary labels: it is not a leaflets mesh.
    std::fs::write(&cfg, "model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\n").unwrap();
    let o = close(&surface, &surface, &cfg, &out, &[]);
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
    let o = close(
        &d.join("leaflets.vtp"),
        &surface,
        &cfg,
        &out,
        &["--valve", &s(&d.join("valve.json")), "--log", &s(&log)],
    );
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

/// The sample valve closes with the seed 001 contact planes: converged, no
/// NaN, sutures unmoved, every leaflet pressed onto its planes and carried
/// towards the axis, and the same bytes whatever the thread count.
#[test]
fn sample_valve_closes_with_contact_planes_and_is_thread_independent() {
    use coapt::io::vtp;
    let d = tmpdir("close-planes");
    let surface = sample_leaflets(&d);
    let cfg = repo().join("pipelines/close.toml");
    let log = close_on_one_and_two_threads(&d, &surface, &cfg);
    assert_eq!(log["solver"]["converged"], true);
    assert!(log["solver"]["residual_n"].as_f64().unwrap() <= 1e-7);
    let before = vtp::read_mesh(&d.join("leaflets.vtp")).unwrap();
    let after = vtp::read_mesh(&d.join("closed1.vtp")).unwrap();
    let valve: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("valve.json")).unwrap()).unwrap();
    let v = |j: &serde_json::Value| {
        coapt::geom::Vector3::new(
            j[0].as_f64().unwrap(),
            j[1].as_f64().unwrap(),
            j[2].as_f64().unwrap(),
        )
    };
    let (axis, centre) = (
        v(&valve["valve_frame"]["axis"]),
        v(&valve["commissure_cylinder"]["centre_mm"]),
    );
    let radial = |p: &coapt::geom::Point3| {
        let q = p.coords - centre;
        (q - axis * q.dot(&axis)).norm()
    };
    let bnd = before
        .point_data
        .get("boundary")
        .unwrap()
        .values
        .to_f64()
        .unwrap();
    let contact = after
        .point_data
        .get("contact")
        .unwrap()
        .values
        .to_f64()
        .unwrap();
    let (mut free_before, mut free_after, mut n_free) = (0.0, 0.0, 0.0);
    for i in 0..before.vertices.len() {
        assert!(after.vertices[i].iter().all(|c| c.is_finite()));
        if bnd[i] == 1.0 {
            assert_eq!(
                before.vertices[i], after.vertices[i],
                "a sutured node moved"
            );
        }
        if bnd[i] == 2.0 {
            free_before += radial(&before.vertices[i]);
            free_after += radial(&after.vertices[i]);
            n_free += 1.0;
        }
    }
    assert!(
        free_after / n_free < 0.9 * free_before / n_free,
        "free edges did not move towards the axis: {} → {} mm",
        free_before / n_free,
        free_after / n_free
    );
    // Diastole pushes the bellies towards the ventricle.
    let (mut down, mut n) = (0.0, 0.0);
    for i in 0..before.vertices.len() {
        if bnd[i] == 0.0 {
            down += (after.vertices[i] - before.vertices[i]).dot(&axis);
            n += 1.0;
        }
    }
    assert!(
        down / n < -0.1,
        "mean axial move of interior nodes {} mm",
        down / n
    );
    // Each leaflet touches both of its planes.
    let leaf = after
        .cell_data
        .get("leaflet")
        .unwrap()
        .values
        .to_f64()
        .unwrap();
    for k in 1..=3 {
        let mut bits = 0u8;
        for (t, tri) in after.triangles.iter().enumerate() {
            if leaf[t] == k as f64 {
                for &i in tri {
                    bits |= contact[i as usize] as u8;
                }
            }
        }
        assert_eq!(bits.count_ones(), 2, "leaflet {k} touches planes {bits:b}");
    }
}

/// The sample valve closes with true leaflet-to-leaflet contact (the
/// barrier): converged, the same bytes whatever the thread count, every
/// leaflet touching both others, and no triangle pair of different
/// leaflets crossing that did not cross in the placed leaflets (exact
/// triangle–triangle tests; the placement may sew neighbours over each
/// other at the commissures).
#[test]
fn sample_valve_closes_with_leaflet_contact_without_crossing() {
    use coapt::geom::bvh::Bvh;
    use coapt::geom::tri_tri;
    use coapt::io::vtp;
    use coapt::mech::element::V3;
    let d = tmpdir("close-leaflets");
    let surface = sample_leaflets(&d);
    let text = std::fs::read_to_string(repo().join("pipelines/close.toml")).unwrap();
    let text: String = text
        .lines()
        .map(|l| {
            if l.starts_with("contact") {
                "contact = \"leaflets\""
            } else {
                l
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let cfg = d.join("close-leaflets.toml");
    std::fs::write(&cfg, text).unwrap();
    let log = close_on_one_and_two_threads(&d, &surface, &cfg);
    assert_eq!(log["solver"]["converged"], true);
    let crossing = |m: &coapt::geom::TriMesh| {
        let x: Vec<V3> = m.vertices.iter().map(|p| V3::new(p.x, p.y, p.z)).collect();
        let body: Vec<u16> = m
            .cell_data
            .get("leaflet")
            .unwrap()
            .values
            .to_f64()
            .unwrap()
            .iter()
            .map(|&k| k as u16)
            .collect();
        let bvh = Bvh::build(&x, &m.triangles);
        tri_tri::intersecting_pairs(&x, &m.triangles, &body, &bvh)
    };
    let before = vtp::read_mesh(&d.join("leaflets.vtp")).unwrap();
    let after = vtp::read_mesh(&d.join("closed1.vtp")).unwrap();
    let (c0, c1) = (crossing(&before), crossing(&after));
    assert!(
        c1.iter().all(|p| c0.contains(p)),
        "{} crossing pairs after, {} before",
        c1.len(),
        c0.len()
    );
    assert_eq!(log["intersecting_triangle_pairs"], c1.len());
    // Every leaflet touches both others (contact bits are leaflet numbers).
    let contact = after
        .point_data
        .get("contact")
        .unwrap()
        .values
        .to_f64()
        .unwrap();
    let leaf = after
        .cell_data
        .get("leaflet")
        .unwrap()
        .values
        .to_f64()
        .unwrap();
    for k in 1..=3 {
        let mut bits = 0u8;
        for (t, tri) in after.triangles.iter().enumerate() {
            if leaf[t] == k as f64 {
                for &i in tri {
                    bits |= contact[i as usize] as u8;
                }
            }
        }
        assert_eq!(bits.count_ones(), 2, "leaflet {k} touches {bits:b}");
        assert_eq!(bits & (1 << (k - 1)), 0, "leaflet {k} touches itself");
    }
}
