//! Tests on the sample preset (or smaller grids) so they take seconds.
//! Generation time per preset is measured by `coapt bench phantom` and
//! `cargo bench --bench phantom`, never by a test.

use std::sync::OnceLock;

use super::shapes::Sdf;
use super::*;
use coapt_geom::Vector3;

fn sample() -> &'static Phantom {
    static P: OnceLock<Phantom> = OnceLock::new();
    P.get_or_init(|| generate(&PhantomParams::new(Preset::Sample, 7), &|_| {}).unwrap())
}

/// Rebuild the analytic lumen the phantom was made from.
pub(super) fn anatomy_of(params: &PhantomParams) -> anatomy::Anatomy {
    let (dims, spacing) = params.grid_shape();
    anatomy::Anatomy::new(
        params.seed,
        params.tilt_rad,
        [0, 1, 2].map(|a| dims[a] as f64 * spacing[a]),
        params.extras(),
    )
    .unwrap()
    .0
}

fn stats(v: impl Iterator<Item = f64>) -> (f64, f64, usize) {
    let (mut n, mut s, mut s2) = (0usize, 0.0, 0.0);
    for x in v {
        n += 1;
        s += x;
        s2 += x * x;
    }
    let m = s / n.max(1) as f64;
    (m, (s2 / n.max(1) as f64 - m * m).max(0.0).sqrt(), n)
}

#[test]
fn preset_parse_and_validate() {
    for p in [Preset::Sample, Preset::Standard, Preset::Full] {
        assert_eq!(p.to_string().parse::<Preset>().unwrap(), p);
    }
    assert!("huge".parse::<Preset>().is_err());
    let ok = PhantomParams::new(Preset::Sample, 1);
    ok.validate().unwrap();
    let mut bad = ok.clone();
    bad.noise_hu = 250.0;
    assert!(bad.validate().is_err());
    let mut bad = ok.clone();
    bad.tilt_rad = 70f64.to_radians();
    assert!(bad.validate().is_err());
    let mut bad = ok.clone();
    bad.spacing_mm = Some([0.1, 1.0, 1.0]);
    assert!(bad.validate().is_err());
    let mut bad = PhantomParams::new(Preset::Full, 1);
    bad.spacing_mm = Some([0.2, 0.2, 0.2]);
    assert!(bad.validate().unwrap_err().to_string().contains("voxels"));
    let mut bad = ok.clone();
    bad.blood_hu = 50.0;
    assert!(bad.validate().unwrap_err().to_string().contains("blood"));
}

#[test]
fn truth_surface_is_closed_and_matches_analytic_volume() {
    let ph = sample();
    let m = &ph.truth_surface;
    m.sanity_check().unwrap();
    let topo = m.topology();
    assert_eq!(topo.boundary_edges, 0);
    assert_eq!(topo.euler_characteristic, 2);
    assert_eq!(topo.components, 1);
    let v = m.signed_volume();
    let t = &ph.truth;
    assert!(v > 0.0);
    let rel = (v - t.lumen_volume_mm3).abs() / t.lumen_volume_mm3;
    assert!(
        rel < 0.005,
        "surface volume {v} vs analytic {}",
        t.lumen_volume_mm3
    );
    assert!(
        m.vertices.len() * 24 <= 1_050_000,
        "{} vertices",
        m.vertices.len()
    );
    let region = m.cell_data.get("region").unwrap();
    assert_eq!(region.tuples(), m.triangles.len());
    // Wall edges (the fan caps have long spokes by design).
    let wall_edge = (0..m.triangles.len())
        .filter(|&t| matches!(&region.values, coapt_geom::DataValues::I32(r) if r[t] == 0))
        .map(|t| m.quality(t).max_edge)
        .fold(0.0, f64::max);
    // The sample's ~1 MB vertex budget puts its grid near 0.5 mm, so its
    // quad diagonals reach ~0.75 mm (standard/full keep every edge ≤ 0.5 mm).
    assert!(wall_edge < 0.8, "longest wall edge {wall_edge} mm");
}

#[test]
fn truth_mask_volume_matches_analytic_volume() {
    let t = &sample().truth;
    let rel = (t.truth_mask_volume_mm3 - t.lumen_volume_mm3).abs() / t.lumen_volume_mm3;
    assert!(
        rel < 0.03,
        "mask {} vs analytic {} mm³",
        t.truth_mask_volume_mm3,
        t.lumen_volume_mm3
    );
}

#[test]
fn surface_vertices_and_landmarks_lie_on_the_wall() {
    let params = PhantomParams::new(Preset::Sample, 7);
    let an = anatomy_of(&params);
    let ph = sample();
    let m = &ph.truth_surface;
    let normals = m.vertex_normals();
    let region = match &m.cell_data.get("region").unwrap().values {
        coapt_geom::DataValues::I32(v) => v.clone(),
        _ => panic!("region is Int32"),
    };
    // Wall-only vertices (not on a cap ring): inside/outside flips across them.
    let mut on_cap = vec![false; m.vertices.len()];
    for (t, tri) in m.triangles.iter().enumerate() {
        if region[t] != 0 {
            for &v in tri {
                on_cap[v as usize] = true;
            }
        }
    }
    let mut checked = 0;
    for (v, p) in m.vertices.iter().enumerate() {
        if on_cap[v] {
            continue;
        }
        let n = normals[v];
        assert!(
            an.lumen.inside(&(p - n * 0.05)),
            "vertex {v} not inside just below the wall"
        );
        assert!(
            !an.lumen.inside(&(p + n * 0.05)),
            "vertex {v} not outside just above the wall"
        );
        checked += 1;
    }
    assert!(checked > 1000);
    for label in ["C1", "C2", "C3", "N1", "N2", "N3"] {
        let p = ph.landmarks.get(label).unwrap();
        let l = an.lumen.local(&p);
        let r = an.lumen.profile.eval(l.station.s, l.theta).r;
        assert!((l.rho - r).abs() < 1e-9, "{label}: rho {} r {r}", l.rho);
    }
    // Commissure triangle: circumcentre on the axis.
    let c = ph.landmarks.require(&["C1", "C2", "C3"]).unwrap();
    let (a, b) = (c[1] - c[0], c[2] - c[0]);
    let n = a.cross(&b);
    let cc =
        c[0] + (b * a.norm_squared() - a * b.norm_squared()).cross(&n) / (2.0 * n.norm_squared());
    let vf = &ph.truth.valve_frame;
    let d = cc - vf.origin_mm;
    let off_axis = (d - vf.axis * d.dot(&vf.axis)).norm();
    assert!(off_axis < 1.0, "circumcentre {off_axis} mm off the axis");
    // Nadirs in the VAJ plane, commissures at h_comm.
    for (k, ck) in c.iter().enumerate() {
        let (h, _, _) = vf.to_cylindrical(&ph.landmarks.get(&format!("N{}", k + 1)).unwrap());
        assert!(h.abs() < 1e-9);
        let (h, _, _) = vf.to_cylindrical(ck);
        assert!((h - ph.truth.h_comm_mm).abs() < 1e-9);
    }
}

#[test]
fn anatomy_ranges_and_orientation() {
    for seed in (0u64..10).chain([99, 12345]) {
        let params = PhantomParams::new(Preset::Sample, seed);
        let an = anatomy_of(&params);
        let p = &an.lumen.profile;
        let r_a = p.r_annulus_mm;
        assert!((11.0..=13.0).contains(&r_a));
        for k in 0..3 {
            let ratio = p.sinus_max(k) / r_a;
            assert!(
                (1.28..=1.47).contains(&ratio),
                "seed {seed} sinus {k}: {ratio}"
            );
        }
        let c = p.commissure_angles_rad;
        for gap in [
            c[1] - c[0],
            c[2] - c[1],
            c[0] + std::f64::consts::TAU - c[2],
        ] {
            assert!((gap.to_degrees() - 120.0).abs() <= 8.0 + 1e-9);
        }
        // Right-coronary sinus faces anterior (−y), left-coronary left-posterior,
        // non-coronary right-posterior.
        let dir = |k: usize| {
            let w = an.lumen.wall_point(0.0, p.sinus_centre(k)) - an.lumen.centreline.origin;
            Vector3::new(w.x, w.y, 0.0).normalize()
        };
        assert!(dir(0).y < -0.5, "seed {seed}: RCS {:?}", dir(0));
        assert!(
            dir(1).x > 0.2 && dir(1).y > -0.2,
            "seed {seed}: LCS {:?}",
            dir(1)
        );
        assert!(
            dir(2).x < -0.2 && dir(2).y > -0.2,
            "seed {seed}: NCS {:?}",
            dir(2)
        );
        // The PA passes 1.5–3 mm from the aortic lumen where closest, the LA
        // 3–5 mm.
        let (dims, spacing) = params.grid_shape();
        let (_, needs) = anatomy::Anatomy::new(
            seed,
            params.tilt_rad,
            [0, 1, 2].map(|a| dims[a] as f64 * spacing[a]),
            params.extras(),
        )
        .unwrap();
        let gap = an.pa_aorta_gap(needs.z_top + 30.0);
        assert!((1.5..=3.0).contains(&gap), "seed {seed}: PA gap {gap}");
        let gap = an.la_aorta_gap(needs.z_top + 30.0);
        assert!((3.0..=5.0).contains(&gap), "seed {seed}: LA gap {gap}");
        // The LV overlaps the LVOT near its end (blood path LV → root), and
        // stays below the VAJ by more than the blend width.
        let cl = &an.lumen.centreline;
        let lvot_end = cl.origin - cl.axis * (an.lumen.lvot_length_mm - 1.0);
        assert!(
            an.lv.eval(&lvot_end).0 < 0.0,
            "seed {seed}: LV detached from LVOT"
        );
        for s in [0.0, 5.0, 10.0] {
            for k in 0..12 {
                let w = an.lumen.wall_point(s, k as f64 * 0.5);
                assert!(
                    an.lv.eval(&w).0 > anatomy::LV_BLEND_MM,
                    "seed {seed}: LV near the root wall"
                );
            }
        }
        // Coronary ostia halfway up the sinus, on the wall.
        for c in &an.coronaries {
            let f = c.ostium_height_mm / p.h_stj_mm;
            assert!((0.4..=0.6).contains(&f));
            let l = an.lumen.local(&c.ostium);
            assert!((l.rho - p.eval(l.station.s, l.theta).r).abs() < 1e-9);
        }
    }
}

#[test]
fn image_realism_on_sample() {
    let ph = sample();
    let t = &ph.truth;
    let ct = ph.ct.as_slice();
    let mask = ph.truth_mask.as_slice();
    let [ni, nj, nk] = ph.ct.dims();
    // Voxels deep inside the mask (all 6 neighbours at distance 2 inside).
    let idx = |i: usize, j: usize, k: usize| i + ni * (j + nj * k);
    let mut deep = Vec::new();
    for k in 2..nk - 2 {
        for j in 2..nj - 2 {
            for i in 2..ni - 2 {
                if mask[idx(i, j, k)] == 1
                    && mask[idx(i - 2, j, k)] == 1
                    && mask[idx(i + 2, j, k)] == 1
                    && mask[idx(i, j - 2, k)] == 1
                    && mask[idx(i, j + 2, k)] == 1
                    && mask[idx(i, j, k - 2)] == 1
                    && mask[idx(i, j, k + 2)] == 1
                {
                    deep.push(idx(i, j, k));
                }
            }
        }
    }
    let (mean, std, n) = stats(deep.iter().map(|&v| ct[v] as f64));
    assert!(n > 5000);
    assert!((mean - t.blood_hu).abs() < 0.1 * t.blood_hu, "mean {mean}");
    // The ±5 % blood field adds a little spread on top of the noise.
    assert!((std - t.noise_hu).abs() < 0.2 * t.noise_hu, "std {std}");

    // Top slice: both AA and DA are bright discs.
    let k = nk - 1;
    let an = anatomy_of(&PhantomParams::new(Preset::Sample, 7));
    let z = ph.ct.index_to_world([0.0, 0.0, k as f64]).z;
    let s = an.lumen.centreline.s_at_z_vertical(z);
    let aa = an.lumen.centreline.station(s).point;
    let da = Point3::new(an.da.cx, an.da.cy, z);
    for (name, c, r) in [
        ("AA", aa, an.lumen.profile.r_ascending_mm * 0.9),
        ("DA", da, an.da.rx),
    ] {
        let ijk = ph.ct.world_to_index(&c);
        let (ci, cj) = (ijk[0].round() as i64, ijk[1].round() as i64);
        let rv = (0.6 * r / ph.ct.spacing()[0]) as i64;
        let vals = (-rv..=rv)
            .flat_map(|dj| (-rv..=rv).map(move |di| (di, dj)))
            .filter_map(|(di, dj)| {
                let (i, j) = (ci + di, cj + dj);
                (i >= 0
                    && j >= 0
                    && (i as usize) < ni
                    && (j as usize) < nj
                    && di * di + dj * dj <= rv * rv)
                    .then(|| ct[idx(i as usize, j as usize, k)] as f64)
            });
        let (m, _, n) = stats(vals);
        assert!(n > 50, "{name} disc not in the top slice");
        assert!(m > 0.8 * t.blood_hu, "{name} mean {m}");
    }
    // Between AA and DA the top slice is not bright (separate circles).
    let mid = Point3::new(0.5 * (aa.x + da.x), 0.5 * (aa.y + da.y), z);
    let ijk = ph.ct.world_to_index(&mid);
    let v = ct[idx(ijk[0].round() as usize, ijk[1].round() as usize, k)] as f64;
    assert!(
        v < 0.5 * t.blood_hu,
        "AA and DA touch on the top slice ({v} HU midway)"
    );
}

#[test]
fn no_contrast_blood_is_dark() {
    let mut p = PhantomParams::new(Preset::Sample, 7);
    p.contrast = false;
    p.spacing_mm = Some([1.8, 1.8, 2.0]);
    let ph = generate(&p, &|_| {}).unwrap();
    let (mean, _, n) = stats(
        ph.ct
            .as_slice()
            .iter()
            .zip(ph.truth_mask.as_slice())
            .filter(|(_, m)| **m == 1)
            .map(|(v, _)| *v as f64),
    );
    assert!(n > 1000);
    assert!(mean < 100.0, "mean {mean}");
}

/// Flood fill over bright voxels (> threshold) from `seed`.
fn bright_component(ct: &Volume<i16>, seed: [usize; 3], threshold: i16) -> Vec<bool> {
    let [ni, nj, nk] = ct.dims();
    let v = ct.as_slice();
    let mut seen = vec![false; v.len()];
    let mut stack = vec![seed];
    let id = |p: [usize; 3]| p[0] + ni * (p[1] + nj * p[2]);
    seen[id(seed)] = true;
    while let Some(p) = stack.pop() {
        for a in 0..3 {
            for d in [-1i64, 1] {
                let mut q = p;
                let x = q[a] as i64 + d;
                if x < 0 || x as usize >= [ni, nj, nk][a] {
                    continue;
                }
                q[a] = x as usize;
                if !seen[id(q)] && v[id(q)] > threshold {
                    seen[id(q)] = true;
                    stack.push(q);
                }
            }
        }
    }
    seen
}

#[test]
fn coronaries_connect_to_the_sinus_lumen() {
    // Without noise so "bright" is unambiguous; finer grid than the sample.
    let mut p = PhantomParams::new(Preset::Sample, 7);
    p.noise_hu = 0.0;
    let ph = generate(&p, &|_| {}).unwrap();
    let an = anatomy_of(&p);
    let ct = &ph.ct;
    let seed_p = an.lumen.wall_point(0.5 * an.lumen.profile.h_stj_mm, 0.0);
    let c = an
        .lumen
        .centreline
        .station(0.5 * an.lumen.profile.h_stj_mm)
        .point;
    let mid = Point3::from((seed_p.coords + c.coords) * 0.5);
    let ijk = ct.world_to_index(&mid).map(|x| x.round() as usize);
    let comp = bright_component(ct, ijk, (0.5 * p.blood_hu) as i16);
    for cor in &an.coronaries {
        // A point 6 mm beyond the ostium along the artery.
        let t = &cor.tubes[0];
        let pts = t.points();
        let q = pts[1] + (pts[2] - pts[1]).normalize() * 2.0;
        let qi = ct.world_to_index(&q).map(|x| x.round() as usize);
        let id = ct.linear_index(qi[0], qi[1], qi[2]);
        assert!(comp[id], "{} not connected to the sinus lumen", cor.name);
    }
}

#[test]
fn determinism_across_thread_counts() {
    let mut p = PhantomParams::new(Preset::Sample, 11);
    p.spacing_mm = Some([1.5, 1.5, 1.6]);
    p.calcium = true;
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| generate(&p, &|_| {}).unwrap())
    };
    let a = run(1);
    let b = run(2);
    let c = run(2);
    assert_eq!(a.ct.as_slice(), b.ct.as_slice());
    assert_eq!(b.ct.as_slice(), c.ct.as_slice());
    assert_eq!(a.truth_mask.as_slice(), b.truth_mask.as_slice());
    assert_eq!(a.truth_surface.vertices, b.truth_surface.vertices);
    assert_eq!(
        serde_json::to_string(&a.truth).unwrap(),
        serde_json::to_string(&b.truth).unwrap()
    );
}

#[test]
fn calcium_is_bright_and_excluded_from_the_mask() {
    let mut p = PhantomParams::new(Preset::Sample, 7);
    p.calcium = true;
    p.noise_hu = 0.0;
    let ph = generate(&p, &|_| {}).unwrap();
    assert!(ph.truth.calcium_in_lumen_mm3 > 0.0);
    let an = anatomy_of(&p);
    for e in &an.calcium {
        let ijk = ph.ct.world_to_index(&e.centre).map(|x| x.round() as usize);
        let id = ph.ct.linear_index(ijk[0], ijk[1], ijk[2]);
        assert!(
            ph.ct.as_slice()[id] > 400,
            "calcium blob at {:?} not bright",
            e.centre
        );
    }
    let plain = sample();
    assert!(ph.truth.truth_mask_voxels <= plain.truth.truth_mask_voxels);
}

#[test]
fn spacing_override_keeps_the_fov_and_tilt_zero_works() {
    let mut p = PhantomParams::new(Preset::Sample, 5);
    p.spacing_mm = Some([1.8, 1.8, 2.0]);
    p.tilt_rad = 0.0;
    let ph = generate(&p, &|_| {}).unwrap();
    assert_eq!(ph.ct.dims(), [56, 56, 56]);
    let fov = Preset::Sample.fov();
    for (a, f) in fov.iter().enumerate() {
        assert!((ph.ct.dims()[a] as f64 * ph.ct.spacing()[a] - f).abs() < 1e-9);
    }
    let t = &ph.truth;
    assert!(t.centreline.arc.is_none());
    let a = t.valve_frame.axis;
    assert!((a - Vector3::z()).norm() < 1e-12);
    let rel = (t.truth_surface_volume_mm3 - t.lumen_volume_mm3).abs() / t.lumen_volume_mm3;
    assert!(rel < 0.005);
    let rel = (t.truth_mask_volume_mm3 - t.lumen_volume_mm3).abs() / t.lumen_volume_mm3;
    assert!(rel < 0.06, "coarse mask {rel}");
}

#[test]
fn every_tilt_fits_the_sample_and_keeps_exact_truth() {
    for tilt_deg in [0.0, 20.0, 45.0, 60.0] {
        let mut p = PhantomParams::new(Preset::Sample, 3);
        p.tilt_rad = f64::to_radians(tilt_deg);
        p.spacing_mm = Some([1.8, 1.8, 2.0]);
        p.noise_hu = 0.0;
        let seen = std::sync::Mutex::new(Vec::new());
        let ph = generate(&p, &|f| seen.lock().unwrap().push(f)).unwrap();
        let t = &ph.truth;
        let rel = (t.truth_surface_volume_mm3 - t.lumen_volume_mm3).abs() / t.lumen_volume_mm3;
        assert!(rel < 0.005, "tilt {tilt_deg}: surface volume off by {rel}");
        let axis = t.valve_frame.axis;
        assert!((axis.z.acos().to_degrees() - tilt_deg).abs() < 1e-9);
        // Right-anterior: both x and y components non-positive.
        assert!(axis.x <= 1e-12 && axis.y <= 1e-12);
        let seen = seen.into_inner().unwrap();
        assert!(seen.iter().all(|f| (0.0..=1.0).contains(f)));
        assert!(
            seen.windows(2).all(|w| w[0] <= w[1]),
            "progress went backwards"
        );
        assert_eq!(*seen.last().unwrap(), 1.0);
        // The lumen leaves through the top face on its vertical piece.
        let top = t.top_cap_s_mm;
        let s2 = t.centreline.straight_ascending.s_start_mm;
        assert!(
            top - s2 >= 10.0,
            "tilt {tilt_deg}: only {} mm vertical",
            top - s2
        );
        // At least 40 mm of ascending aorta above the STJ.
        assert!(top - t.h_stj_mm >= 40.0);
    }
}

#[test]
fn truth_json_has_the_documented_keys() {
    let v = serde_json::to_value(&sample().truth).unwrap();
    for key in [
        "preset",
        "seed",
        "dims",
        "spacing_mm",
        "affine",
        "valve_frame",
        "commissures_mm",
        "nadirs_mm",
        "commissure_angles_deg",
        "h_stj_mm",
        "h_comm_mm",
        "radii",
        "coronaries",
        "centreline",
        "lumen_volume_mm3",
        "truth_mask_voxels",
        "truth_mask_volume_mm3",
        "truth_surface_area_mm2",
        "definitions",
    ] {
        assert!(v.get(key).is_some(), "truth.json lacks {key}");
    }
    for d in ["truth_mask", "valve_frame", "nadir", "commissure"] {
        assert!(v["definitions"].get(d).is_some());
    }
}

#[test]
fn no_coronaries_removes_them_from_ct_and_truth_only() {
    // Without noise so the ostium HU is unambiguous.
    let mut p = PhantomParams::new(Preset::Sample, 7);
    p.noise_hu = 0.0;
    let with = generate(&p, &|_| {}).unwrap();
    let mut q = p.clone();
    q.coronaries = false;
    let without = generate(&q, &|_| {}).unwrap();
    let an = anatomy_of(&p);
    assert_eq!(an.coronaries.len(), 2);
    assert_eq!(with.truth.coronaries.len(), 2);
    assert!(without.truth.coronaries.is_empty());
    assert!(with.truth.layers.iter().any(|l| l.starts_with("coronary_")));
    assert!(
        !without
            .truth
            .layers
            .iter()
            .any(|l| l.starts_with("coronary_"))
    );
    // The truth mask excludes coronaries by construction: it, the surface
    // and the landmarks are the same phantom's.
    assert_eq!(with.truth_mask.as_slice(), without.truth_mask.as_slice());
    assert_eq!(with.truth_surface.vertices, without.truth_surface.vertices);
    assert_eq!(with.truth.nadirs_mm, without.truth.nadirs_mm);
    // 2 mm beyond each ostium along the artery: blood with, tissue without.
    let ct = &with.ct;
    let mut changed_far = 0usize;
    for cor in &an.coronaries {
        let pts = cor.tubes[0].points();
        let x = pts[1] + (pts[2] - pts[1]).normalize() * 2.0;
        let i = ct.world_to_index(&x).map(|v| v.round() as usize);
        let id = ct.linear_index(i[0], i[1], i[2]);
        assert!(with.ct.as_slice()[id] as f64 > 0.6 * p.blood_hu);
        assert!((without.ct.as_slice()[id] as f64) < 0.3 * p.blood_hu);
    }
    // Only voxels near the coronaries differ (the rest is bit for bit).
    for (v, (a, b)) in with
        .ct
        .as_slice()
        .iter()
        .zip(without.ct.as_slice())
        .enumerate()
    {
        if a != b {
            let [ni, nj, _] = ct.dims();
            let w = ct.index_to_world([
                (v % ni) as f64,
                ((v / ni) % nj) as f64,
                (v / (ni * nj)) as f64,
            ]);
            let near = an
                .coronaries
                .iter()
                .any(|c| c.tubes.iter().any(|t| t.eval(&w).0 < 3.0));
            changed_far += (!near) as usize;
        }
    }
    assert_eq!(changed_far, 0, "voxels changed away from the coronaries");
}

#[test]
fn coronaries_switch_is_deterministic() {
    let mut p = PhantomParams::new(Preset::Sample, 3);
    p.spacing_mm = Some([1.5, 1.5, 1.6]);
    p.coronaries = false;
    let a = generate(&p, &|_| {}).unwrap();
    let b = generate(&p, &|_| {}).unwrap();
    assert_eq!(a.ct.as_slice(), b.ct.as_slice());
    assert_eq!(
        serde_json::to_string(&a.truth).unwrap(),
        serde_json::to_string(&b.truth).unwrap()
    );
}
