//! Seed 001 §3.1 closes one leaflet between two contact planes through the
//! axis that bound its 120° sector; the neighbours are the leaflet's
//! mirror images across those planes. To measure such a closure like a
//! valve, the report adds the two mirror images as leaflets 2 and 3 and
//! measures leaflet 1 against the planes themselves (the gap to a mirror
//! image is twice the signed distance to its plane), so a margin of 0.02 R
//! is the seed's zone (signed distance to the plane ≤ 0.01 R) exactly —
//! the distance to the mirror surface would be smaller wherever the leaflet
//! leaves the plane at an angle.

use coapt_geom::{Point3, Vector3};

use super::ClosedValve;
use super::coaptation::MirrorPlane;

/// Lug corners: sutured nodes on an edge with a free-edge node.
fn corners(v: &ClosedValve) -> Vec<usize> {
    let mut c = Vec::new();
    for t in &v.tris {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            for (s, f) in [(a, b), (b, a)] {
                if v.boundary[s] == 1 && v.boundary[f] == 2 && !c.contains(&s) {
                    c.push(s);
                }
            }
        }
    }
    c.sort_unstable();
    c
}

/// Unit normals of the planes through the axis 60° either side of the
/// middle of the two outermost lug corners (by angle about the axis, seen
/// from the leaflet's centroid), each pointing into the leaflet's side.
fn planes(v: &ClosedValve) -> Option<[Vector3; 2]> {
    let f = &v.frame;
    let radial = |p: &Point3| {
        let d = p - f.origin_mm;
        d - f.axis * d.dot(&f.axis)
    };
    let centroid = v.x.iter().map(|p| p.coords).sum::<Vector3>() / v.x.len() as f64;
    let mid = radial(&Point3::from(centroid)).try_normalize(1e-9)?;
    let side = f.axis.cross(&mid);
    let angle = |p: &Point3| {
        let r = radial(p);
        r.dot(&side).atan2(r.dot(&mid))
    };
    let c = corners(v);
    let lo = c
        .iter()
        .min_by(|&&a, &&b| angle(&v.x[a]).total_cmp(&angle(&v.x[b])))?;
    let hi = c
        .iter()
        .max_by(|&&a, &&b| angle(&v.x[a]).total_cmp(&angle(&v.x[b])))?;
    // The close stage bounds a leaflet alone by its 120° sector, 60° either
    // side of the middle of its outermost corners.
    let (a, b) = (
        radial(&v.x[*lo]).try_normalize(1e-9)?,
        radial(&v.x[*hi]).try_normalize(1e-9)?,
    );
    let middle = (a + b).try_normalize(1e-9)?;
    let normal = |end: &Vector3| {
        let edge = coapt_mech::model::sector_edge(&f.axis, &middle, end);
        let n = f.axis.cross(&edge).try_normalize(1e-9)?;
        Some(if n.dot(&mid) < 0.0 { -n } else { n })
    };
    Some([normal(&a)?, normal(&b)?])
}

/// The valve completed by the two mirror images, and the planes; `None`
/// unless it has exactly one leaflet with two lug corners off the axis.
pub fn complete(v: &ClosedValve) -> Option<(ClosedValve, Vec<MirrorPlane>)> {
    if v.leaflets != 1 {
        return None;
    }
    let o = v.frame.origin_mm;
    let n = v.x.len() as u32;
    let mut w = v.clone();
    let mut mirrors = Vec::new();
    for (k, normal) in planes(v)?.into_iter().enumerate() {
        mirrors.push(MirrorPlane {
            leaflet: k + 1,
            point: o,
            normal,
        });
        let mirror = |p: &Point3| p - normal * (2.0 * (p - o).dot(&normal));
        w.x.extend(v.x.iter().map(mirror));
        w.x0.extend(v.x0.iter().map(mirror));
        let off = (k as u32 + 1) * n;
        // A reflection reverses orientation: swap two corners to keep normals.
        w.tris
            .extend(v.tris.iter().map(|t| [t[0] + off, t[2] + off, t[1] + off]));
        w.tri_leaflet
            .extend(std::iter::repeat_n(k as u8 + 1, v.tris.len()));
        w.boundary.extend_from_slice(&v.boundary);
        if let (Some(uv), Some(src)) = (w.ref_uv.as_mut(), v.ref_uv.as_ref()) {
            uv.extend_from_slice(src);
        }
    }
    w.leaflets = 3;
    Some((w, mirrors))
}
