//! Known-answer geometry for the coaptation measures: three folded sheets
//! whose wings lie on the 120° commissural planes, a gap g apart from the
//! neighbour's wing from z0 up to the free edge z1, and (optionally) below z0
//! a skirt that opens at an angle β, so the zone's lower boundary is where
//! 2·a(z)·cos β = margin, with a(z) = g/2 + (z0 − z)·tan β the offset of a
//! wing from its plane.

use std::f64::consts::PI;

use super::coaptation::{self, Options};
use super::metrics::{self, Metrics};
use super::orifice;
use super::*;
use super::{clip, symmetry};
use coapt_geom::{Point3, ValveFrame, Vector3};

const W: f64 = 8.0; // wing width along the plane, mm
const Z0: f64 = 6.0;
const Z1: f64 = 10.0;
const GAP: f64 = 0.2;
const MARGIN: f64 = 0.9;

fn frame() -> ValveFrame {
    let c = |k: usize| {
        let a = 2.0 * PI * k as f64 / 3.0;
        Point3::new(W * a.cos(), W * a.sin(), Z1)
    };
    ValveFrame::new(Point3::origin(), Vector3::z(), [c(0), c(1), c(2)], None).unwrap()
}

/// Leaflet `k`'s 120° sector: its first commissural angle, the unit
/// directions of its two commissural planes and their normals into it.
fn sector(k: usize) -> (f64, [Vector3; 4]) {
    let ta = 2.0 * PI * k as f64 / 3.0;
    let tb = ta + 2.0 * PI / 3.0;
    (
        ta,
        [
            Vector3::new(ta.cos(), ta.sin(), 0.0),
            Vector3::new(tb.cos(), tb.sin(), 0.0),
            Vector3::new(-ta.sin(), ta.cos(), 0.0),
            Vector3::new(tb.sin(), -tb.cos(), 0.0),
        ],
    )
}

/// The folded-sheet valve, meshed with spacing `h`; skirt from `zb` to Z0
/// opening at `beta` (radians).
fn sheets(h: f64, zb: f64, beta: f64) -> ClosedValve {
    let ns = (2.0 * W / h).round() as usize;
    let nz = ((Z1 - zb) / h).round() as usize;
    let mut x = Vec::new();
    let mut uv = Vec::new();
    let mut boundary = Vec::new();
    let mut tris = Vec::new();
    let mut tri_leaflet = Vec::new();
    for k in 0..3 {
        let (_, [ua, ub, na, nb]) = sector(k);
        let base = x.len() as u32;
        for iz in 0..=nz {
            let z = zb + (Z1 - zb) * iz as f64 / nz as f64;
            let a = GAP / 2.0 + (Z0 - z).max(0.0) * beta.tan();
            let apex = a / 3f64.sqrt();
            for is in 0..=ns {
                let s = -W + 2.0 * W * is as f64 / ns as f64;
                let (u, n) = if s < 0.0 { (ua, na) } else { (ub, nb) };
                let p = (apex + s.abs()) * u + a * n + z * Vector3::z();
                x.push(Point3::from(p));
                uv.push([s, z]);
                boundary.push(if iz == nz {
                    if is == 0 || is == ns { 1 } else { 2 }
                } else if is == 0 || is == ns {
                    // The wings' outer ends are sutured to the wall; the
                    // bottom row is left free so the lumen outline (from
                    // the sutures) is the wall circle.
                    1
                } else {
                    0
                });
            }
        }
        grid(base, nz, ns, k as u8, &mut tris, &mut tri_leaflet);
    }
    ClosedValve {
        x0: x.clone(),
        x,
        tris,
        tri_leaflet,
        boundary,
        ref_uv: Some(uv),
        frame: frame(),
        leaflets: 3,
    }
}

/// Two triangles per cell of leaflet `k`'s (nz + 1) × (ns + 1) node grid,
/// numbered from `base` row by row.
fn grid(base: u32, nz: usize, ns: usize, k: u8, tris: &mut Vec<[u32; 3]>, leaf: &mut Vec<u8>) {
    let id = |iz: usize, is: usize| base + (iz * (ns + 1) + is) as u32;
    for iz in 0..nz {
        for is in 0..ns {
            tris.push([id(iz, is), id(iz, is + 1), id(iz + 1, is + 1)]);
            tris.push([id(iz, is), id(iz + 1, is + 1), id(iz + 1, is)]);
            leaf.extend([k, k]);
        }
    }
}

fn measure(v: &ClosedValve) -> (coaptation::Coaptation, Metrics) {
    let c = coaptation::find(
        v,
        &Options {
            margin_mm: MARGIN,
            refine: 4,
        },
    );
    let m = metrics::measure(v, &c, &metrics::Options::default());
    (c, m)
}

/// Lower boundary of the zone on the skirt (closed form above).
fn z_star(beta: f64) -> f64 {
    Z0 - (MARGIN / (2.0 * beta.cos()) - GAP / 2.0) / beta.tan()
}

#[test]
fn parallel_sheets_coapt_over_their_whole_height_with_a_central_zone() {
    let v = sheets(0.5, Z0, 0.0);
    let (c, m) = measure(&v);
    let near = |a: Option<f64>, b: f64, tol: f64| {
        let a = a.expect("measured");
        assert!((a - b).abs() <= tol, "{a} vs {b}");
    };
    near(m.coaptation_height_mm, Z1 - Z0, 1e-9);
    near(m.central_coaptation_height_mm, Z1 - Z0, 1e-9);
    near(m.h_cc_mm, Z1 - Z0, 1e-9);
    near(m.effective_height_mm, Z1, 1e-9);
    assert!(m.closed);
    assert_eq!(m.coaptation_above_vaj, Some(true));
    near(m.lowest_central_coaptation_mm, Z0, 1e-9);
    for l in &m.leaflets {
        // Every point touches a neighbour: the zone is the whole leaflet.
        assert!(
            (l.coaptation_area_mm2 - 2.0 * W * (Z1 - Z0)).abs() < 1e-9,
            "{l:?}"
        );
        assert!((l.cusp_area_closed_mm2 - 2.0 * W * (Z1 - Z0)).abs() < 1e-9);
        assert!((l.free_edge_length_mm - 2.0 * W).abs() < 1e-9);
        // Exactly +0, not −0 or round-off: a report prints it.
        assert_eq!(
            l.billowing_mm.to_bits(),
            0f64.to_bits(),
            "{}",
            l.billowing_mm
        );
    }
    near(m.ncca, 1.0, 1e-12);
    near(m.h_avr_mm, Z1 - Z0, 1e-9);
    // Vertical sheets hide nothing seen along the axis: the orifice is the
    // whole lumen (radius W + apex offset at the sutured ends).
    let r = W + GAP / 2.0 / 3f64.sqrt();
    let lumen = (r * r + (GAP / 2.0).powi(2)) * PI;
    let (l, o) = (
        m.lumen_area_mm2.unwrap(),
        m.regurgitant_orifice_area_mm2.unwrap(),
    );
    assert!((l - lumen).abs() / lumen < 0.01, "{l}");
    assert!((o - l).abs() < 0.02 * lumen);
    assert!(c.node_mask.iter().all(|&b| b.count_ones() >= 1));
}

/// Sheets whose middles are pushed 1 mm off the axis along their own
/// bisectors: the wings still touch pairwise, but no point is within the
/// margin of both other leaflets. "Coaptation above the VAJ" then places
/// the pairwise zones rather than calling itself not measurable.
#[test]
fn without_a_triple_zone_the_vaj_criterion_places_the_pairwise_zones() {
    let mut v = sheets(0.5, Z0, 0.0);
    let uv = v.ref_uv.clone().unwrap();
    let per = v.x.len() / 3;
    for (i, p) in v.x.iter_mut().enumerate() {
        let (ta, _) = sector(i / per);
        let mid = ta + PI / 3.0;
        if uv[i][0].abs() < 1.5 {
            *p += Vector3::new(mid.cos(), mid.sin(), 0.0);
        }
    }
    let (_, m) = measure(&v);
    assert!(!m.closed);
    assert_eq!(m.lowest_central_coaptation_mm, None);
    let any = m.lowest_coaptation_mm.expect("the wings touch pairwise");
    assert!((any - Z0).abs() < 1e-9, "{any}");
    assert_eq!(m.coaptation_above_vaj, Some(true));
}

#[test]
fn skirt_places_the_zone_boundary_where_the_gap_reaches_the_margin() {
    let beta = 10f64.to_radians();
    let zs = z_star(beta);
    for h in [0.5, 0.25] {
        let v = sheets(h, 2.0, beta);
        let (_, m) = measure(&v);
        let ch = m.coaptation_height_mm.unwrap();
        assert!(
            (ch - (Z1 - zs)).abs() < 0.05,
            "h {h}: coaptation height {ch} vs {}",
            Z1 - zs
        );
        let hcc = m.h_cc_mm.unwrap();
        assert!((hcc - (Z1 - zs)).abs() < 0.05, "h {h}: h_cc {hcc}");
        assert!((m.lowest_coaptation_mm.unwrap() - zs).abs() < 0.05);
        for p in &m.pairs {
            let s = p.base_to_margin_mm.expect("base and margin lines");
            // The base line on the skirt is (Z1 − z*) below the free edge
            // and (a* − g/2) off the vertical part.
            let a = MARGIN / (2.0 * beta.cos());
            let d = (Z1 - zs).hypot(a - GAP / 2.0);
            assert!((s.max - d).abs() < 0.05, "h {h}: max {} vs {d}", s.max);
            assert!(s.p50 <= s.p75 && s.p75 <= s.p90 && s.min <= s.p10);
        }
    }
}

#[test]
fn heights_change_less_than_a_tenth_of_a_millimetre_when_h_halves() {
    let beta = 10f64.to_radians();
    let (_, a) = measure(&sheets(0.5, 2.0, beta));
    let (_, b) = measure(&sheets(0.25, 2.0, beta));
    for (x, y) in [
        (a.coaptation_height_mm, b.coaptation_height_mm),
        (
            a.central_coaptation_height_mm,
            b.central_coaptation_height_mm,
        ),
        (a.effective_height_mm, b.effective_height_mm),
        (a.h_cc_mm, b.h_cc_mm),
    ] {
        let (x, y) = (x.unwrap(), y.unwrap());
        assert!((x - y).abs() <= 0.1, "{x} vs {y}");
    }
    let (x, y) = (
        a.leaflets[0].coaptation_area_mm2,
        b.leaflets[0].coaptation_area_mm2,
    );
    assert!((x - y).abs() / y < 0.01, "area {x} vs {y}");
}

#[test]
fn metrics_do_not_move_with_the_valve() {
    let v = sheets(0.5, 2.0, 10f64.to_radians());
    let (_, a) = measure(&v);
    let rot = nalgebra::Rotation3::from_euler_angles(0.3, -1.1, 2.0);
    let shift = Vector3::new(-20.0, 7.5, -160.0);
    let mv = |p: &Point3| rot * p + shift;
    let mut w = v.clone();
    w.x = v.x.iter().map(mv).collect();
    w.x0 = w.x.clone();
    let f = &v.frame;
    w.frame = ValveFrame::new(
        mv(&f.origin_mm),
        rot * f.axis,
        f.commissures_mm.map(|c| mv(&c)),
        None,
    )
    .unwrap();
    let (_, b) = measure(&w);
    let same = |x: Option<f64>, y: Option<f64>| {
        assert!((x.unwrap() - y.unwrap()).abs() < 1e-6, "{x:?} {y:?}")
    };
    same(a.coaptation_height_mm, b.coaptation_height_mm);
    same(
        a.central_coaptation_height_mm,
        b.central_coaptation_height_mm,
    );
    same(a.effective_height_mm, b.effective_height_mm);
    same(a.h_cc_mm, b.h_cc_mm);
    same(a.ncca, b.ncca);
    // The orifice raster is aligned with the valve frame and moves with it;
    // only pixel centres within rounding of an edge may flip.
    let (x, y) = (
        a.regurgitant_orifice_area_mm2.unwrap(),
        b.regurgitant_orifice_area_mm2.unwrap(),
    );
    assert!(
        (x - y).abs() < 1e-3 * a.lumen_area_mm2.unwrap(),
        "{x} vs {y}"
    );
}

/// Three flat sectors at z = 0 closing a disc of radius `r`, the third one
/// trimmed to leave a known wedge open.
#[test]
fn orifice_of_a_disc_with_a_missing_wedge() {
    let r = 10.0;
    let n = 60;
    let mut x = Vec::new();
    let mut tris = Vec::new();
    let mut leaf = Vec::new();
    let mut boundary = Vec::new();
    // Leaflet k covers angles [120k, 120k + 120) except the last 30° of leaflet 2.
    for k in 0..3 {
        let a0 = (120.0 * k as f64).to_radians();
        let span = if k == 2 { 90f64 } else { 120.0 }.to_radians();
        let c = x.len() as u32;
        x.push(Point3::origin());
        boundary.push(2);
        for i in 0..=n {
            let a = a0 + span * i as f64 / n as f64;
            x.push(Point3::new(r * a.cos(), r * a.sin(), 0.0));
            boundary.push(1);
        }
        for i in 0..n as u32 {
            tris.push([c, c + 1 + i, c + 2 + i]);
            leaf.push(k as u8);
        }
    }
    let v = ClosedValve {
        x0: x.clone(),
        x,
        tris,
        tri_leaflet: leaf,
        boundary,
        ref_uv: None,
        frame: ValveFrame::new(
            Point3::origin(),
            Vector3::z(),
            [0.0, 120.0, 240.0]
                .map(|d: f64| Point3::new(r * d.to_radians().cos(), r * d.to_radians().sin(), 0.0)),
            None,
        )
        .unwrap(),
        leaflets: 3,
    };
    let o = orifice::measure(&v, 0.02, 0.0);
    // Inscribed 60-gons per sector; the open wedge is a quarter of a sector.
    let sector = 0.5 * r * r * n as f64 * (120f64.to_radians() / n as f64).sin();
    let wedge = sector / 4.0;
    assert!(
        (o.lumen_mm2 - PI * r * r).abs() / (PI * r * r) < 0.005,
        "{}",
        o.lumen_mm2
    );
    assert!(
        (o.uncovered_mm2 - wedge - (PI * r * r - 3.0 * sector)).abs() < 0.5,
        "{} vs {wedge}",
        o.uncovered_mm2
    );
}

/// Seed 001 §3.1: one leaflet closed between two contact planes. The
/// report's zone (distance to the mirror images ≤ 0.02 R) must be the
/// paper's (signed distance to the plane ≤ 0.01 R), here evaluated exactly
/// on every triangle (the plane distance is linear on it).
#[test]
fn one_leaflet_closure_reproduces_the_seed_zone() {
    use coapt_mech::peer;
    // The mechanics' kept peer leaflet, equal to what `coapt bench close`
    // builds (`tests/it/peer_fixture.rs`).
    let mech_dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../mech");
    let (l, axis) = peer::read_leaflet(&peer::fixture_path(&mech_dir, 1.0)).unwrap();
    let cfg =
        coapt_mech::config::parse(&peer::config_text_with("svk", "newton", 120.0, true)).unwrap();
    let closed = coapt_mech::closure::close(&l, &cfg, Some(axis)).unwrap();
    assert!(closed.outcome.converged, "{}", closed.outcome.reason);
    let c = |a: f64| Point3::new(peer::R * a.cos(), peer::R * a.sin(), 0.0);
    let frame = ValveFrame::new(
        Point3::new(0.0, 0.0, -(peer::HC + peer::HB)),
        Vector3::z(),
        [c(0.0), c(2.0 * PI / 3.0), c(4.0 * PI / 3.0)],
        None,
    )
    .unwrap();
    let one = ClosedValve {
        x: closed.x.iter().map(|p| Point3::from(*p)).collect(),
        x0: l.x.iter().map(|p| Point3::from(*p)).collect(),
        tris: l.tris.clone(),
        tri_leaflet: vec![0; l.tris.len()],
        boundary: l.boundary.clone(),
        ref_uv: l.ref_uv.clone(),
        frame,
        leaflets: 1,
    };
    let (v, planes) = symmetry::complete(&one).expect("two lug corners");
    let tol = 0.01 * peer::R;
    let co = coaptation::find_with_planes(
        &v,
        &Options {
            margin_mm: 2.0 * tol,
            refine: 4,
        },
        &planes,
    );
    // Reference: exact clip of each triangle by the plane-distance field.
    let d = peer::plane_distances(&l, &closed.x);
    let mut seed = [0.0; 2];
    for t in &l.tris {
        for (k, s) in seed.iter_mut().enumerate() {
            let poly: Vec<(Point3, f64)> = t
                .iter()
                .map(|&i| (Point3::from(closed.x[i as usize]), d[i as usize][k] - tol))
                .collect();
            *s += clip::area(&clip::clip_below(&poly).0);
        }
    }
    let ours = [co.pair[0][1].area_mm2, co.pair[0][2].area_mm2];
    // Match mirror images to planes by area (their order is the planes').
    let (a, b) = if (ours[0] - seed[0]).abs() + (ours[1] - seed[1]).abs()
        <= (ours[0] - seed[1]).abs() + (ours[1] - seed[0]).abs()
    {
        (ours, seed)
    } else {
        ([ours[1], ours[0]], seed)
    };
    for k in 0..2 {
        assert!(b[k] > 5.0, "the seed zone is not empty: {b:?}");
        assert!(
            (a[k] - b[k]).abs() <= 1e-9 * b[k],
            "zone area {a:?} vs seed {b:?} mm²"
        );
    }
}

// ------------------------------------------------------------ the verdict

use super::criteria::{self as crit, Anatomy, Pressures, Thresholds};
use super::verdict::{self, Status};

/// A closed valve that meets every criterion by construction: each leaflet
/// is the folded sheet above (wings on the 120° planes, GAP apart, from z0
/// to its free edge at z1) over a flat floor at z0 that covers its 120°
/// sector of the lumen out to radius W (sutured on the arc), so seen along
/// the axis the floors tile the disc. `trim_deg` cuts that many degrees off
/// the end of leaflet 3's floor (an uncovered wedge).
fn cups(z0: f64, z1: f64, zc: f64, trim_deg: f64) -> ClosedValve {
    let (h, nr, na) = (0.5, 16usize, 48usize);
    let ns = (2.0 * W / h).round() as usize;
    let nz = ((z1 - z0) / h).round() as usize;
    let mut x = Vec::new();
    let mut uv = Vec::new();
    let mut boundary = Vec::new();
    let mut tris = Vec::new();
    let mut tri_leaflet = Vec::new();
    for k in 0..3 {
        let (ta, [ua, ub, na_, nb]) = sector(k);
        let a = GAP / 2.0;
        let apex = a / 3f64.sqrt();
        let base = x.len() as u32;
        for iz in 0..=nz {
            let z = z0 + (z1 - z0) * iz as f64 / nz as f64;
            for is in 0..=ns {
                let s = -W + 2.0 * W * is as f64 / ns as f64;
                let (u, n) = if s < 0.0 { (ua, na_) } else { (ub, nb) };
                x.push(Point3::from(
                    (apex + s.abs()) * u + a * n + z * Vector3::z(),
                ));
                uv.push([s, z]);
                boundary.push(if is == 0 || is == ns {
                    1
                } else if iz == nz {
                    2
                } else {
                    0
                });
            }
        }
        grid(base, nz, ns, k as u8, &mut tris, &mut tri_leaflet);
        // The floor: a fan around the axis, then rings out to W.
        let span = 2.0 * PI / 3.0 - if k == 2 { trim_deg.to_radians() } else { 0.0 };
        let centre = x.len() as u32;
        x.push(Point3::new(0.0, 0.0, z0));
        uv.push([100.0, 0.0]);
        boundary.push(0);
        let ring0 = x.len() as u32;
        for i in 1..=nr {
            for j in 0..=na {
                let (r, t) = (W * i as f64 / nr as f64, ta + span * j as f64 / na as f64);
                x.push(Point3::new(r * t.cos(), r * t.sin(), z0));
                uv.push([100.0 + r * t.cos(), r * t.sin()]);
                boundary.push(if i == nr { 1 } else { 0 });
            }
        }
        let q = |i: usize, j: usize| ring0 + ((i - 1) * (na + 1) + j) as u32;
        for j in 0..na {
            tris.push([centre, q(1, j), q(1, j + 1)]);
            tri_leaflet.push(k as u8);
            for i in 1..nr {
                tris.push([q(i, j), q(i + 1, j), q(i + 1, j + 1)]);
                tris.push([q(i, j), q(i + 1, j + 1), q(i, j + 1)]);
                tri_leaflet.extend([k as u8, k as u8]);
            }
        }
    }
    // The commissures sit 0.25 rad off the seams so that no floor edge runs
    // along the orifice raster's rows (the frame's e1 points at C1): an
    // edge on a row of pixel centres is counted whole on one side, half a
    // pixel times its length (0.2 mm² here) of bias.
    let c = |k: usize| {
        let a = 2.0 * PI * k as f64 / 3.0 + 0.25;
        Point3::new(W * a.cos(), W * a.sin(), zc)
    };
    ClosedValve {
        x0: x.clone(),
        x,
        tris,
        tri_leaflet,
        boundary,
        ref_uv: Some(uv),
        frame: ValveFrame::new(Point3::origin(), Vector3::z(), [c(0), c(1), c(2)], None).unwrap(),
        leaflets: 3,
    }
}

const Z_FLOOR: f64 = 0.5;
const Z_EDGE: f64 = 10.0;
const Z_COMM: f64 = 12.0;
const Z_STJ: f64 = 14.0;

fn anatomy(v: &ClosedValve, stj: Result<f64, String>) -> Anatomy {
    Anatomy::new(&v.frame, stj)
}

const P80: Pressures = Pressures {
    closing_mmhg: Some(80.0),
    low_mmhg: None,
};

fn clean_log() -> serde_json::Value {
    serde_json::json!({"solver": {"converged": true, "reason": "converged"}, "intersecting_triangle_pairs": 0})
}

/// (criteria, verdict) of `v` with a clean closure.json.
fn judged(v: &ClosedValve, stj: Result<f64, String>) -> (Vec<crit::Criterion>, verdict::Verdict) {
    let (_, m) = measure(v);
    let c = crit::judge(&m, &Thresholds::default(), &anatomy(v, stj), &P80);
    let d = verdict::decide(&c, verdict::gates(Some(&clean_log())));
    (c, d)
}

fn value(c: &[crit::Criterion], id: &str) -> f64 {
    match c.iter().find(|c| c.id == id).expect(id).value {
        crit::Value::Mm(Some(v)) | crit::Value::Mm2(Some(v)) => v,
        other => panic!("{id}: {other:?}"),
    }
}

#[test]
fn a_valve_built_to_meet_every_criterion_meets_them_all() {
    let v = cups(Z_FLOOR, Z_EDGE, Z_COMM, 0.0);
    let (c, d) = judged(&v, Ok(Z_STJ));
    let ids: Vec<&str> = c.iter().map(|c| c.id).collect();
    assert_eq!(
        ids,
        [
            "central_coaptation",
            "effective_height",
            "coaptation_below_commissures",
            "coaptation_above_vaj",
            "leaflets_below_stj",
            "no_billowing",
            "no_prolapse",
            "no_residual_regurgitation",
            "closed"
        ]
    );
    let near = |id: &str, want: f64| {
        let got = value(&c, id);
        assert!((got - want).abs() < 1e-9, "{id}: {got} vs {want}");
    };
    near("central_coaptation", Z_EDGE - Z_FLOOR);
    near("effective_height", Z_EDGE);
    near("coaptation_below_commissures", Z_COMM - Z_EDGE);
    near("leaflets_below_stj", Z_STJ - Z_EDGE);
    near("no_billowing", 0.0);
    // The floors tile the disc; what is left is the sliver between the
    // floors' chords and the outline bridged through the wings' sutured
    // ends, well under the 1 mm² bound.
    let o = value(&c, "no_residual_regurgitation");
    assert!(o < 0.3, "orifice {o} mm²");
    assert!(c.iter().all(|c| c.pass == Some(true)), "{c:#?}");
    assert_eq!(d.status, Status::MeetsAllCriteria);
    assert!(d.assessable && d.meets_all_criteria && d.not_assessable_reasons.is_empty());
}

#[test]
fn crossings_an_unconverged_solve_or_no_log_make_a_passing_valve_not_assessable() {
    let v = cups(Z_FLOOR, Z_EDGE, Z_COMM, 0.0);
    let (c, _) = judged(&v, Ok(Z_STJ));
    let mut crossing = clean_log();
    crossing["intersecting_triangle_pairs"] = 594.into();
    let mut unconverged = clean_log();
    unconverged["solver"] = serde_json::json!({"converged": false, "reason": "iteration limit"});
    let mut low = clean_log();
    low["low_pressure"] =
        serde_json::json!({"pressure_mmhg": 3.0, "converged": false, "reason": "stalled"});
    let mut unrecorded = clean_log();
    unrecorded
        .as_object_mut()
        .unwrap()
        .remove("intersecting_triangle_pairs");
    for (log, words) in [
        (Some(&crossing), "594 pairs of triangles"),
        (Some(&unconverged), "did not converge (iteration limit)"),
        (
            Some(&low),
            "low-pressure closure (3.0 mmHg) did not converge",
        ),
        (Some(&unrecorded), "does not record whether leaflets cross"),
        (None, "no closure.json"),
    ] {
        let d = verdict::decide(&c, verdict::gates(log));
        assert_eq!(d.status, Status::NotAssessable, "{words}");
        assert!(!d.assessable && !d.meets_all_criteria);
        assert_eq!(d.not_assessable_reasons.len(), 1, "{d:?}");
        assert!(d.not_assessable_reasons[0].contains(words), "{d:?}");
        assert!(verdict::summary(&d, true, &c).starts_with("Not assessable: "));
    }
}

#[test]
fn a_central_point_lifted_above_the_commissures_fails_that_criterion() {
    // Free edges 0.5 mm above the commissure tips.
    let v = cups(Z_FLOOR, Z_COMM + 0.5, Z_COMM, 0.0);
    let (c, d) = judged(&v, Ok(Z_STJ));
    assert!((value(&c, "coaptation_below_commissures") + 0.5).abs() < 1e-9);
    assert_eq!(d.status, Status::FailsCriteria);
    assert_eq!(d.failed, ["coaptation_below_commissures"]);
    assert!(!d.meets_all_criteria);
}

#[test]
fn a_leaflet_above_the_stj_fails_and_an_unknown_stj_is_not_measurable() {
    let v = cups(Z_FLOOR, Z_EDGE, Z_COMM, 0.0);
    let (c, d) = judged(&v, Ok(Z_EDGE - 1.0));
    assert!((value(&c, "leaflets_below_stj") + 1.0).abs() < 1e-9);
    assert_eq!(d.failed, ["leaflets_below_stj"]);
    assert_eq!(d.status, Status::FailsCriteria);
    let (c, d) = judged(&v, Err("valve.json has no sections.stj".into()));
    let stj = c.iter().find(|c| c.id == "leaflets_below_stj").unwrap();
    assert_eq!((stj.value, stj.pass), (crit::Value::Mm(None), None));
    assert_eq!(d.status, Status::NotAssessable);
    assert!(d.failed.is_empty() && !d.meets_all_criteria);
    assert!(
        d.not_assessable_reasons[0].contains("Leaflets below the STJ is not measurable"),
        "{d:?}"
    );
}

#[test]
fn an_uncovered_wedge_above_the_bound_fails_no_residual_regurgitation() {
    let (c0, _) = judged(&cups(Z_FLOOR, Z_EDGE, Z_COMM, 0.0), Ok(Z_STJ));
    let (c, d) = judged(&cups(Z_FLOOR, Z_EDGE, Z_COMM, 6.0), Ok(Z_STJ));
    // The missing 6° of leaflet 3's floor: a sector of radius W (its
    // 48-chord floor differs from the arc by < 0.01 mm²).
    let wedge = 0.5 * W * W * 6f64.to_radians();
    let extra = value(&c, "no_residual_regurgitation") - value(&c0, "no_residual_regurgitation");
    assert!((extra - wedge).abs() < 0.05, "{extra} vs {wedge} mm²");
    assert_eq!(d.failed, ["no_residual_regurgitation"]);
    assert_eq!(d.status, Status::FailsCriteria);
}

/// Leaflet 1's floor, 2.5–5.5 mm from the axis and away from both seams,
/// sunk `depth` mm below the plane of the lowest sutured points, while the
/// free edge stays at Z_EDGE (billowing, not prolapse).
fn sunk_belly(depth: f64) -> ClosedValve {
    let mut v = cups(Z_FLOOR, Z_EDGE, Z_COMM, 0.0);
    let mut moved = 0;
    for (k, p) in v.x.iter_mut().enumerate() {
        let (r, a) = (p.x.hypot(p.y), p.y.atan2(p.x));
        if v.boundary[k] == 0
            && (p.z - Z_FLOOR).abs() < 1e-12
            && (2.5..=5.5).contains(&r)
            && (0.4..=1.7).contains(&a)
            && !(p.x.abs() < 1.0 || (a - 2.0 * PI / 3.0).abs() < 0.3)
        {
            p.z = Z_FLOOR - depth;
            moved += 1;
        }
    }
    assert!(moved > 20, "{moved}");
    v
}

#[test]
fn a_belly_pushed_below_the_annulus_plane_fails_no_billowing() {
    // The seeds' group's bound is 1.4 mm: a belly 1 mm deep is within it,
    // 2 mm is billowing.
    for (depth, fails) in [(1.0, false), (2.0, true)] {
        let v = sunk_belly(depth);
        let (_, m) = measure(&v);
        assert!((m.leaflets[0].billowing_mm - depth).abs() < 1e-12);
        assert_eq!(m.leaflets[1].billowing_mm, 0.0);
        let c = crit::judge(&m, &Thresholds::default(), &anatomy(&v, Ok(Z_STJ)), &P80);
        let d = verdict::decide(&c, verdict::gates(Some(&clean_log())));
        assert!((value(&c, "no_billowing") - depth).abs() < 1e-12);
        let expected: &[&str] = if fails { &["no_billowing"] } else { &[] };
        assert_eq!(d.failed, expected, "belly {depth} mm deep");
        assert!(m.lowest_free_edge_mm > 0.0);
    }
}

#[test]
fn the_criterion_judges_the_low_pressure_effective_height_when_there_is_one() {
    let v = cups(Z_FLOOR, Z_EDGE, Z_COMM, 0.0);
    let (_, mut m) = measure(&v);
    // The same leaflets 0.8 mm lower at 3 mmHg: h_E 9.2 mm passes, and a
    // loaded value below 9 mm would not decide.
    let low: Vec<Point3> = v.x.iter().map(|p| p - Vector3::z() * 0.8).collect();
    m.effective_height_low_pressure_mm = metrics::effective_height_at(&v, &low, 3);
    m.effective_height_mm = Some(8.0);
    let p = Pressures {
        closing_mmhg: Some(80.0),
        low_mmhg: Some(3.0),
    };
    let c = crit::judge(&m, &Thresholds::default(), &anatomy(&v, Ok(Z_STJ)), &p);
    let e = c.iter().find(|c| c.id == "effective_height").unwrap();
    assert!((value(&c, "effective_height") - (Z_EDGE - 0.8)).abs() < 1e-9);
    assert_eq!(e.pass, Some(true));
    assert!(
        e.note.contains("at 3 mmHg") && e.note.contains("(80 mmHg) it is 8.00 mm"),
        "{}",
        e.note
    );
    // Without the low-pressure closure the loaded 8 mm is judged: fails.
    m.effective_height_low_pressure_mm = None;
    let c = crit::judge(&m, &Thresholds::default(), &anatomy(&v, Ok(Z_STJ)), &P80);
    assert_eq!(c[1].pass, Some(false));
    assert!(c[1].note.contains("at 80 mmHg"), "{}", c[1].note);
}

#[test]
fn the_stj_is_placed_from_the_commissure_cylinder_or_not_at_all() {
    use coapt_io::valve_json::stj_height;
    // Annulus 17 mm below the commissure cylinder's centre, commissures on
    // the centre's plane, STJ section 1.5 mm above it: 18.5 mm above the
    // annulus.
    let tilt = Vector3::new(0.3, -0.2, 1.0).normalize();
    let e1 = tilt.cross(&Vector3::x()).normalize();
    let e2 = tilt.cross(&e1);
    let centre = Point3::new(-20.0, 10.0, -150.0);
    let origin = centre - tilt * 17.0;
    let c = |a: f64| centre + (e1 * a.cos() + e2 * a.sin()) * 12.0;
    let f = ValveFrame::new(origin, tilt, [c(0.0), c(2.1), c(4.2)], None).unwrap();
    let mut v = serde_json::json!({
        "sections": {"stj": {"height_mm": 1.5}},
        "commissure_cylinder": {"centre_mm": [centre.x, centre.y, centre.z]},
        "h_comm_mm": 17.0,
    });
    let s = stj_height(&v, &f).unwrap();
    assert!((s - 18.5).abs() < 1e-9, "{s}");
    v["h_comm_mm"] = 16.0.into();
    assert!(stj_height(&v, &f).unwrap_err().contains("does not match"));
    v["sections"]["stj"] = serde_json::Value::Null;
    assert!(stj_height(&v, &f).unwrap_err().contains("no STJ section"));
    let old = serde_json::json!({"valve_frame": {}});
    assert!(
        stj_height(&old, &f)
            .unwrap_err()
            .contains("older or hand-written")
    );
}

/// Two leaflets pressed together by true contact keep their mid-surfaces
/// a thickness apart: seen along the axis, their bare mid-surfaces leave
/// that slit open, their solids (half the thickness each side) close it.
#[test]
fn the_orifice_counts_the_leaflets_thickness() {
    let v = slit_valve(0.4);
    let bare = orifice::measure(&v, 0.02, 0.0);
    let solid = orifice::measure(&v, 0.02, 0.2);
    // The slit: 0.4 mm wide across the 20 mm lumen, less its ends.
    assert!(
        (bare.uncovered_mm2 - 0.4 * 20.0).abs() < 0.6,
        "bare {}",
        bare.uncovered_mm2
    );
    assert!(solid.uncovered_mm2 < 0.05, "solid {}", solid.uncovered_mm2);
    assert!((bare.lumen_mm2 - solid.lumen_mm2).abs() < 1e-9);
}

/// Two flat half-discs of radius 10 mm at z = 0 (the rim sutured), `w` mm
/// apart across x = 0.
fn slit_valve(w: f64) -> ClosedValve {
    let (r, n) = (10.0f64, 60);
    let a0 = (0.5 * w / r).acos();
    let (mut x, mut tris, mut leaf, mut boundary) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (k, side) in [1.0f64, -1.0].into_iter().enumerate() {
        let c = x.len() as u32;
        x.push(Point3::new(side * 0.5 * w, 0.0, 0.0));
        boundary.push(2);
        for i in 0..=n {
            let a = -a0 + 2.0 * a0 * i as f64 / n as f64;
            x.push(Point3::new(side * r * a.cos(), r * a.sin(), 0.0));
            boundary.push(1);
        }
        for i in 0..n as u32 {
            tris.push([c, c + 1 + i, c + 2 + i]);
            leaf.push(k as u8);
        }
    }
    ClosedValve {
        x0: x.clone(),
        x,
        tris,
        tri_leaflet: leaf,
        boundary,
        ref_uv: None,
        frame: ValveFrame::new(
            Point3::origin(),
            Vector3::z(),
            [90.0, 210.0, 330.0]
                .map(|d: f64| Point3::new(r * d.to_radians().cos(), r * d.to_radians().sin(), 0.0)),
            None,
        )
        .unwrap(),
        leaflets: 2,
    }
}

/// "refs [21–25]", "[18, 19]", "[21]" → every number in them.
fn cited_numbers(text: &str) -> Vec<u32> {
    let mut out = Vec::new();
    for part in text.split('[').skip(1) {
        let Some(inside) = part.split(']').next() else {
            continue;
        };
        for item in inside.split(',') {
            let bounds: Vec<u32> = item
                .split(['–', '-'])
                .filter_map(|x| x.trim().parse().ok())
                .collect();
            match bounds.as_slice() {
                [a] => out.push(*a),
                [a, b] if a <= b => out.extend(*a..=*b),
                _ => {}
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// A researcher can trace every criterion to a full reference: each
/// bracketed number and named source the criteria cite is in the page's
/// References section.
#[test]
fn every_cited_source_is_in_the_references() {
    use crate::references::REFERENCES;
    let labels: Vec<&str> = REFERENCES.iter().map(|r| r.label).collect();
    let v = cups(Z_FLOOR, Z_EDGE, Z_COMM, 0.0);
    let (c, _) = judged(&v, Ok(Z_STJ));
    let cited: String = c.iter().map(|c| c.source).collect::<Vec<_>>().join(" ");
    let numbers = cited_numbers(&cited);
    assert_eq!(numbers, vec![18, 19, 21, 22, 23, 24, 25], "{cited}");
    for n in numbers {
        let label = format!("[{n}]");
        assert!(
            labels.contains(&label.as_str()),
            "{label} is cited, not listed"
        );
    }
    for (named, label) in [
        ("seed 001", "seed 001"),
        ("seeds 000/002", "seed 000"),
        ("seeds 000/002", "seed 002"),
        ("Marom", "Marom et al."),
        ("ASE/EACVI", "ASE/EACVI"),
        ("membrane_model", "membrane_model"),
    ] {
        assert!(cited.contains(named), "{named} no longer cited: {cited}");
        assert!(labels.contains(&label), "{label} is cited, not listed");
    }
}
