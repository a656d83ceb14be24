//! Centreline of the root and ascending aorta: straight along the valve axis,
//! a circular arc turning the axis into +z (superior), straight along +z.
//!
//! Three exact pieces make the closest-point projection analytic, and the
//! rotation-minimising frame is exact too: constant on the straight pieces,
//! a rotation about the arc's (constant) binormal on the arc. Arc length `s`
//! is measured from the annulus centre (s = 0), negative into the LV.

use serde::Serialize;

use coapt_geom::{Point3, Vector3};

/// A point of the centreline with its rotation-minimising frame.
#[derive(Debug, Clone, Copy)]
pub struct Station {
    pub s: f64,
    pub point: Point3,
    pub tangent: Vector3,
    pub e1: Vector3,
    pub e2: Vector3,
}

#[derive(Debug, Clone)]
pub struct Centreline {
    /// Annulus (VAJ) centre: s = 0.
    pub origin: Point3,
    /// Valve axis (LV → aorta).
    pub axis: Vector3,
    /// Frame vector at s = 0, ⟂ axis, towards commissure C1.
    pub e1: Vector3,
    /// End of the first straight piece.
    pub s1: f64,
    /// Arc radius (mm); unused when the tilt is zero.
    pub arc_radius: f64,
    /// Turning angle of the arc (= angle between axis and +z).
    pub arc_angle: f64,
    /// Unit vector ⟂ axis towards which the arc turns (zero if no arc).
    turn: Vector3,
    /// Binormal axis × turn (rotation axis of the arc).
    binormal: Vector3,
    arc_centre: Point3,
    /// Start point and direction of the vertical piece (cached).
    end_point: Point3,
    end_tangent: Vector3,
}

/// Below this turning angle the arc is dropped (a straight centreline).
const MIN_ARC_ANGLE: f64 = 1e-9;

/// Serializable description of the three pieces (truth.json).
#[derive(Debug, Clone, Serialize)]
pub struct CentrelineDescription {
    pub straight_root: PieceLine,
    pub arc: Option<PieceArc>,
    pub straight_ascending: PieceLine,
}

#[derive(Debug, Clone, Serialize)]
pub struct PieceLine {
    pub start_mm: [f64; 3],
    pub direction: [f64; 3],
    pub s_start_mm: f64,
    pub s_end_mm: Option<f64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct PieceArc {
    pub centre_mm: [f64; 3],
    pub radius_mm: f64,
    pub angle_deg: f64,
    pub binormal: [f64; 3],
    pub s_start_mm: f64,
    pub s_end_mm: f64,
}

impl Centreline {
    pub fn new(origin: Point3, axis: Vector3, e1: Vector3, s1: f64, arc_radius: f64) -> Self {
        let axis = axis.normalize();
        let e1 = (e1 - axis * e1.dot(&axis)).normalize();
        let z = Vector3::z();
        let arc_angle = axis.dot(&z).clamp(-1.0, 1.0).acos();
        let perp = z - axis * axis.dot(&z);
        let (turn, arc_angle) = if arc_angle > MIN_ARC_ANGLE && perp.norm() > 1e-12 {
            (perp.normalize(), arc_angle)
        } else {
            (Vector3::zeros(), 0.0)
        };
        let binormal = axis.cross(&turn);
        let p1 = origin + axis * s1;
        let mut cl = Centreline {
            origin,
            axis,
            e1,
            s1,
            arc_radius,
            arc_angle,
            turn,
            binormal,
            arc_centre: p1 + turn * arc_radius,
            end_point: p1,
            end_tangent: axis,
        };
        let end = cl.station(cl.s2());
        cl.end_point = end.point;
        cl.end_tangent = end.tangent;
        cl
    }

    pub fn has_arc(&self) -> bool {
        self.arc_angle > 0.0
    }

    /// Arc length at the end of the arc (start of the vertical piece).
    pub fn s2(&self) -> f64 {
        self.s1 + self.arc_radius * self.arc_angle
    }

    /// Rotate `v` about the binormal by `phi` (the arc's frame transport).
    fn rotate(&self, v: &Vector3, phi: f64) -> Vector3 {
        if !self.has_arc() {
            return *v;
        }
        let b = self.binormal;
        let (s, c) = phi.sin_cos();
        v * c + b.cross(v) * s + b * (b.dot(v) * (1.0 - c))
    }

    /// Frame vectors (tangent, e1) at arc length s.
    pub fn station(&self, s: f64) -> Station {
        let (point, tangent, e1) = if s <= self.s1 || !self.has_arc() {
            (self.origin + self.axis * s, self.axis, self.e1)
        } else if s <= self.s2() {
            let phi = (s - self.s1) / self.arc_radius;
            let p =
                self.arc_centre + (self.axis * phi.sin() - self.turn * phi.cos()) * self.arc_radius;
            (p, self.rotate(&self.axis, phi), self.rotate(&self.e1, phi))
        } else {
            let t = self.rotate(&self.axis, self.arc_angle);
            let p2 = self.arc_centre
                + (self.axis * self.arc_angle.sin() - self.turn * self.arc_angle.cos())
                    * self.arc_radius;
            (
                p2 + t * (s - self.s2()),
                t,
                self.rotate(&self.e1, self.arc_angle),
            )
        };
        let e2 = tangent.cross(&e1);
        Station {
            s,
            point,
            tangent,
            e1,
            e2,
        }
    }

    /// Closest centreline station to `p` (straight ends extended to
    /// infinity). Unique within the arc radius of the curve, which exceeds
    /// every lumen radius.
    pub fn project(&self, p: &Point3) -> Station {
        // Piece 1: line through origin along axis, s ≤ s1.
        let s_a = (p - self.origin).dot(&self.axis);
        if !self.has_arc() {
            return self.station(s_a);
        }
        let c1 = s_a.min(self.s1);
        let d1 = (p - (self.origin + self.axis * c1)).norm_squared();
        // Piece 2: arc, angle from the in-plane position.
        let q = p - self.arc_centre;
        let u = -q.dot(&self.turn);
        let v = q.dot(&self.axis);
        let phi = v.atan2(u).clamp(0.0, self.arc_angle);
        let c2 = self.s1 + phi * self.arc_radius;
        let pa =
            self.arc_centre + (self.axis * phi.sin() - self.turn * phi.cos()) * self.arc_radius;
        let d2 = (p - pa).norm_squared();
        // Piece 3: vertical line from the arc end.
        let (e, t) = (self.end_point, self.end_tangent);
        let c3 = self.s2() + (p - e).dot(&t).max(0.0);
        let d3 = (p - (e + t * (c3 - self.s2()))).norm_squared();
        let s = if d1 <= d2 && d1 <= d3 {
            c1
        } else if d2 <= d3 {
            c2
        } else {
            c3
        };
        self.station(s)
    }

    /// A lower bound of the distance from `p` to the centreline, without
    /// trigonometry: the arc is replaced by its full circle.
    pub fn distance_lower_bound(&self, p: &Point3) -> f64 {
        let s_a = (p - self.origin).dot(&self.axis);
        if !self.has_arc() {
            let q = p - self.origin - self.axis * s_a;
            return q.norm();
        }
        let d1 = (p - (self.origin + self.axis * s_a.min(self.s1))).norm_squared();
        let q = p - self.arc_centre;
        let off_plane = q.dot(&self.binormal);
        let in_plane = (q - self.binormal * off_plane).norm() - self.arc_radius;
        let d2 = in_plane * in_plane + off_plane * off_plane;
        let t = self.end_tangent;
        let d3 = (p - (self.end_point + t * (p - self.end_point).dot(&t).max(0.0))).norm_squared();
        d1.min(d2).min(d3).sqrt()
    }

    /// Arc length where the centreline reaches height `z` on its vertical
    /// piece (the caller guarantees it is there).
    pub fn s_at_z_vertical(&self, z: f64) -> f64 {
        let st = self.station(self.s2());
        self.s2() + (z - st.point.z) / st.tangent.z
    }

    /// `s_min`: where the tube starts in the LV (the straight piece is
    /// infinite for projection, but the lumen is capped there).
    pub fn describe(&self, s_min: f64) -> CentrelineDescription {
        let arr = |v: Vector3| [v.x, v.y, v.z];
        let parr = |p: Point3| [p.x, p.y, p.z];
        let st2 = self.station(self.s2());
        CentrelineDescription {
            straight_root: PieceLine {
                start_mm: parr(self.origin),
                direction: arr(self.axis),
                s_start_mm: s_min,
                s_end_mm: Some(self.s1),
            },
            arc: self.has_arc().then(|| PieceArc {
                centre_mm: parr(self.arc_centre),
                radius_mm: self.arc_radius,
                angle_deg: self.arc_angle.to_degrees(),
                binormal: arr(self.binormal),
                s_start_mm: self.s1,
                s_end_mm: self.s2(),
            }),
            straight_ascending: PieceLine {
                start_mm: parr(st2.point),
                direction: arr(st2.tangent),
                s_start_mm: self.s2(),
                s_end_mm: None,
            },
        }
    }
}
