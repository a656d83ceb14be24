//! Mesh quality on every template (issue acceptance: h = 0.5 mm, minimum
//! angle ≥ 25°, mean shape ≥ 0.9, ≥ 95 % of edges in [0.7h, 1.4h]) and
//! property tests over random template parameters.

use std::f64::consts::PI;

use super::aft::{self, FlatMesh};
use coapt_base::rng::SplitMix64;
use coapt_base::units::{Angle, Length};
use coapt_template::outline::Outline;
use coapt_template::seed001::Seed001;
use coapt_template::{Template, TemplateSpec};

fn all_templates() -> Vec<Template> {
    coapt_template::reference_templates()
}

/// Boundary nodes lie on the outline, in order, at equal arc length per piece.
fn boundary_follows(o: &Outline, m: &FlatMesh, h: f64) {
    let (pts, _) = o.discretise(h);
    assert_eq!(pts.len(), m.n_boundary);
    for (p, q) in pts.iter().zip(&m.nodes) {
        assert_eq!(p, q, "boundary node moved");
    }
}

#[test]
fn quality_on_every_template_at_half_mm() {
    let h = 0.5;
    for t in all_templates() {
        let o = t.outline();
        let m = aft::mesh(&o, h).unwrap_or_else(|e| panic!("{}: {e}", t.name()));
        let s = m.stats(h);
        assert!(m.all_positive(), "{}", t.name());
        assert!(s.min_angle_deg >= 25.0, "{}: {s:?}", t.name());
        assert!(s.mean_shape >= 0.9, "{}: {s:?}", t.name());
        assert!(s.edges_in_range >= 0.95, "{}: {s:?}", t.name());
        // Triangles tile the boundary polygon exactly.
        assert!((s.area_mm2 - m.boundary_polygon_area()).abs() < 1e-9 * s.area_mm2);
        // and that polygon is the outline up to the chord error.
        assert!(
            (s.area_mm2 - o.area()).abs() < 2e-3 * o.area(),
            "{}",
            t.name()
        );
        boundary_follows(&o, &m, h);
    }
}

/// Random parameters across each family's domain: valid ones always mesh
/// with every triangle positive and the outline kept; invalid ones are
/// refused with a message.
#[test]
fn random_templates_mesh_or_are_refused() {
    let mut rng = SplitMix64::new(7);
    let (mut meshed, mut refused) = (0, 0);
    for i in 0..90 {
        let spec = match i % 3 {
            0 => TemplateSpec::FourParameter {
                r: Length(if rng.uniform() < 0.1 {
                    -rng.uniform()
                } else {
                    rng.range(5.0, 20.0)
                }),
                alpha: Angle(rng.range(-10.0, 190.0).to_radians()),
                a: Length(if rng.uniform() < 0.1 {
                    -rng.uniform()
                } else {
                    rng.range(1.0, 25.0)
                }),
                b: Length(rng.range(2.0, 30.0)),
            },
            1 => {
                let h = rng.range(-2.0, 25.0);
                TemplateSpec::Ozaki {
                    diameter: Length(rng.range(9.0, 34.0)),
                    lug_height: Length(h),
                    apex_rise: Length(rng.range(-h, 6.0)),
                    lug_chord: Length(rng.range(5.0, 40.0)),
                }
            }
            _ => TemplateSpec::FiveParameter {
                radius: Length(rng.range(8.0, 20.0)),
                phi: Angle(rng.range(1.0, 2.2)),
                hc: Length(if rng.uniform() < 0.2 {
                    -rng.uniform()
                } else {
                    rng.range(0.5, 4.0)
                }),
                hb: Length(rng.range(5.0, 20.0)),
                omega: Angle(rng.range(-1.2, 0.4)),
            },
        };
        match spec.build(None) {
            Ok(t) => {
                let o = t.outline();
                // The mesher refuses pieces under h/4 (it does not grade).
                let shortest = o
                    .pieces
                    .iter()
                    .map(|p| p.shape.length())
                    .fold(f64::INFINITY, f64::min);
                let h = rng.range(0.6, 1.5).min(4.0 * shortest);
                let m = aft::mesh(&o, h).unwrap_or_else(|e| panic!("{spec:?}: {e}"));
                assert!(m.all_positive(), "{spec:?}");
                let a = m.stats(h).area_mm2;
                assert!((a - m.boundary_polygon_area()).abs() < 1e-9 * a, "{spec:?}");
                boundary_follows(&o, &m, h);
                meshed += 1;
            }
            Err(e) => {
                assert!(
                    e.contains("must")
                        || e.contains("too short")
                        || e.contains("inside")
                        || e.contains("cross"),
                    "{e}"
                );
                refused += 1;
            }
        }
    }
    assert!(
        meshed >= 40 && refused >= 10,
        "{meshed} meshed, {refused} refused"
    );
}

/// Seed 001 §3.1 on the ideal cylinder: attachment = eq. 2, extrusion = eq. 3,
/// areas = ∫ d σ' dt.
#[test]
fn seed001_ideal_cylinder_matches_eq_2_and_3() {
    let s = Seed001::new(15.0, 2.0 * PI / 3.0 - 0.4, 1.5, 15.0, -2.0 * PI / 9.0).unwrap();
    let h = 0.5;
    let m = aft::mesh(&s.outline(), h).unwrap();
    let x = super::place::seed001_local(&s, &m);
    let half = s.l() / 2.0;
    let v = s.v();
    let mut att = 0;
    for (i, p) in x.iter().enumerate() {
        let t = s.t_of_sigma(m.nodes[i][0]);
        let base = s.rc(t);
        let off = [p.x - base[0], p.y - base[1], p.z - base[2]];
        let w = off[0] * v[0] + off[1] * v[1] + off[2] * v[2];
        // Every node lies on the ruling through r_c(t) along v.
        let perp = (0..3)
            .map(|k| (off[k] - w * v[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(perp < 1e-9, "off the ruling by {perp}");
        match m.boundary[i] {
            1 => {
                att += 1;
                // On the cylinder and on the eq. 1 curve, checked in closed form.
                assert!((p.x.hypot(p.y) - 15.0).abs() < 1e-9);
                let xb = 15.0 * p.y.atan2(p.x);
                if p.z < -1e-12 {
                    let e = (xb / half).powi(2) + (p.z / 15.0).powi(2);
                    assert!((e - 1.0).abs() < 1e-9, "ellipse residual {}", e - 1.0);
                } else {
                    assert!((xb.abs() - half).abs() < 1e-9 && p.z <= 1.5 + 1e-9);
                }
            }
            2 => assert!(
                (w - s.d(t)).abs() < 1e-9,
                "extrusion {w} vs eq. 3 {}",
                s.d(t)
            ),
            _ => assert!(w > -1e-9 && w < s.d(t) + 1e-9),
        }
    }
    assert!(att > 80, "{att} attachment nodes");
    let a = s.analytic_area();
    let flat = m.stats(h).area_mm2;
    let area3: f64 = m
        .tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| x[i as usize]);
            (b - a).cross(&(c - a)).norm() / 2.0
        })
        .sum();
    // Chord error of 0.5 mm edges on curves of radius ≥ 7.5 mm: ≤ 0.2 %.
    assert!((flat - a).abs() < 2e-3 * a, "flat {flat} vs {a}");
    assert!((area3 - a).abs() < 2e-3 * a, "3-D {area3} vs {a}");
}

/// Nodes a little outside a real, rough wall go back to 0.05 mm inside it,
/// counted with their distance; sutured nodes stay on their path; nodes
/// inside stay put. The wall: a closed 720-gon cylinder of radius 15 mm
/// (facet sagitta 15·(1 − cos(π/720)) ≈ 1.4e-4 mm).
#[test]
fn nodes_outside_the_wall_are_pulled_back_and_counted() {
    use coapt_geom::Point3;
    use coapt_geom::wall::Wall;
    use coapt_valve::cylinder;
    let wall = Wall::new(&cylinder::mesh(15.0, -10.0, 10.0, 720, 0.5)).unwrap();
    let at = |r: f64, deg: f64, z: f64| {
        let a = deg.to_radians();
        Point3::new(r * a.cos(), r * a.sin(), z)
    };
    let mut x = vec![
        at(10.0, 10.0, 0.0),   // inside
        at(15.3, 33.0, 2.0),   // 0.3 mm out
        at(15.8, 200.0, -4.0), // 0.8 mm out
        at(15.5, 100.0, 1.0),  // out, but sutured: left alone
    ];
    let before = x.clone();
    let p = super::stage::pull_inside(&mut x, &[0, 0, 2, 1], &wall);
    assert_eq!(p.count, 2);
    assert!((p.max_mm - 0.8).abs() < 1e-3, "{}", p.max_mm);
    assert!((p.mean_mm - 0.55).abs() < 1e-3, "{}", p.mean_mm);
    assert_eq!(x[0], before[0]);
    assert_eq!(x[3], before[3]);
    for (i, z) in [(1, 2.0), (2, -4.0)] {
        let r = x[i].x.hypot(x[i].y);
        assert!(
            (r - 14.95).abs() < 1e-3 && (x[i].z - z).abs() < 1e-9,
            "{:?}",
            x[i]
        );
        assert!(wall.contains(&x[i]));
    }
    assert!(!wall.contains(&before[1]) && wall.contains(&before[0]));
}
