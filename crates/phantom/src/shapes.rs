//! Signed-distance primitives for the non-truth anatomy.
//!
//! Every shape returns an approximate signed distance (negative inside, mm)
//! together with an approximate unit outward normal: the renderer needs the
//! normal to project the voxel onto it (analytic partial volume), and having
//! it analytically avoids six extra evaluations per voxel for finite
//! differences. Only the aortic lumen (see `lumen.rs`) has to be exact; these
//! shapes only have to look right and be cheap.

use coapt_geom::{Matrix3, Point3, Vector3};

/// Axis-aligned box in world mm, for culling.
#[derive(Debug, Clone, Copy)]
pub struct Aabb {
    pub lo: Point3,
    pub hi: Point3,
}

impl Aabb {
    pub fn empty() -> Self {
        Aabb {
            lo: Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY),
            hi: Point3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY),
        }
    }

    pub fn around(p: &Point3, r: f64) -> Self {
        let d = Vector3::new(r, r, r);
        Aabb {
            lo: p - d,
            hi: p + d,
        }
    }

    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            lo: Point3::new(
                self.lo.x.min(o.lo.x),
                self.lo.y.min(o.lo.y),
                self.lo.z.min(o.lo.z),
            ),
            hi: Point3::new(
                self.hi.x.max(o.hi.x),
                self.hi.y.max(o.hi.y),
                self.hi.z.max(o.hi.z),
            ),
        }
    }

    /// Euclidean distance from `p` to the box (0 inside).
    pub fn distance(&self, p: &Point3) -> f64 {
        let dx = (self.lo.x - p.x).max(p.x - self.hi.x).max(0.0);
        let dy = (self.lo.y - p.y).max(p.y - self.hi.y).max(0.0);
        let dz = (self.lo.z - p.z).max(p.z - self.hi.z).max(0.0);
        (dx * dx + dy * dy + dz * dz).sqrt()
    }

    pub fn grow(&self, m: f64) -> Aabb {
        let d = Vector3::new(m, m, m);
        Aabb {
            lo: self.lo - d,
            hi: self.hi + d,
        }
    }
}

/// A shape known by its approximate signed distance.
pub trait Sdf: Send + Sync {
    /// (signed distance in mm, unit outward normal).
    fn eval(&self, p: &Point3) -> (f64, Vector3);
    /// A box outside which the distance is positive and larger than any
    /// offset a layer applies (callers grow it by their own offsets).
    fn aabb(&self) -> Aabb;
}

/// Tube of piecewise-constant radius along a polyline: a union of capsules,
/// one per segment. Consecutive capsules share their end spheres, so with
/// constant radius the union is exact (the distance is the true Euclidean
/// distance outside), which the PA–aorta gap check relies on.
#[derive(Debug, Clone)]
pub struct Tube {
    points: Vec<Point3>,
    /// Radius per segment; a taper is a sequence of slightly smaller radii.
    radii: Vec<f64>,
    bound: Aabb,
}

impl Tube {
    pub fn new(points: Vec<Point3>, radii: Vec<f64>) -> Self {
        assert!(points.len() >= 2 && radii.len() == points.len() - 1);
        let mut t = Tube {
            points,
            radii,
            bound: Aabb::empty(),
        };
        t.bound = t.aabb();
        t
    }

    #[cfg(test)]
    pub fn points(&self) -> &[Point3] {
        &self.points
    }

    /// Move the whole tube.
    pub fn translate(&mut self, v: &Vector3) {
        for p in self.points.iter_mut() {
            *p += v;
        }
        self.bound = self.aabb();
    }
}

impl Tube {
    /// As `eval`, but a point farther than `cutoff` from the tube's box only
    /// gets that box distance (a lower bound): far voxels cost one box test.
    pub fn eval_within(&self, p: &Point3, cutoff: f64) -> (f64, Vector3) {
        let d = self.bound.distance(p);
        if d > cutoff {
            return (d, Vector3::z());
        }
        self.eval(p)
    }
}

impl Sdf for Tube {
    fn eval(&self, p: &Point3) -> (f64, Vector3) {
        let mut best = (f64::INFINITY, Vector3::z());
        for (w, r) in self.points.windows(2).zip(&self.radii) {
            let ab = w[1] - w[0];
            let t = ((p - w[0]).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
            let v = p - (w[0] + ab * t);
            let dist = v.norm();
            let d = dist - r;
            if d < best.0 {
                let n = if dist > 1e-12 { v / dist } else { Vector3::z() };
                best = (d, n);
            }
        }
        best
    }

    fn aabb(&self) -> Aabb {
        let mut b = Aabb::empty();
        for (w, r) in self.points.windows(2).zip(&self.radii) {
            b = b
                .union(&Aabb::around(&w[0], *r))
                .union(&Aabb::around(&w[1], *r));
        }
        b
    }
}

/// Ellipsoid with arbitrary orientation (columns of `rot` are its axes).
#[derive(Debug, Clone)]
pub struct Ellipsoid {
    pub centre: Point3,
    pub rot: Matrix3,
    pub semi: Vector3,
}

impl Sdf for Ellipsoid {
    fn eval(&self, p: &Point3) -> (f64, Vector3) {
        // Quilez's bound k0(k0−1)/k1: exact on the surface, a good
        // approximation within a few mm of it, which is all partial volume needs.
        let q = self.rot.transpose() * (p - self.centre);
        let a = q.component_div(&self.semi);
        let b = a.component_div(&self.semi);
        let k0 = a.norm();
        let k1 = b.norm();
        if k1 < 1e-12 {
            return (-self.semi.min(), Vector3::z());
        }
        let d = k0 * (k0 - 1.0) / k1;
        let n = (self.rot * b).normalize();
        (d, n)
    }

    fn aabb(&self) -> Aabb {
        // Exact half-extent of a rotated ellipsoid along each world axis.
        let mut h = Vector3::zeros();
        for w in 0..3 {
            let mut s = 0.0;
            for k in 0..3 {
                s += (self.rot[(w, k)] * self.semi[k]).powi(2);
            }
            h[w] = s.sqrt();
        }
        Aabb {
            lo: self.centre - h,
            hi: self.centre + h,
        }
    }
}

/// Elliptic cylinder along world z, between `z_lo` and `z_hi` (use infinite
/// bounds for a vessel crossing every slice).
#[derive(Debug, Clone)]
pub struct ZCylinder {
    pub cx: f64,
    pub cy: f64,
    pub rx: f64,
    pub ry: f64,
    pub z_lo: f64,
    pub z_hi: f64,
}

impl ZCylinder {
    /// An elliptic cylinder along z with no ends (the body, a bone's
    /// column, the descending aorta through the whole scan).
    pub fn endless(cx: f64, cy: f64, rx: f64, ry: f64) -> ZCylinder {
        ZCylinder {
            cx,
            cy,
            rx,
            ry,
            z_lo: f64::NEG_INFINITY,
            z_hi: f64::INFINITY,
        }
    }
}

impl Sdf for ZCylinder {
    fn eval(&self, p: &Point3) -> (f64, Vector3) {
        let (x, y) = (p.x - self.cx, p.y - self.cy);
        // 2-D ellipse distance by the same first-order bound as the ellipsoid.
        let (ax, ay) = (x / self.rx, y / self.ry);
        let (bx, by) = (ax / self.rx, ay / self.ry);
        let k0 = (ax * ax + ay * ay).sqrt();
        let k1 = (bx * bx + by * by).sqrt();
        let (dr, nr) = if k1 < 1e-12 {
            (-self.rx.min(self.ry), Vector3::x())
        } else {
            (k0 * (k0 - 1.0) / k1, Vector3::new(bx, by, 0.0) / k1)
        };
        let zc = 0.5 * (self.z_lo + self.z_hi);
        let dz = if self.z_lo.is_finite() && self.z_hi.is_finite() {
            (p.z - zc).abs() - 0.5 * (self.z_hi - self.z_lo)
        } else {
            f64::NEG_INFINITY
        };
        if dz > dr {
            (dz, Vector3::new(0.0, 0.0, (p.z - zc).signum()))
        } else {
            (dr, nr)
        }
    }

    fn aabb(&self) -> Aabb {
        Aabb {
            lo: Point3::new(self.cx - self.rx, self.cy - self.ry, self.z_lo),
            hi: Point3::new(self.cx + self.rx, self.cy + self.ry, self.z_hi),
        }
    }
}

/// Polynomial smooth minimum of two distances with blend width `k` (mm):
/// LV and LVOT join without a crease, as a real outflow tract does.
pub fn smooth_union(a: (f64, Vector3), b: (f64, Vector3), k: f64) -> (f64, Vector3) {
    let h = (0.5 + 0.5 * (b.0 - a.0) / k).clamp(0.0, 1.0);
    let d = b.0 * (1.0 - h) + a.0 * h - k * h * (1.0 - h);
    let n = (b.1 * (1.0 - h) + a.1 * h)
        .try_normalize(1e-12)
        .unwrap_or(a.1);
    (d, n)
}

/// Plain union (minimum) with the winner's normal.
pub fn union(a: (f64, Vector3), b: (f64, Vector3)) -> (f64, Vector3) {
    if a.0 <= b.0 { a } else { b }
}

/// Orthonormal basis whose third column is `axis`.
pub fn basis_with_axis(axis: &Vector3) -> Matrix3 {
    let w = axis.normalize();
    let helper = if w.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = helper.cross(&w).normalize();
    let v = w.cross(&u);
    Matrix3::from_columns(&[u, v, w])
}
