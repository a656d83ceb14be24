//! The ascending aorta found from the commissure landmarks.
//!
//! The commissures lie on the root wall, so the centre of their circle is
//! in the lumen whatever the field of view holds above it (the arch, the
//! descending aorta, the neck). From there the aorta is followed up the
//! axis of the commissure circle: the first axial section a little above
//! the commissures that is a contrast-filled circle near that axis anchors
//! the usual slice-by-slice track, which runs upward while the section
//! stays a circle (it stops where the ascending aorta bends into the arch).
//!
//! Works on a grid whose k axis points to the head ([`coapt_geom::resample`]).

use super::hough::{HoughParams, circleness};
use super::track::{
    Found, TrackPoint, annulus_values, best_circle_near, median, slice_f32, track_step,
};
use coapt_base::{Error, Result};
use coapt_geom::{Point3, Vector3, Volume};

/// Heights above the commissure centre (mm, along the valve axis) tried for
/// the anchor section: the STJ and the tube above it.
const ANCHOR_HEIGHTS_MM: [f64; 8] = [8.0, 12.0, 16.0, 20.0, 4.0, 25.0, 30.0, 0.0];
/// The anchor circle's centre within this fraction of the commissure radius
/// of the axis point, and its radius within these factors of it.
const ANCHOR_SHIFT: f64 = 0.6;
const ANCHOR_R: (f64, f64) = (0.55, 1.5);
/// Least circleness of the anchor (lower than a free seed's: an axial cut
/// of a tilted tube is an ellipse, and the landmarks vouch for the place).
const C_ANCHOR: f64 = 0.3;

/// Centre, unit normal and radius of the circle through three points.
pub fn circumcircle(c: &[Point3; 3]) -> Option<(Point3, Vector3, f64)> {
    let (a, b) = (c[1] - c[0], c[2] - c[0]);
    let n = a.cross(&b);
    let n2 = n.norm_squared();
    if n2 < 1e-12 {
        return None;
    }
    let off = (n.cross(&a) * b.norm_squared() + b.cross(&n) * a.norm_squared()) / (2.0 * n2);
    Some((c[0] + off, n / n2.sqrt(), off.norm()))
}

/// Track of the ascending aorta (top first, as [`super::track::find_aorta`]
/// gives it) anchored at the commissures `c` on `ct` (k toward the head).
pub fn from_commissures(ct: &Volume<i16>, c: &[Point3; 3], hp: &HoughParams) -> Result<Found> {
    let [ni, nj, nk] = ct.dims();
    let sp = ct.spacing();
    let (centre, mut axis, radius) = circumcircle(c).ok_or_else(|| {
        Error::failed(
            "segment",
            "the commissures C1–C3 are collinear: their circle, which seeds the segmentation, is undefined",
        )
    })?;
    // The aorta leaves the root toward the head.
    if axis.z < 0.0 {
        axis = -axis;
    }
    let mut anchor = None;
    let mut tried = Vec::new();
    for h in ANCHOR_HEIGHTS_MM {
        let p = centre + axis * h;
        let q = ct.world_to_index(&p);
        let k = q[2].round();
        if !(k >= 0.0 && k < nk as f64) {
            tried.push(format!("{h:.0} mm: outside the scan"));
            continue;
        }
        match anchor_circle(ct, k as usize, (q[0], q[1]), radius, hp) {
            Ok(t) => {
                anchor = Some(t);
                break;
            }
            Err(why) => tried.push(format!("{h:.0} mm: {why}")),
        }
    }
    let Some(anchor) = anchor else {
        return Err(Error::failed(
            "segment",
            format!(
                "found no contrast-filled circular lumen of radius {:.0}–{:.0} mm on the axis of the commissures C1–C3 (circle centre {:.1}, {:.1}, {:.1} mm LPS) at any height tried above them ({}); are the landmarks on this CT's aortic root?",
                ANCHOR_R.0 * radius,
                ANCHOR_R.1 * radius,
                centre.x,
                centre.y,
                centre.z,
                tried.join("; ")
            ),
        ));
    };
    let mut up = vec![anchor];
    let mut k = anchor.k + 1;
    while k < nk {
        let last = *up.last().expect("anchored");
        let Some(next) = track_step(ct, k, &last, hp) else {
            break;
        };
        up.push(next);
        k += 1;
    }
    up.reverse();
    let top_k = up[0].k;
    let img = slice_f32(ct, top_k);
    let top_map = circleness(&img, ni, nj, sp[0], sp[1], hp);
    Ok(Found {
        top_k,
        dk: -1,
        candidates: Vec::new(),
        track: up,
        top_map,
        direction: Some(axis),
        level_radii: Vec::new(),
    })
}

/// The contrast-filled circle in slice `k` nearest to index point `at`
/// (radius about `r` mm), or why there is none.
fn anchor_circle(
    ct: &Volume<i16>,
    k: usize,
    at: (f64, f64),
    r: f64,
    hp: &HoughParams,
) -> std::result::Result<TrackPoint, String> {
    let sp = ct.spacing();
    let w = best_circle_near(
        ct,
        k,
        at,
        (ANCHOR_SHIFT + ANCHOR_R.1) * r + 3.0 * hp.sigma_mm,
        (ANCHOR_R.0 * r, ANCHOR_R.1 * r),
        ANCHOR_SHIFT * r,
        hp,
    )
    .ok_or("at the edge of the scan")?;
    let (c, v, map, win, wi, wj) = (w.c, w.v, &w.map, &w.win, w.wi, w.wj);
    let (i0, j0) = (w.i0, w.j0);
    if (c as f64) < C_ANCHOR {
        return Err(format!("circleness {c:.2} < {C_ANCHOR}"));
    }
    let circ = map.refine(v % wi, v / wi, map.r_mm[v] as f64);
    let inside = median(&mut annulus_values(
        win,
        wi,
        wj,
        [sp[0], sp[1]],
        (circ.i, circ.j),
        0.0,
        0.6 * circ.r_mm,
    ));
    if !(inside >= hp.bright_min) {
        return Err(format!(
            "inside {inside:.0} HU < {:.0} HU: not a contrast lumen",
            hp.bright_min
        ));
    }
    Ok(TrackPoint {
        k,
        i: circ.i + i0 as f64,
        j: circ.j + j0 as f64,
        r_mm: circ.r_mm,
        c: c as f64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn circumcircle_of_a_tilted_triangle() {
        let rot = nalgebra::Rotation3::from_euler_angles(0.4, -0.3, 1.2);
        let c0 = Point3::new(5.0, -7.0, 30.0);
        let pts = [0.3, 2.2, 4.4]
            .map(|a: f64| c0 + rot * Vector3::new(12.0 * a.cos(), 12.0 * a.sin(), 0.0));
        let (c, n, r) = circumcircle(&pts).unwrap();
        assert!((c - c0).norm() < 1e-9);
        assert!((r - 12.0).abs() < 1e-9);
        assert!((n.dot(&(rot * Vector3::z())).abs() - 1.0).abs() < 1e-12);
        assert!(circumcircle(&[c0, c0 + Vector3::x(), c0 + 2.0 * Vector3::x()]).is_none());
    }
}
