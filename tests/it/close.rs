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

/// Per leaflet (1–3 in cell data `leaflet`), the union of its nodes'
/// `contact` bits.
fn contact_bits(m: &coapt::geom::TriMesh, contact: &[f64]) -> [u8; 3] {
    let leaf = m.cell_data.get("leaflet").unwrap().values.to_f64().unwrap();
    let mut bits = [0u8; 3];
    for (t, tri) in m.triangles.iter().enumerate() {
        for &i in tri {
            bits[leaf[t] as usize - 1] |= contact[i as usize] as u8;
        }
    }
    bits
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
    let base = "model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\ncontact = \"none\"\nmax_iterations = 2\n";
    let out = d.join("closed.vtp");
    let log = d.join("closure.json");
    let run = |text: &str| {
        std::fs::write(&cfg, text).unwrap();
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
        (stderr(&o), v)
    };
    // The closure itself (no suturing) stops at its iteration limit.
    let (_, v) = run(&format!("{base}\n[suture]\nmode = \"off\"\n"));
    assert_eq!(
        v["solver"]["stopped_by"], "iteration_limit",
        "{}",
        v["solver"]
    );
    let h = v["solver"]["history"].as_array().unwrap();
    assert_eq!(h.len(), 2, "one record per iteration");
    for r in h {
        let x = r["residual_n"].as_f64().unwrap();
        assert!(x.is_finite() && x > 0.0);
    }
    // The placed leaflets hang from the sutures: those nodes lie on the wall.
    assert!(v["sutured_to_wall_mm"]["max"].as_f64().unwrap() < 0.05);
    // Suturing's auxiliary problem gets the same limit and says so.
    let (err, v) = run(base);
    assert!(err.contains("suturing"), "{err}");
    assert_eq!(v["solver"]["stopped_by"], "suturing_failed");
    let su = &v["suturing"];
    assert_eq!(su["status"], "failed");
    let r = &su["rounds"][0];
    assert_eq!(r["converged"], false);
    assert_eq!(r["iterations"], 2);
    assert!(r["residual_n"].as_f64().unwrap().is_finite());
    // GOH on the flat template: placing strains it so far that the first
    // residual is ~1e48 N and the relative tolerance is met at ~1e39 N.
    // That is not an equilibrium, and it is not called one.
    let (err, v) = run(
        "model = \"goh\"\nmu = \"900 kPa\"\nk1 = \"1100 kPa\"\nk2 = 1000\nkappa = 0.29\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\ncontact = \"none\"\nreference = \"flat\"\n[suture]\nmode = \"off\"\n",
    );
    assert!(err.contains("of the pressure load"), "{err}");
    assert_eq!(v["solver"]["stopped_by"], "not_an_equilibrium");
    assert!(v["solver"]["residual_n"].as_f64().unwrap() > 1.0, "{v}");
}

/// The sample valve closes with the seed 001 contact planes: converged, no
/// NaN, sutures unmoved, every leaflet pressed onto its planes and carried
/// towards the axis, and the same bytes whatever the thread count.
#[test]
fn sample_valve_closes_with_contact_planes_and_is_thread_independent() {
    use coapt::io::vtp;
    let d = tmpdir("close-planes");
    let surface = sample_leaflets(&d);
    // The pipeline's settings with the planes instead of its true contact.
    let text = std::fs::read_to_string(repo().join("pipelines/close.toml")).unwrap();
    let text: String = text
        .lines()
        .map(|l| {
            if l.starts_with("contact") {
                "contact = \"planes\""
            } else {
                l
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let cfg = d.join("close-planes.toml");
    std::fs::write(&cfg, text).unwrap();
    let log = close_on_one_and_two_threads(&d, &surface, &cfg);
    assert_eq!(log["solver"]["converged"], true);
    assert_eq!(log["solver"]["stopped_by"], "converged");
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
    for (k, bits) in contact_bits(&after, &contact).into_iter().enumerate() {
        assert_eq!(
            bits.count_ones(),
            2,
            "leaflet {} touches planes {bits:b}",
            k + 1
        );
    }
}

/// The sample valve closes with true leaflet-to-leaflet contact (the
/// barrier; the pipeline's default): converged, the same bytes whatever the
/// thread count, every leaflet touching both others, no crossing triangle
/// pair by the rule of leaflets.json, and no triangle pair of different
/// leaflets meeting at all that did not meet where the closure started, the
/// sutured leaflets (exact triangle–triangle tests; neighbours sewn to the
/// same commissure post meet there, in a point).
#[test]
fn sample_valve_closes_with_leaflet_contact_without_crossing() {
    use coapt::geom::bvh::Bvh;
    use coapt::geom::tri_tri;
    use coapt::io::vtp;
    use coapt::mech::element::V3;
    let d = tmpdir("close-leaflets");
    let surface = sample_leaflets(&d);
    let cfg = repo().join("pipelines/close.toml");
    let log = close_on_one_and_two_threads(&d, &surface, &cfg);
    assert_eq!(log["config"]["contact"], "leaflets");
    assert_eq!(log["solver"]["converged"], true);
    assert_eq!(log["intersecting_triangle_pairs"], 0);
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
    let after = vtp::read_mesh(&d.join("closed1.vtp")).unwrap();
    let mut before = after.clone();
    let sewn = after
        .point_data
        .get("sutured_position")
        .expect("the closure sutured first")
        .values
        .to_f64()
        .unwrap();
    for (i, p) in before.vertices.iter_mut().enumerate() {
        *p = coapt::geom::Point3::new(sewn[3 * i], sewn[3 * i + 1], sewn[3 * i + 2]);
    }
    let (c0, c1) = (crossing(&before), crossing(&after));
    assert!(
        c1.iter().all(|p| c0.contains(p)),
        "{} crossing pairs after, {} before",
        c1.len(),
        c0.len()
    );
    // What meets is the commissure seams: triangles that both have a
    // sutured node (leaflets.json's sewn contacts).
    assert_eq!(log["sewn_contacts"], c1.len());
    let bnd = after
        .point_data
        .get("boundary")
        .unwrap()
        .values
        .to_f64()
        .unwrap();
    let strip = |t: u32| {
        after.triangles[t as usize]
            .iter()
            .any(|&k| bnd[k as usize] == 1.0)
    };
    assert!(c1.iter().all(|&(i, j)| strip(i) && strip(j)), "{c1:?}");
    // Suturing kept them apart too (it sews with the same barrier).
    assert!(c0.iter().all(|&(i, j)| strip(i) && strip(j)), "{c0:?}");
    // Every leaflet touches both others (contact bits are leaflet numbers).
    let contact = after
        .point_data
        .get("contact")
        .unwrap()
        .values
        .to_f64()
        .unwrap();
    for (k, bits) in contact_bits(&after, &contact).into_iter().enumerate() {
        assert_eq!(bits.count_ones(), 2, "leaflet {} touches {bits:b}", k + 1);
        assert_eq!(bits & (1 << k), 0, "leaflet {} touches itself", k + 1);
    }
}

/// The suturing pre-stage (seed 001 Algorithm 1) runs by default on placed
/// leaflets: closure.json records its rounds (K doubling from k0 until
/// max sin φ < 0.01), closed.vtp carries the sutured positions with the
/// sutures unmoved, and the closure's displacement is measured from the
/// placed leaflets. Leaflets that say they are sutured (field data
/// `sutured` = 1) are closed as they are, and `mode = "off"` does the same.
#[test]
fn placed_leaflets_are_sutured_first_unless_they_say_they_are() {
    use coapt::geom::{DataArray, DataValues};
    use coapt::io::vtp;
    let d = tmpdir("close-suture");
    let surface = sample_leaflets(&d);
    let cfg = repo().join("pipelines/close.toml");
    let run = |leaflets: &Path, cfg: &Path, name: &str| {
        let out = d.join(format!("{name}.vtp"));
        let log = d.join(format!("{name}.json"));
        let o = close(
            leaflets,
            &surface,
            cfg,
            &out,
            &[
                "--valve",
                &s(&d.join("valve.json")),
                "--log",
                &s(&log),
                "--quiet",
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        (vtp::read_mesh(&out).unwrap(), json(&log))
    };
    let (closed, log) = run(&d.join("leaflets.vtp"), &cfg, "sewn");
    let su = &log["suturing"];
    assert_eq!(su["status"], "sewn", "{su}");
    assert!(su["max_sin_phi"].as_f64().unwrap() < 0.01);
    assert!(su["initial_max_sin_phi"].as_f64().unwrap() > 0.5);
    let rounds = su["rounds"].as_array().unwrap();
    assert!(rounds.len() > 3);
    for (i, r) in rounds.iter().enumerate() {
        assert_eq!(
            r["k_n_per_mm"].as_f64().unwrap(),
            64.0 * 2f64.powi(i as i32)
        );
    }
    assert_eq!(log["config"]["reference"], "sutured");
    let placed = vtp::read_mesh(&d.join("leaflets.vtp")).unwrap();
    let bnd = placed
        .point_data
        .get("boundary")
        .unwrap()
        .values
        .to_f64()
        .unwrap();
    let sewn = closed
        .point_data
        .get("sutured_position")
        .unwrap()
        .values
        .to_f64()
        .unwrap();
    let disp = closed
        .point_data
        .get("displacement")
        .unwrap()
        .values
        .to_f64()
        .unwrap();
    let mut moved = 0.0f64;
    for (i, p) in placed.vertices.iter().enumerate() {
        let q = coapt::geom::Point3::new(sewn[3 * i], sewn[3 * i + 1], sewn[3 * i + 2]);
        if bnd[i] == 1.0 {
            assert_eq!(q, *p, "suturing moved a sutured node");
        }
        moved = moved.max((q - p).norm());
        let c = closed.vertices[i];
        for k in 0..3 {
            assert!((c[k] - p[k] - disp[3 * i + k]).abs() < 1e-9);
        }
    }
    assert!(moved > 0.5, "suturing moved nothing ({moved} mm)");

    // The same leaflets, marked as sutured: closed from where they are.
    let mut marked = placed.clone();
    marked
        .field_data
        .insert(DataArray::new("sutured", 1, DataValues::U8(vec![1])));
    let mpath = d.join("marked.vtp");
    std::fs::write(&mpath, {
        let mut b = Vec::new();
        vtp::encode(&mut b, &marked.to_polydata(), &vtp::WriteOptions::default()).unwrap();
        b
    })
    .unwrap();
    let (c_marked, log_marked) = run(&mpath, &cfg, "marked-closed");
    assert!(
        log_marked["suturing"]
            .as_str()
            .unwrap()
            .contains("say they are sutured")
    );
    assert!(c_marked.point_data.get("sutured_position").is_none());
    let text = std::fs::read_to_string(&cfg).unwrap() + "\n[suture]\nmode = \"off\"\n";
    let off = d.join("off.toml");
    std::fs::write(&off, text).unwrap();
    let (c_off, log_off) = run(&d.join("leaflets.vtp"), &off, "off");
    assert!(log_off["suturing"].as_str().unwrap().contains("off"));
    assert_eq!(c_off.vertices, c_marked.vertices);
    assert_ne!(c_off.vertices, closed.vertices);
}
