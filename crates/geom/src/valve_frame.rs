//! The valve frame: axis along the blood flow (LV → aorta), origin at the
//! annulus (ventriculo-aortic junction) centre.

use serde::{Deserialize, Serialize};

use super::{Frame, Point3, Vector3};

/// Valve-centred coordinates. Cylindrical coordinates (height along `axis`,
/// angle from `e1` towards `e2 = axis × e1`, radius) are measured about
/// `origin`; `e1` points from the axis towards commissure C1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValveFrame {
    /// World frame of every point and vector here.
    pub frame: Frame,
    /// Annulus (VAJ) centre.
    pub origin_mm: Point3,
    /// Unit axis, LV → ascending aorta.
    pub axis: Vector3,
    /// Unit vector ⟂ axis, towards commissure C1.
    pub e1: Vector3,
    /// Commissures C1, C2, C3.
    pub commissures_mm: [Point3; 3],
    /// Nadirs N1..N3 (lowest points of the attachment lines), when known.
    pub nadirs_mm: Option<[Point3; 3]>,
}

impl ValveFrame {
    /// Build from origin, axis and commissures; `e1` is C1's direction
    /// projected off the axis. `None` if the axis is degenerate or C1 lies on it.
    pub fn new(
        origin: Point3,
        axis: Vector3,
        commissures: [Point3; 3],
        nadirs: Option<[Point3; 3]>,
    ) -> Option<Self> {
        let axis = axis.try_normalize(1e-12)?;
        let d = commissures[0] - origin;
        let e1 = (d - axis * d.dot(&axis)).try_normalize(1e-9)?;
        Some(Self {
            frame: Frame::Lps,
            origin_mm: origin,
            axis,
            e1,
            commissures_mm: commissures,
            nadirs_mm: nadirs,
        })
    }

    /// Distances C1–C2, C2–C3, C3–C1 (mm): what the surgeon's Ozaki sizer
    /// measures in the opened root.
    pub fn intercommissural_mm(&self) -> [f64; 3] {
        let c = &self.commissures_mm;
        [
            (c[0] - c[1]).norm(),
            (c[1] - c[2]).norm(),
            (c[2] - c[0]).norm(),
        ]
    }

    pub fn e2(&self) -> Vector3 {
        self.axis.cross(&self.e1)
    }

    /// World point → (height along the axis, angle in (−π, π], radius), mm and rad.
    pub fn to_cylindrical(&self, p: &Point3) -> (f64, f64, f64) {
        let d = p - self.origin_mm;
        let h = d.dot(&self.axis);
        let x = d.dot(&self.e1);
        let y = d.dot(&self.e2());
        (h, y.atan2(x), x.hypot(y))
    }

    /// (height, angle, radius) → world point.
    pub fn from_cylindrical(&self, h: f64, angle: f64, r: f64) -> Point3 {
        self.origin_mm + self.axis * h + (self.e1 * angle.cos() + self.e2() * angle.sin()) * r
    }

    /// World point → local Cartesian (e1, e2, axis) coordinates.
    pub fn to_local(&self, p: &Point3) -> Vector3 {
        let d = p - self.origin_mm;
        Vector3::new(d.dot(&self.e1), d.dot(&self.e2()), d.dot(&self.axis))
    }

    pub fn from_local(&self, l: &Vector3) -> Point3 {
        self.origin_mm + self.e1 * l.x + self.e2() * l.y + self.axis * l.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cylindrical_round_trip() {
        let c = [
            Point3::new(10.0, 1.0, 15.0),
            Point3::new(-5.0, 9.0, 15.0),
            Point3::new(-5.0, -9.0, 15.0),
        ];
        let f = ValveFrame::new(
            Point3::new(0.0, 1.0, 0.0),
            Vector3::new(0.0, 0.0, 2.0),
            c,
            None,
        )
        .unwrap();
        let (h, a, r) = f.to_cylindrical(&c[0]);
        assert!((h - 15.0).abs() < 1e-12 && a.abs() < 1e-12 && (r - 10.0).abs() < 1e-12);
        let p = Point3::new(3.0, -4.0, 7.0);
        let (h, a, r) = f.to_cylindrical(&p);
        assert!((f.from_cylindrical(h, a, r) - p).norm() < 1e-12);
        assert!((f.from_local(&f.to_local(&p)) - p).norm() < 1e-12);
        assert!((f.e2().norm() - 1.0).abs() < 1e-12);
    }
}
