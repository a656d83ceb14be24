//! Seed 001 §3.1 closes one leaflet between two symmetry planes. To measure
//! such a closure like a whole valve, the leaflet is copied twice, turned by
//! ±120° about the valve axis: with a leaflet symmetric about its own
//! mid-plane, each copy is the mirror image across the contact plane, so the
//! distance to a copy is twice the signed distance to that plane and a
//! margin of 0.02 R reproduces the seed's zone (distance to the plane
//! ≤ 0.01 R).

use nalgebra::{Rotation3, Unit};

use super::ClosedValve;

/// The valve completed to three leaflets; `None` unless it has exactly one.
pub fn complete(v: &ClosedValve) -> Option<ClosedValve> {
    if v.leaflets != 1 {
        return None;
    }
    let axis = Unit::new_normalize(v.frame.axis);
    let o = v.frame.origin_mm;
    let n = v.x.len() as u32;
    let mut w = v.clone();
    for k in 1..3u32 {
        let rot = Rotation3::from_axis_angle(&axis, 2.0 * std::f64::consts::PI * k as f64 / 3.0);
        let turn = |p: &crate::geom::Point3| o + rot * (p - o);
        w.x.extend(v.x.iter().map(turn));
        w.x0.extend(v.x0.iter().map(turn));
        w.tris.extend(v.tris.iter().map(|t| t.map(|i| i + k * n)));
        w.tri_leaflet
            .extend(std::iter::repeat_n(k as u8, v.tris.len()));
        w.boundary.extend_from_slice(&v.boundary);
        if let (Some(uv), Some(src)) = (w.ref_uv.as_mut(), v.ref_uv.as_ref()) {
            uv.extend_from_slice(src);
        }
    }
    w.leaflets = 3;
    Some(w)
}
