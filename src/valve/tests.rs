//! Suture paths on the ideal cylinder against seed 001 eq. 1–2.

use std::collections::BTreeMap;
use std::f64::consts::PI;

use super::stage::{SPEC, compute};
use super::wall::Wall;
use super::{cylinder, suture};
use crate::leaflet::template::{Template, TemplateSpec};
use crate::pipeline::Params;
use crate::units::Length;

const R: f64 = 15.0;
const HC: f64 = 1.5;
const HB: f64 = 15.0;

fn params() -> Params {
    Params::resolve(&SPEC, BTreeMap::new()).unwrap()
}

/// Length of the planar eq. 1 curve with l = R·2π/3 (no gaps).
fn eq1_length() -> f64 {
    let l = R * 2.0 * PI / 3.0;
    let n = 200_000;
    let (a, b) = (l / 2.0, HB);
    let quarter: f64 = (0..n)
        .map(|i| {
            let u = (i as f64 + 0.5) / n as f64 * PI / 2.0;
            (a * u.cos()).hypot(b * u.sin()) * (PI / 2.0 / n as f64)
        })
        .sum();
    2.0 * HC + 2.0 * quarter
}

#[test]
fn paths_on_the_ideal_cylinder_follow_eq_1_and_2() {
    let mesh = cylinder::mesh(R, -25.0, 30.0, 1440, 1.0);
    let wall = Wall::new(&mesh).unwrap();
    let (c, n) = cylinder::landmarks(R, HC, HB);
    let r = compute(&mesh, &wall, &c, Some(&n), None, &params()).unwrap();
    // Facet sagitta of a 1440-gon of radius 15 mm: 15·(1 − cos(π/1440)) ≈ 3.6e-5 mm.
    let sag = R * (1.0 - (PI / 1440.0).cos());
    for (k, p) in r.paths.iter().enumerate() {
        assert!((p[0] - c[k]).norm() < 1e-12 && (p[p.len() - 1] - c[(k + 1) % 3]).norm() < 1e-12);
        let mid = 2.0 * PI * (k as f64 + 0.5) / 3.0;
        let half = R * PI / 3.0;
        let dn = p
            .iter()
            .map(|q| (q - n[k]).norm())
            .fold(f64::INFINITY, f64::min);
        assert!(dn < 1e-9, "nadir missed by {dn}");
        for q in p {
            let rad = q.x.hypot(q.y);
            // Facets plus 0.2 mm path chords (0.2²/(8R) ≈ 3.3e-4 mm).
            assert!(rad <= R + 1e-9 && rad >= R - sag - 4e-4, "radius {rad}");
            let xb = R * super::frame::wrap(q.y.atan2(q.x) - mid);
            if q.z < -HC - 1e-9 {
                // Elliptic part of eq. 1 (chords of 0.2 mm sag ≤ 1e-3 mm).
                let e = (xb / half).powi(2) + ((q.z + HC) / HB).powi(2);
                assert!((e - 1.0).abs() < 2e-4, "ellipse residual {}", e - 1.0);
            } else {
                assert!(
                    (xb.abs() - half).abs() < 2e-3,
                    "straight part off by {}",
                    xb.abs() - half
                );
            }
        }
        let len = suture::length(p);
        assert!(
            (len - eq1_length()).abs() < 1e-3 * len,
            "{len} vs {}",
            eq1_length()
        );
    }
    let radii = &r.json["radii"];
    assert!((radii["annulus_mm"].as_f64().unwrap() - R).abs() < 1e-3);
    assert!((radii["commissure_circumradius_mm"].as_f64().unwrap() - R).abs() < 1e-9);
}

#[test]
fn depth_is_matched_to_the_attachment_edge() {
    let mesh = cylinder::mesh(R, -40.0, 40.0, 720, 1.0);
    let wall = Wall::new(&mesh).unwrap();
    let (c, _) = cylinder::landmarks(R, HC, HB);
    let spec = TemplateSpec::Ozaki {
        diameter: Length(19.0),
        lug_height: Length(11.0),
        apex_rise: Length(2.0),
        lug_chord: Length(24.0),
    };
    let t: Template = spec.build().unwrap();
    let ts = [t.clone(), t.clone(), t];
    let r = compute(&mesh, &wall, &c, None, Some(&ts), &params()).unwrap();
    for (k, p) in r.paths.iter().enumerate() {
        let m = &r.json["paths"][k];
        let len = suture::length(p);
        assert!((len - 52.38).abs() < 0.01 * 52.38, "{len}");
        assert!(m["relative_mismatch"].as_f64().unwrap().abs() < 0.01);
        assert!(m["adjusted"].as_bool().unwrap());
    }
}

/// A segmented VAJ cap on a tilted valve is a staircase that can bulge past
/// the annulus level; a suture path at the annulus must land on the wall,
/// not on the cap inside the lumen (the `full` phantom's path 3 did: 64 mm
/// long, points 7–10 mm from the axis of an 11.5 mm annulus).
#[test]
fn radial_projection_ignores_the_caps() {
    let mut mesh = cylinder::mesh(R, 0.0, 30.0, 360, 1.0);
    // The bottom cap's centre pulled 2 mm below the wall's lower rim: a cone.
    let centre = mesh.vertices.len() - 2;
    mesh.vertices[centre].z = -2.0;
    let wall = Wall::new(&mesh).unwrap();
    let o = crate::geom::Point3::new(0.0, 0.0, -0.5);
    let d = crate::geom::Vector3::new(1.0, 0.0, 0.0);
    // Below the wall, the ray meets only the cone (at r = 11.25 mm).
    let all = wall.hits(&o, &d, 100.0);
    assert_eq!(all.len(), 1);
    assert!((all[0] - 11.25).abs() < 0.02, "{all:?}");
    let p = wall.radial(&o, &d, R);
    assert!(
        (p.x.hypot(p.y) - R).abs() < 1e-3 && p.z.abs() < 1e-9,
        "{p:?}"
    );
    // Above the rim, the wall itself is hit.
    let p = wall.radial(&crate::geom::Point3::new(0.0, 0.0, 3.0), &d, R);
    assert!((p.x - R).abs() < 1e-3 && (p.z - 3.0).abs() < 1e-12, "{p:?}");
}
