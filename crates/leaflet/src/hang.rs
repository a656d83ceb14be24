//! Hanging placement of a flat template: the leaflet as sewn and closed
//! in diastole, the state the closure starts from and (with the sutured
//! reference, seed 001) rests on.
//!
//! Why not extrusion. A leaflet extruded from its suture line leans its
//! free edge towards the axis at the full length of the template's columns:
//! an Ozaki template's central column (28–30 mm) put the free edge 5–9 mm
//! above the commissures on the sample, and since the sutured state is the
//! stress-free reference, the closure kept it there (effective height
//! 24–29 mm against commissures at 17.4 mm, for every sizer size). Ozaki's
//! sizing rests on the free edge: under diastolic load it hangs taut from
//! one commissure to the centre and on to the next, so its length sets how
//! far below the commissures the leaflets meet (size 23: free edge 31.6 mm
//! over commissures 13.3 mm off the axis hangs 8.3 mm below them).
//!
//! The placement, per leaflet:
//! * **Free edge**: a taut V from commissure A through a point C on the
//!   leaflet's mid-plane, `clearance` off the axis, to commissure B, its
//!   two legs together as long as the template's free edge. A free edge
//!   too short to reach C stops short of it on the mid-plane, taut; one
//!   shorter than A–B is laid on A–B, stretched (the closure then shows the
//!   leak).
//! * **Columns**: each node's column (the flat segment from its attachment
//!   point to the free-edge point of equal abscissa s) runs from the suture
//!   path to the free edge, keeping its flat length: a circular arc bowed
//!   towards the ventricle that leaves the suture line level or upwards,
//!   then a vertical strip up to the free edge (the coapting surface) whose
//!   foot stays 0.5 mm above the suture point and the annulus plane. A
//!   column shorter than its chord stops short of the free edge; one too
//!   long to fit is placed at the longest length that does, and the rest is
//!   reported as excess.
//!
//! Lengths along the free edge and the columns are kept; lengths across the
//! columns are not (the template is flat, the sewn leaflet is not
//! developable). The closure takes this as the sewn state (seed 001's
//! Algorithm 1 is skipped); with the sutured reference it is stress-free,
//! so the closed shape follows this placement's geometry (see
//! docs/results.md, "Leaflet sizing", for how much).

use coapt_geom::{Point3, Vector3};

use super::place::Path3;

/// The free edge as placed, for the record.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct FreeEdge {
    /// How far the V's apex lies below the mean height of the two
    /// commissures (mm); 0 when the free edge cannot reach the centre.
    pub drop_mm: f64,
    /// Distance of the apex from the axis (mm): the clearance when the free
    /// edge reaches the centre, more when it is too short to.
    pub apex_radius_mm: f64,
    /// The free edge's template length over the shortest V through the
    /// clearance point at the commissures' height (< 1: too short to close).
    pub slack: f64,
}

/// The free-edge V of one leaflet.
pub struct Vee {
    pub a: Point3,
    pub c: Point3,
    pub b: Point3,
    pub info: FreeEdge,
}

impl Vee {
    /// The point at fraction f of the free edge's length from A.
    pub fn at(&self, f: f64) -> Point3 {
        let (l1, l2) = ((self.c - self.a).norm(), (self.b - self.c).norm());
        let s = f.clamp(0.0, 1.0) * (l1 + l2);
        if s <= l1 && l1 > 0.0 {
            self.a + (self.c - self.a) * (s / l1)
        } else if l2 > 0.0 {
            self.c + (self.b - self.c) * ((s - l1) / l2)
        } else {
            self.c
        }
    }
}

/// Horizontal part of v (perpendicular to the unit `axis`).
fn flat(v: &Vector3, axis: &Vector3) -> Vector3 {
    v - axis * v.dot(axis)
}

/// The taut V of a free edge of `length` between the commissures `a` and
/// `b`, its apex on the mid-plane `clearance` off the axis (through
/// `centre`) or farther out when the edge is too short.
pub fn vee(
    a: Point3,
    b: Point3,
    length: f64,
    axis: &Vector3,
    centre: &Point3,
    clearance: f64,
) -> Vee {
    let (ra, rb) = (flat(&(a - centre), axis), flat(&(b - centre), axis));
    let mid = (ra.normalize() + rb.normalize())
        .try_normalize(1e-9)
        .unwrap_or_else(|| {
            // A 180° sector: its mid-plane is perpendicular to A–B.
            axis.cross(&(rb - ra)).normalize()
        });
    let top = ((a - centre).dot(axis) + (b - centre).dot(axis)) / 2.0;
    let apex = |rho: f64, z: f64| centre + mid * rho + axis * z;
    let legs = |p: Point3| (p - a).norm() + (b - p).norm();
    let shortest = legs(apex(clearance, top));
    let info = |c: Point3, slack: f64| FreeEdge {
        drop_mm: (top - (c - centre).dot(axis)).max(0.0),
        apex_radius_mm: flat(&(c - centre), axis).norm(),
        slack,
    };
    let slack = length / shortest;
    if length >= shortest {
        // Lower the apex until the legs take the whole length (they grow
        // monotonically as it sinks below the commissures).
        let (mut lo, mut hi) = (0.0, length);
        for _ in 0..60 {
            let m = 0.5 * (lo + hi);
            if legs(apex(clearance, top - m)) < length {
                lo = m;
            } else {
                hi = m;
            }
        }
        let c = apex(clearance, top - 0.5 * (lo + hi));
        return Vee {
            a,
            c,
            b,
            info: info(c, slack),
        };
    }
    // Too short to reach the centre: the apex moves out along the mid-plane
    // at the commissures' height until the legs fit (or onto A–B).
    let chord = (b - a).norm();
    let on_ab = a + (b - a) * 0.5;
    if length <= chord {
        return Vee {
            a,
            c: on_ab,
            b,
            info: info(on_ab, slack),
        };
    }
    let far = flat(&(on_ab - centre), axis).dot(&mid).max(clearance);
    let (mut lo, mut hi) = (clearance, far);
    for _ in 0..60 {
        let m = 0.5 * (lo + hi);
        if legs(apex(m, top)) > length {
            lo = m;
        } else {
            hi = m;
        }
    }
    let c = apex(0.5 * (lo + hi), top);
    Vee {
        a,
        c,
        b,
        info: info(c, slack),
    }
}

/// A column from p to q of flat length `len`: its point at fraction λ.
pub struct Column {
    p: Point3,
    /// Chord of the arc part, from p to q_low.
    u: Vector3,
    chord: f64,
    /// Unit bow direction of the arc (⊥ u, towards the ventricle).
    bow: Vector3,
    /// Half the arc's turning angle (0: straight).
    theta: f64,
    arc_len: f64,
    /// Foot of the vertical strip and its length up to q.
    q_low: Point3,
    strip: f64,
    axis: Vector3,
    /// Placed length: the template's, or less when it is too short to
    /// reach the free edge (the chord) or too long to fit (see `excess`).
    len: f64,
    /// Template length the column could not place (mm).
    pub excess: f64,
}

/// θ with sin θ / θ = k, for k ∈ (0, 1].
fn half_angle(k: f64) -> f64 {
    if k >= 1.0 {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0f64, std::f64::consts::PI);
    for _ in 0..60 {
        let m = 0.5 * (lo + hi);
        if m.sin() / m > k {
            lo = m;
        } else {
            hi = m;
        }
    }
    0.5 * (lo + hi)
}

impl Column {
    /// `floor`: a point and upward unit normal of the plane (the annulus
    /// through the nadirs) that the strip's foot stays 0.5 mm above.
    pub fn new(
        p: Point3,
        q: Point3,
        len: f64,
        axis: &Vector3,
        floor: Option<(Point3, Vector3)>,
    ) -> Column {
        let len_template = len;
        let straight = |len: f64| {
            let d = q - p;
            let c = d.norm();
            let u = if c > 0.0 { d / c } else { *axis };
            Column {
                p,
                u,
                chord: len,
                bow: Vector3::zeros(),
                theta: 0.0,
                arc_len: len,
                q_low: p + u * len,
                strip: 0.0,
                axis: *axis,
                len,
                excess: 0.0,
            }
        };
        let c0 = (q - p).norm();
        if !(len > c0 * (1.0 + 1e-9)) || c0 <= 0.0 {
            // Too short (or degenerate): straight towards q, as far as it goes.
            return straight(len.min(c0));
        }
        // The arc turns no more than its chord rises, so it leaves the
        // suture line level or upwards (no belly below the line), and never
        // so far that its end runs past vertical (back on itself, into the
        // next leaflet's sector). The rest of the length is a vertical
        // strip (the coapting surface).
        let arc = |v: f64| {
            let ql = q - axis * v;
            let d = ql - p;
            let c = d.norm();
            let u = d / c;
            let elev = u.dot(axis).clamp(-1.0, 1.0).asin();
            let turn = (std::f64::consts::FRAC_PI_2 - elev - 0.1).clamp(0.05, 3.0);
            let cap = elev.clamp(0.05, turn);
            (ql, c, u, cap)
        };
        let fits = |v: f64| {
            let (_, c, _, cap) = arc(v);
            c / (len - v) >= cap.sin() / cap
        };
        let first_fit = |v_max: f64| -> Option<f64> {
            const STEPS: usize = 64;
            let mut prev = 0.0;
            for k in 0..=STEPS {
                let v = v_max * k as f64 / STEPS as f64;
                if fits(v) {
                    if k == 0 {
                        return Some(0.0);
                    }
                    let (mut lo, mut hi) = (prev, v);
                    for _ in 0..50 {
                        let m = 0.5 * (lo + hi);
                        if fits(m) {
                            hi = m;
                        } else {
                            lo = m;
                        }
                    }
                    return Some(hi);
                }
                prev = v;
            }
            None
        };
        // The strip's foot stays above the suture point. A column too long
        // to fit so is placed at the longest length that does (the arc
        // turned as far as it may, at the strip length that gives most):
        // the rest is excess tissue, which the sewn leaflet would gather,
        // billow below the annulus or fold, and which the record reports.
        let mut rise = ((q - p).dot(axis) - 0.5).max(0.0);
        if let Some((o, n)) = floor {
            let down = axis.dot(&n);
            if down > 0.1 {
                rise = rise.min((((q - o).dot(&n) - 0.5) / down).max(0.0));
            }
        }
        let (v, len) = match first_fit(rise.min(len * (1.0 - 1e-9))) {
            Some(v) => (v, len),
            None => {
                const STEPS: usize = 64;
                (0..=STEPS)
                    .map(|k| {
                        let v = rise * k as f64 / STEPS as f64;
                        let (_, c, _, cap) = arc(v);
                        (v, v + c * cap / cap.sin())
                    })
                    .fold((0.0, 0.0), |best, t| if t.1 > best.1 { t } else { best })
            }
        };
        let (q_low, c, u, _) = arc(v);
        let arc_len = len - v;
        let theta = half_angle(c / arc_len).min(3.0);
        let bow = {
            let b = u * u.dot(axis) - axis;
            b.try_normalize(1e-9)
                .unwrap_or_else(|| u.cross(axis).cross(&u).normalize())
        };
        Column {
            p,
            u,
            chord: c,
            bow,
            theta,
            arc_len,
            q_low,
            strip: v,
            axis: *axis,
            len,
            excess: len_template - len,
        }
    }

    pub fn at(&self, lam: f64) -> Point3 {
        let d = lam.clamp(0.0, 1.0) * self.len;
        if d >= self.arc_len {
            return self.q_low + self.axis * (d - self.arc_len).min(self.strip);
        }
        if self.theta < 1e-9 {
            return self.p + self.u * (d / self.arc_len.max(1e-300) * self.chord);
        }
        let rho = self.chord / (2.0 * self.theta.sin());
        let mid = self.p + self.u * (0.5 * self.chord);
        let centre = mid - self.bow * (rho * self.theta.cos());
        let psi = -self.theta + 2.0 * self.theta * (d / self.arc_len);
        centre + self.u * (rho * psi.sin()) + self.bow * (rho * psi.cos())
    }
}

/// Places a flat template's nodes (abscissa s, fraction λ, column length
/// `len`) between `path` and the free-edge V.
/// Also returns the largest excess of a column (mm, see [`Column`]).
pub fn place(
    s: &[f64],
    lam: &[f64],
    len: &[f64],
    path: &Path3,
    vee: &Vee,
    axis: &Vector3,
    floor: Option<(Point3, Vector3)>,
) -> (Vec<Point3>, f64) {
    let mut excess = 0.0f64;
    let x = s
        .iter()
        .zip(lam)
        .zip(len)
        .map(|((&si, &li), &ni)| {
            let p = path.at(si);
            if li <= 0.0 {
                return p;
            }
            let c = Column::new(p, vee.at(si), ni, axis, floor);
            excess = excess.max(c.excess);
            c.at(li)
        })
        .collect();
    (x, excess)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn z() -> Vector3 {
        Vector3::new(0.0, 0.0, 1.0)
    }

    #[test]
    fn the_vee_keeps_the_free_edge_length_and_hangs_by_pythagoras() {
        let r = 13.0f64;
        let a = Point3::new(r, 0.0, 17.0);
        let b = Point3::new(
            r * (2.0f64 * std::f64::consts::PI / 3.0).cos(),
            r * (2.0f64 * std::f64::consts::PI / 3.0).sin(),
            17.0,
        );
        let o = Point3::origin();
        let v = vee(a, b, 31.6, &z(), &o, 0.0);
        assert!(((v.c - a).norm() + (v.b - v.c).norm() - 31.6).abs() < 1e-9);
        // Each leg is 15.8 mm from a point 13 mm off the axis: drop √(15.8² − 13²).
        assert!(
            (v.info.drop_mm - (15.8f64.powi(2) - 169.0).sqrt()).abs() < 1e-9,
            "{:?}",
            v.info
        );
        assert!(v.info.slack > 1.0);
        // Too short to reach the axis: taut at the commissures' height.
        let v = vee(a, b, 24.0, &z(), &o, 0.0);
        assert!(v.info.drop_mm < 1e-9 && v.info.apex_radius_mm > 1.0 && v.info.slack < 1.0);
        assert!(((v.c - a).norm() + (v.b - v.c).norm() - 24.0).abs() < 1e-6);
        // Shorter than A–B: laid on A–B.
        let v = vee(a, b, 20.0, &z(), &o, 0.0);
        assert!((v.c - Point3::from((a.coords + b.coords) / 2.0)).norm() < 1e-12);
    }

    #[test]
    fn a_column_keeps_its_length_and_ends_on_the_free_edge() {
        let p = Point3::new(13.0, 0.0, 0.0);
        let q = Point3::new(1.0, 0.0, 9.0);
        for len in [10.0, 15.0, 17.0, 22.0, 28.0] {
            let c = Column::new(p, q, len, &z(), None);
            let n = 2000;
            let pts: Vec<Point3> = (0..=n).map(|k| c.at(k as f64 / n as f64)).collect();
            let l: f64 = pts.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
            let chord = (q - p).norm();
            // Too long to fit above the suture point: placed shorter, the
            // rest reported as excess.
            assert_eq!(c.excess > 0.0, len > 21.0, "len {len}: excess {}", c.excess);
            assert!((l - (len - c.excess)).abs() < 1e-3 * len, "len {len}: {l}");
            if len >= chord {
                assert!(
                    (pts[n] - q).norm() < 1e-6,
                    "len {len}: ends at {:?}",
                    pts[n]
                );
            }
            // Never past the free edge towards (or beyond) the axis.
            assert!(pts.iter().all(|x| x.x >= q.x - 1e-9), "len {len}");
            // Bowed towards the ventricle: below the chord.
            let m = c.at(0.5);
            let below = (m - p).cross(&(q - p)).y;
            assert!(len <= chord || below >= -1e-9, "len {len}");
        }
    }
}
