//! Suture paths (docs/valve-and-leaflets.md): seed 001's eq. 1 curve — straight
//! parts of height H_c at the commissures and an elliptic arc through the
//! nadir — drawn in (angle, height) on the commissure cylinder and projected
//! onto the wall by radial rays from the axis.

use std::f64::consts::PI;

use super::frame::{CommissureCylinder, wrap};
use super::wall::Wall;
use crate::geom::Point3;

/// One leaflet's path in cylinder coordinates: from commissure a to b.
#[derive(Debug, Clone, Copy)]
pub struct PathSpec {
    pub angle_a: f64,
    pub height_a: f64,
    pub angle_b: f64,
    pub height_b: f64,
    pub hc: f64,
    pub nadir_angle: f64,
    pub nadir_height: f64,
}

impl PathSpec {
    /// Symmetric path between two commissures with depth `hb` below the
    /// lower of the two straight parts' ends (eq. 1 when heights agree).
    pub fn between(
        cyl: &CommissureCylinder,
        ca: &Point3,
        cb: &Point3,
        hc: f64,
        hb: f64,
    ) -> PathSpec {
        let (ha, aa) = cyl.height_angle(ca);
        let (hbb, ab) = cyl.height_angle(cb);
        let ab = aa + wrap(ab - aa);
        PathSpec {
            angle_a: aa,
            height_a: ha,
            angle_b: ab,
            height_b: hbb,
            hc,
            nadir_angle: (aa + ab) / 2.0,
            nadir_height: (ha + hbb) / 2.0 - hc - hb,
        }
    }

    /// The path on the cylinder of radius `r` about +z, 4000 points per
    /// unit of t (≈ 0.003 mm apart on a root's radius), commissure to
    /// commissure: the benchmarks' exact suture lines.
    pub fn on_cylinder(&self, r: f64) -> Vec<crate::geom::Point3> {
        const PER: usize = 4000;
        (0..=4 * PER)
            .map(|i| {
                let (ang, z) = self.at(i as f64 / PER as f64);
                crate::geom::Point3::new(r * ang.cos(), r * ang.sin(), z)
            })
            .collect()
    }

    /// Point of the planar curve at t ∈ [0, 4] (eq. 1 parametrisation):
    /// (angle, height).
    pub fn at(&self, t: f64) -> (f64, f64) {
        let (zb, zd) = (self.height_a - self.hc, self.height_b - self.hc);
        if t <= 1.0 {
            (self.angle_a, self.height_a - self.hc * t)
        } else if t <= 2.0 {
            let u = PI * (t - 1.0) / 2.0;
            (
                self.nadir_angle - (self.nadir_angle - self.angle_a) * u.cos(),
                zb - (zb - self.nadir_height) * u.sin(),
            )
        } else if t <= 3.0 {
            let u = PI * (t - 2.0) / 2.0;
            (
                self.nadir_angle + (self.angle_b - self.nadir_angle) * u.sin(),
                zd - (zd - self.nadir_height) * u.cos(),
            )
        } else {
            (self.angle_b, zd + self.hc * (t - 3.0))
        }
    }
}

/// Project the curve onto the wall, pin commissures (and the nadir when it
/// is a landmark) and resample to spacing ≤ `ds` by arc length.
pub fn project(
    wall: &Wall,
    cyl: &CommissureCylinder,
    spec: &PathSpec,
    pins: (Point3, Option<Point3>, Point3),
    ds: f64,
) -> Vec<Point3> {
    // Dense samples in t: ~0.05 mm apart on the cylinder.
    let mut raw = Vec::new();
    let mut split = 0;
    for piece in 0..4 {
        if piece == 2 {
            split = raw.len();
        }
        let (t0, t1) = (piece as f64, piece as f64 + 1.0);
        let (a0, h0) = spec.at(t0);
        let (a1, h1) = spec.at((t0 + t1) / 2.0);
        let (a2, h2) = spec.at(t1);
        let approx =
            (cyl.radius * (a1 - a0)).hypot(h1 - h0) + (cyl.radius * (a2 - a1)).hypot(h2 - h1);
        let n = ((approx / 0.05).ceil() as usize).max(4);
        for k in 0..n {
            let t = t0 + (t1 - t0) * k as f64 / n as f64;
            let p = if k == 0 && piece == 0 {
                pins.0
            } else if k == 0 && piece == 2 && pins.1.is_some() {
                pins.1.unwrap()
            } else {
                let (a, h) = spec.at(t);
                wall.radial(&cyl.axis_point(h), &cyl.dir(a), cyl.radius)
            };
            raw.push(p);
        }
    }
    raw.push(pins.2);
    // Resample each half on its own so the nadir stays a path point.
    let mut out = resample(&raw[..=split], ds);
    out.pop();
    out.extend(resample(&raw[split..], ds));
    out
}

/// Length of the curve drawn on the commissure cylinder itself, before
/// projection: what the path would measure on a root without sinuses.
pub fn cylinder_length(cyl: &CommissureCylinder, spec: &PathSpec) -> f64 {
    let n = 4000;
    let at = |t: f64| {
        let (a, h) = spec.at(t);
        cyl.axis_point(h) + cyl.dir(a) * cyl.radius
    };
    (0..n)
        .map(|i| (at(4.0 * (i + 1) as f64 / n as f64) - at(4.0 * i as f64 / n as f64)).norm())
        .sum()
}

pub fn length(p: &[Point3]) -> f64 {
    p.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
}

/// Equal arc-length resampling with spacing ≤ ds; endpoints kept exactly.
pub fn resample(p: &[Point3], ds: f64) -> Vec<Point3> {
    let mut cum = vec![0.0];
    for w in p.windows(2) {
        cum.push(cum.last().unwrap() + (w[1] - w[0]).norm());
    }
    let total = *cum.last().unwrap();
    let n = ((total / ds).ceil() as usize).max(1);
    let mut out = Vec::with_capacity(n + 1);
    let mut j = 1;
    for k in 0..=n {
        let s = total * k as f64 / n as f64;
        if k == 0 {
            out.push(p[0]);
            continue;
        }
        if k == n {
            out.push(*p.last().unwrap());
            continue;
        }
        while j < cum.len() - 1 && cum[j] < s {
            j += 1;
        }
        let d = cum[j] - cum[j - 1];
        let t = if d > 0.0 { (s - cum[j - 1]) / d } else { 0.0 };
        out.push(p[j - 1] + (p[j] - p[j - 1]) * t);
    }
    out
}

/// Outcome of length matching for one leaflet.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LengthMatch {
    pub path_mm: f64,
    /// The same curve on the commissure cylinder (no sinus bulge).
    pub on_cylinder_mm: f64,
    pub target_mm: Option<f64>,
    pub relative_mismatch: Option<f64>,
    pub depth_mm: f64,
    pub adjusted: bool,
    /// How far (degrees about the cylinder's axis) the path strays past
    /// the angles of its two commissures; 0 on every healthy path.
    pub past_commissures_deg: f64,
}

/// How far (degrees) the points of `path` stray outside the angular range
/// from `spec`'s commissure a to b about the cylinder's axis. The curve
/// itself never leaves it, and a radial projection keeps each point's
/// angle, so a stray point is one where the ray from the axis met no wall
/// and the nearest wall point was taken.
pub fn past_commissures_deg(cyl: &CommissureCylinder, spec: &PathSpec, path: &[Point3]) -> f64 {
    let (lo, hi) = (
        spec.angle_a.min(spec.angle_b),
        spec.angle_a.max(spec.angle_b),
    );
    let mid = 0.5 * (lo + hi);
    path.iter()
        .map(|p| {
            let a = mid + super::frame::wrap(cyl.height_angle(p).1 - mid);
            (lo - a).max(a - hi).max(0.0)
        })
        .fold(0.0, f64::max)
        .to_degrees()
}

/// Secant on the depth H_b until the path length equals `target` within
/// 0.1 % (the issue asks 1 %). Returns the path and its depth.
pub fn match_length(
    wall: &Wall,
    cyl: &CommissureCylinder,
    ca: &Point3,
    cb: &Point3,
    hc: f64,
    (hb_min, hb_max): (f64, f64),
    target: f64,
    ds: f64,
) -> Result<(Vec<Point3>, f64), String> {
    let eval = |hb: f64| {
        let spec = PathSpec::between(cyl, ca, cb, hc, hb);
        let p = project(wall, cyl, &spec, (*ca, None, *cb), ds);
        (length(&p), p)
    };
    let (lmin, _) = eval(hb_min);
    let (lmax, _) = eval(hb_max);
    if target < lmin || target > lmax {
        if target < lmin {
            return Err(format!(
                "attachment edge {target:.2} mm is shorter than the shallowest path ({lmin:.2} mm)"
            ));
        }
        return Err(format!(
            "attachment edge {target:.2} mm is longer than the deepest path the wall allows ({lmax:.2} mm at depth {hb_max:.2} mm)"
        ));
    }
    // Regula falsi keeps the bracket (length grows with depth).
    let (mut a, mut la, mut b, mut lb) = (hb_min, lmin, hb_max, lmax);
    for _ in 0..40 {
        let m = a + (target - la) * (b - a) / (lb - la);
        let (lm, pm) = eval(m);
        if ((lm - target) / target).abs() < 1e-3 {
            return Ok((pm, m));
        }
        if lm < target {
            (a, la) = (m, lm);
        } else {
            (b, lb) = (m, lm);
        }
        if (b - a) < 1e-6 {
            break;
        }
    }
    let m = (a + b) / 2.0;
    let (_, pm) = eval(m);
    Ok((pm, m))
}
