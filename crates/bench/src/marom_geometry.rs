//! The template of seed 000's closure benchmark, as close as the project can
//! build it: a native-like tricuspid valve with annulus diameter
//! d_AA = 24 mm.
//!
//! Seed 000 closes "the template from Marom et al. 2013" (J Thorac
//! Cardiovasc Surg 145(2):406–411), which is the parametric native valve and
//! root of Haj-Ali et al. 2012 (J Biomech, "A general three-dimensional
//! parametric geometry of the native aortic valve and root for
//! biomechanical modeling"). Haj-Ali's equations could not be found with the
//! project's search tool (documentation, web pages, code and issue corpora;
//! no implementation of them is stored), and the seeds state none of its
//! parameters. So this is a stand-in built from what the project's sources
//! do state, every choice named here and in docs/verification.md ("Seed
//! 000's closure benchmark"):
//!
//! - **root**: a cylinder of radius R = d_AA / 2 = 12 mm (Haj-Ali's root has
//!   sinuses bulging beyond the annulus and a sinotubular junction; closed
//!   leaflets do not reach the wall, so they are left out);
//! - **attachment lines**: seed 001 eq. 1 on the cylinder (a straight part
//!   H_c = 1.5 mm at each commissure, the peer case's value, then a half
//!   ellipse), each leaflet spanning its full 120° so neighbouring
//!   leaflets meet at the commissures as in a native valve;
//! - **commissure height** above the annulus (the plane of the three
//!   nadirs): 17.8 mm, the seeds' group's ideal (Thubrikar) valve at
//!   R = 12 mm, so H_b = 17.8 − 1.5 = 16.3 mm;
//! - **cusp**: the flat parametric Ozaki outline (the group's; belly
//!   circle D, lug corners H above its centre and L_f apart, free edge to an
//!   apex H_f higher) with the group's H_f = 2 mm, a free edge of
//!   d_AA + 10 = 34 mm (the template-free clinical rule: free margin =
//!   annulus diameter + 10 mm), lug corners as high above the belly's
//!   lowest point as the commissures stand above the nadir (D/2 + H =
//!   17.8 mm), and a belly circle of D = d_AA / 2 = 12 mm;
//! - **placement**: the `leaflets` stage's radial placement with its default
//!   lean ω = −40° (each node at the angle of its attachment point, so the
//!   leaflets stay in their wedges), and this placed shape is the native
//!   valve's stress-free state (no suturing pre-stage: nothing is sewn).
//!
//! Coordinates: mm, the valve axis +z through the origin, the annulus
//! (nadir) plane z = 0, commissures at angles 60°, 180°, 300°.

use std::f64::consts::PI;

use coapt_geom::{Point3, ValveFrame, Vector3};
use coapt_leaflet::aft;
use coapt_leaflet::place::{self, Path3};
use coapt_mech::element::V3;
use coapt_mech::model::{Axis, Leaflets};
use coapt_template::{OzakiTemplate, Template};
use coapt_valve::suture::PathSpec;

/// Annulus diameter d_AA (mm), the seed's.
pub const D_AA: f64 = 24.0;
/// Root radius (mm).
pub const R: f64 = D_AA / 2.0;
/// Commissure height above the nadir plane (mm).
pub const COMMISSURE_HEIGHT: f64 = 17.8;
/// Straight part of the attachment line at each commissure (mm).
pub const HC: f64 = 1.5;
/// Apex rise of the free edge on the flat cusp (mm).
pub const HF: f64 = 2.0;
/// Free-edge length of the flat cusp (mm): d_AA + 10.
pub const FREE_EDGE: f64 = D_AA + 10.0;
/// Belly circle diameter of the flat cusp (mm).
pub const BELLY_D: f64 = D_AA / 2.0;
/// Lean of the placed cusp towards the axis (the `leaflets` default).
pub const OMEGA_DEG: f64 = -40.0;

/// The flat cusp (the same for the three leaflets).
pub fn cusp() -> OzakiTemplate {
    cusp_with(COMMISSURE_HEIGHT).expect("valid native cusp")
}

/// The flat cusp with its lug corners `lug_height` (mm) above the belly's
/// lowest point (the benchmark's cusp: the commissure height), for the
/// sensitivity of the closure to the cusp's geometric height.
pub fn cusp_with(lug_height: f64) -> Result<OzakiTemplate, String> {
    let lf = 2.0 * ((FREE_EDGE / 2.0).powi(2) - HF * HF).sqrt();
    OzakiTemplate::new(BELLY_D, lug_height - BELLY_D / 2.0, HF, lf)
}

/// Angles (rad) of leaflet k's two commissures.
pub fn commissure_angles(k: usize) -> (f64, f64) {
    let a = (2.0 * k as f64 - 1.0) * PI / 3.0;
    (a, a + 2.0 * PI / 3.0)
}

/// Leaflet k's attachment line, points exactly on the cylinder ≈ 0.003 mm
/// apart, commissure to commissure.
pub fn attachment(k: usize) -> Vec<Point3> {
    let (a, b) = commissure_angles(k);
    let spec = PathSpec {
        angle_a: a,
        height_a: COMMISSURE_HEIGHT,
        angle_b: b,
        height_b: COMMISSURE_HEIGHT,
        hc: HC,
        nadir_angle: (a + b) / 2.0,
        nadir_height: 0.0,
    };
    spec.on_cylinder(R)
}

/// The valve frame: origin at the annulus centre, axis +z.
pub fn frame() -> ValveFrame {
    let at = |ang: f64, z: f64| Point3::new(R * ang.cos(), R * ang.sin(), z);
    let c = [0, 1, 2].map(|k| at(commissure_angles(k).0, COMMISSURE_HEIGHT));
    let n = [0, 1, 2].map(|k| {
        let (a, b) = commissure_angles(k);
        at((a + b) / 2.0, 0.0)
    });
    ValveFrame::new(Point3::origin(), Vector3::z(), c, Some(n)).expect("valid frame")
}

/// The three placed leaflets at mesh size `h` (mm): nodes numbered leaflet
/// by leaflet, boundary 1 attached / 2 free, `ref_uv` the flat cusp.
pub fn valve(h: f64) -> Result<(Leaflets, Axis), String> {
    valve_with(h, COMMISSURE_HEIGHT)
}

/// [`valve`] with the cusp of [`cusp_with`]`(lug_height)`.
pub fn valve_with(h: f64, lug_height: f64) -> Result<(Leaflets, Axis), String> {
    if !(h > 0.0 && h.is_finite()) {
        return Err(format!("mesh size h = {h} mm must be positive"));
    }
    let t = Template::Ozaki(cusp_with(lug_height)?);
    let m = aft::mesh(&t.outline(), h)?;
    let (s, w) = place::column_coords(&t, &m);
    let mut l = Leaflets {
        x: Vec::new(),
        tris: Vec::new(),
        boundary: Vec::new(),
        leaflet: Vec::new(),
        ref_uv: Some(Vec::new()),
        fibers: None,
        pressure_side: None,
    };
    for k in 0..3 {
        let path = Path3::new(attachment(k));
        let (x, _omega) = place::place_radial(
            &s,
            &w,
            &path,
            &Vector3::z(),
            &Point3::origin(),
            OMEGA_DEG.to_radians(),
            0.5,
        );
        let base = l.x.len() as u32;
        for (p, &b) in x.iter().zip(&m.boundary) {
            let mut q = p.coords;
            // Attached nodes sit on the path's chords: put them on the
            // cylinder exactly, keeping angle and height.
            if b == 1 {
                let r = q.x.hypot(q.y);
                q.x *= R / r;
                q.y *= R / r;
            }
            l.x.push(q);
        }
        l.boundary.extend_from_slice(&m.boundary);
        l.ref_uv.as_mut().expect("set").extend_from_slice(&m.nodes);
        l.tris.extend(m.tris.iter().map(|t| t.map(|i| i + base)));
        l.leaflet
            .extend(std::iter::repeat_n(k as u16, m.tris.len()));
    }
    Ok((
        l,
        Axis {
            origin: V3::zeros(),
            dir: V3::z(),
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path_length(p: &[Point3]) -> f64 {
        p.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
    }

    /// The defining dimensions: d_AA, commissure height, nadirs on the
    /// annulus plane, full 120° wedges meeting at the commissures, the
    /// cusp's free edge d_AA + 10 and its height, every leaflet inside its
    /// wedge, and no two placed leaflets crossing.
    #[test]
    fn marom_template_has_its_defining_dimensions() {
        let c = cusp();
        assert!((c.free_length() - 34.0).abs() < 1e-12);
        assert!((c.d / 2.0 + c.h - COMMISSURE_HEIGHT).abs() < 1e-12);
        assert_eq!(c.d, 12.0);
        // The attachment line: from commissure to commissure through the
        // nadir, on the cylinder of diameter d_AA.
        for k in 0..3 {
            let p = attachment(k);
            let (a, b) = commissure_angles(k);
            assert!((b - a - 2.0 * PI / 3.0).abs() < 1e-12);
            for q in &p {
                assert!((q.x.hypot(q.y) - 12.0).abs() < 1e-9);
            }
            assert!((p[0].z - 17.8).abs() < 1e-9 && (p.last().unwrap().z - 17.8).abs() < 1e-9);
            let low = p.iter().map(|q| q.z).fold(f64::INFINITY, f64::min);
            assert!(low.abs() < 1e-9, "nadir at {low} mm");
            // Neighbours share their commissure point.
            let next = attachment((k + 1) % 3);
            assert!((p.last().unwrap() - next[0]).norm() < 1e-9);
            // The flat cusp's attached edge is within 5 % of the line it
            // is placed on (stated in docs/verification.md).
            let ratio = c.sutured_length() / path_length(&p);
            assert!((ratio - 1.0).abs() < 0.05, "sutured / attachment = {ratio}");
        }
        let f = frame();
        assert!((f.commissures_mm[0].z - 17.8).abs() < 1e-12);
        let (l, _) = valve(1.5).unwrap();
        // Every node inside its leaflet's wedge (up to the commissure
        // posts, which two leaflets share) and below the commissures.
        let mut node_leaflet = vec![0u16; l.x.len()];
        for (t, &k) in l.tris.iter().zip(&l.leaflet) {
            for &i in t {
                node_leaflet[i as usize] = k;
            }
        }
        for (p, &k) in l.x.iter().zip(&node_leaflet) {
            let (a, b) = commissure_angles(k as usize);
            let mid = (a + b) / 2.0;
            let ang = p.y.atan2(p.x);
            let off = (ang - mid + PI).rem_euclid(2.0 * PI) - PI;
            assert!(
                off.abs() <= PI / 3.0 + 1e-9,
                "node at {off} rad from its mid angle"
            );
            assert!(p.z <= COMMISSURE_HEIGHT + 1e-9 && p.z >= -1e-9);
            assert!(p.x.hypot(p.y) <= R + 1e-9);
        }
        let (cross, _sewn) = coapt_mech::model::leaflet_crossings(&l, &l.x);
        assert!(
            cross.is_empty(),
            "{} crossing pairs when placed",
            cross.len()
        );
    }
}
