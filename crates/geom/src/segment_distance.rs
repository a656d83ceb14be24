//! Unsigned distance between two segments, with the region of the closest
//! pair of points (what the edge–edge contact barrier differentiates).
//!
//! The squared distance |a(s) − b(t)|² is convex over (s, t) ∈ [0, 1]², so
//! its minimum is either the interior critical point (when it lies inside)
//! or on the square's border, i.e. the least of the four endpoint-to-segment
//! distances. Each region has its own closed form (interior: distance of
//! the two lines; endpoint to segment interior: distance to a line;
//! endpoint to endpoint), smooth inside the region; across borders the
//! distance is C¹.

use super::Vector3 as V3;

/// Where the closest points of segments a = (a0, a1) and b = (b0, b1) lie.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SegRegion {
    /// Both inside: the distance of the two lines.
    Interior,
    /// Endpoint `p` (0 a0, 1 a1, 2 b0, 3 b1) against the inside of the
    /// other segment.
    PointEdge(u8),
    /// Endpoint `i` of a (0, 1) against endpoint `j` of b (2, 3).
    PointPoint(u8, u8),
}

#[derive(Debug, Clone, Copy)]
pub struct SegProximity {
    /// Distance (mm).
    pub dist: f64,
    /// Closest points a0 + s (a1 − a0) and b0 + t (b1 − b0).
    pub s: f64,
    pub t: f64,
    pub region: SegRegion,
}

/// Below this value of sin² of the angle between the segments the interior
/// solve is ill-conditioned and the border minimum is used: they differ by
/// less than (1e-6 · length)² there.
const PARALLEL_SIN2: f64 = 1e-12;

/// Closest points of the two segments (degenerate segments allowed).
pub fn segment_segment(a0: &V3, a1: &V3, b0: &V3, b1: &V3) -> SegProximity {
    let e1 = a1 - a0;
    let e2 = b1 - b0;
    let w = a0 - b0;
    let (aa, bb, cc) = (e1.dot(&e1), e1.dot(&e2), e2.dot(&e2));
    let (dd, ee) = (e1.dot(&w), e2.dot(&w));
    let den = aa * cc - bb * bb;
    if den > PARALLEL_SIN2 * aa * cc {
        let s = (bb * ee - cc * dd) / den;
        let t = (aa * ee - bb * dd) / den;
        if s > 0.0 && s < 1.0 && t > 0.0 && t < 1.0 {
            return SegProximity {
                dist: (w + e1 * s - e2 * t).norm(),
                s,
                t,
                region: SegRegion::Interior,
            };
        }
    }
    // The border: each endpoint against the other segment; the first of
    // equal minima wins (the distance is the same either way).
    let mut best: Option<SegProximity> = None;
    // The best's squared distance: a candidate with no smaller square has
    // no smaller distance (sqrt is monotone), so its root is not taken.
    let mut best_d2 = f64::INFINITY;
    for p in 0..4u8 {
        let (x, q0, q1, j0) = match p {
            0 => (a0, b0, b1, 2u8),
            1 => (a1, b0, b1, 2),
            2 => (b0, a0, a1, 0),
            _ => (b1, a0, a1, 0),
        };
        let e = q1 - q0;
        let l2 = e.dot(&e);
        let u = if l2 > 0.0 { (x - q0).dot(&e) / l2 } else { 0.0 };
        let (u, region) = if u <= 0.0 {
            (0.0, pp(p, j0))
        } else if u >= 1.0 {
            (1.0, pp(p, j0 + 1))
        } else {
            (u, SegRegion::PointEdge(p))
        };
        let d2 = (x - (q0 + e * u)).norm_squared();
        if best.is_some() && d2.partial_cmp(&best_d2) != Some(std::cmp::Ordering::Less) {
            continue;
        }
        let dist = d2.sqrt();
        let (s, t) = if p < 2 {
            (f64::from(p), u)
        } else {
            (u, f64::from(p - 2))
        };
        if best.as_ref().is_none_or(|b| dist < b.dist) {
            best = Some(SegProximity { dist, s, t, region });
            best_d2 = d2;
        }
    }
    best.expect("four candidates")
}

/// The point–point region of endpoint `p` against endpoint `q`, as (end of
/// a, end of b).
fn pp(p: u8, q: u8) -> SegRegion {
    if p < 2 {
        SegRegion::PointPoint(p, q)
    } else {
        SegRegion::PointPoint(q, p)
    }
}
