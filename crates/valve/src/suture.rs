//! Suture paths (docs/valve-and-leaflets.md): seed 001's eq. 1 curve — straight
//! parts of height H_c at the commissures and an elliptic arc through the
//! nadir — drawn in (angle, height) on the commissure cylinder and projected
//! onto the wall by radial rays from the axis.

use std::f64::consts::PI;

use super::frame::{CommissureCylinder, wrap};
use coapt_geom::Point3;
use coapt_geom::wall::Wall;

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
    pub fn on_cylinder(&self, r: f64) -> Vec<coapt_geom::Point3> {
        const PER: usize = 4000;
        (0..=4 * PER)
            .map(|i| {
                let (ang, z) = self.at(i as f64 / PER as f64);
                coapt_geom::Point3::new(r * ang.cos(), r * ang.sin(), z)
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

/// A projected suture path.
pub struct Projected {
    pub points: Vec<Point3>,
    /// Set when the nadir landmark was not pinned: how far (mm) it lies
    /// from the path's own nadir point (see [`project`]).
    pub nadir_unpinned_mm: Option<f64>,
}

/// A nadir pin that turns the path by more than this (degrees, between the
/// path's directions [`TURN_REACH_MM`] before and after it) is not taken.
pub const NADIR_PIN_MAX_TURN_DEG: f64 = 90.0;
/// How far along the path the directions at a pin are taken (mm): past
/// the wall's voxel-scale roughness.
const TURN_REACH_MM: f64 = 0.5;

/// Project the curve onto the wall, pin commissures (and the nadir when it
/// is a landmark) and resample to spacing ≤ `ds` by arc length. The path
/// never turns back on itself (see [`despike`]).
///
/// The nadir landmark is snapped to the nearest wall point, on the sinus
/// floor, where the horizontal rays at its height graze the wall and may
/// cross it elsewhere: on the real CT resampled to 0.35 × 0.35 × 0.6 mm,
/// N2 pinned 0.5 mm inside its neighbouring rays' crossings made a spike
/// that left a 0.07 mm suture edge, which suturing could not sew. A pin
/// that would turn the path by more than [`NADIR_PIN_MAX_TURN_DEG`] is not
/// taken: the path passes through the rays' own crossing at the nadir's
/// angle and height, and the distance is reported.
pub fn project(
    wall: &Wall,
    cyl: &CommissureCylinder,
    spec: &PathSpec,
    pins: (Point3, Option<Point3>, Point3),
    ds: f64,
) -> Projected {
    // Dense samples in t: ~0.05 mm apart on the cylinder.
    let mut raw: Vec<(Point3, bool)> = vec![(pins.0, true)];
    let mut nadir_at = 0;
    for piece in 0..4 {
        let (t0, t1) = (piece as f64, piece as f64 + 1.0);
        let (a0, h0) = spec.at(t0);
        let (a1, h1) = spec.at((t0 + t1) / 2.0);
        let (a2, h2) = spec.at(t1);
        let approx =
            (cyl.radius * (a1 - a0)).hypot(h1 - h0) + (cyl.radius * (a2 - a1)).hypot(h2 - h1);
        let n = ((approx / 0.05).ceil() as usize).max(4);
        for k in 0..n {
            if k == 0 && piece == 0 {
                continue;
            }
            let t = t0 + (t1 - t0) * k as f64 / n as f64;
            if k == 0 && piece == 2 {
                nadir_at = raw.len();
            }
            let (a, h) = spec.at(t);
            raw.push((
                wall.radial(&cyl.axis_point(h), &cyl.dir(a), cyl.radius),
                false,
            ));
        }
    }
    raw.push((pins.2, true));
    let mut refused = None;
    if let Some(pin) = pins.1 {
        let ray = raw[nadir_at].0;
        raw[nadir_at] = (pin, true);
        let (pinned, split) = despike(&raw, nadir_at);
        if turn_deg(&pinned, split, TURN_REACH_MM) <= NADIR_PIN_MAX_TURN_DEG {
            return Projected {
                points: resampled(&pinned, split, ds),
                nadir_unpinned_mm: None,
            };
        }
        raw[nadir_at] = (ray, false);
        refused = Some(pin);
    }
    let (free, split) = despike(&raw, nadir_at);
    Projected {
        points: resampled(&free, split, ds),
        nadir_unpinned_mm: refused.map(|pin| (pin - free[split]).norm()),
    }
}

/// Each half resampled on its own, so the nadir (or the sample nearest it
/// that is left) stays a path point.
fn resampled(p: &[Point3], split: usize, ds: f64) -> Vec<Point3> {
    let mut out = resample(&p[..=split], ds);
    out.pop();
    out.extend(resample(&p[split..], ds));
    out
}

/// The turn (degrees) of polyline `p` at point `k`: the angle between the
/// chords to the points `reach` mm of arc before and after it.
fn turn_deg(p: &[Point3], k: usize, reach: f64) -> f64 {
    let along = |step: isize| {
        let mut i = k as isize;
        let mut s = 0.0;
        while s < reach && i + step >= 0 && ((i + step) as usize) < p.len() {
            s += (p[(i + step) as usize] - p[i as usize]).norm();
            i += step;
        }
        p[i as usize]
    };
    let (a, b) = (p[k] - along(-1), along(1) - p[k]);
    if a.norm() == 0.0 || b.norm() == 0.0 {
        return 0.0;
    }
    (a.dot(&b) / (a.norm() * b.norm()))
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// The samples of a projected path without its spikes: a sample where the
/// path turns back on itself (the two segments meeting there point more
/// than 90° apart) is dropped, until no unpinned one is left. A rough
/// segmented wall crossed at a grazing angle (the sinus floor) puts rays a
/// fraction of a millimetre in or out of their neighbours, and on a tilted
/// root the crossing jumps between the floor and the sinus wall at the
/// nadir (the real CT's third path: from 7 mm off the commissure axis to
/// 12, and the path ran 5 mm back out along the line it came in on); a
/// suture line has no hairpins. Returns the samples and the index of the
/// one left nearest (in sample order) to sample `mark`.
fn despike(raw: &[(Point3, bool)], mark: usize) -> (Vec<Point3>, usize) {
    let mut out: Vec<(Point3, bool, usize)> = Vec::with_capacity(raw.len());
    for (i, &(q, pinned)) in raw.iter().enumerate() {
        while let [.., (a, _, _), (b, false, _)] = out[..] {
            if (b - a).dot(&(q - b)) < 0.0 {
                out.pop();
            } else {
                break;
            }
        }
        out.push((q, pinned, i));
    }
    let split = (0..out.len())
        .min_by_key(|&k| out[k].2.abs_diff(mark))
        .expect("the pinned ends stay");
    (out.into_iter().map(|o| o.0).collect(), split)
}

#[cfg(test)]
mod despike_tests {
    use super::*;

    #[test]
    fn spikes_go_and_pins_stay() {
        // Along x at 0.05 mm, with a spike 0.5 mm out at sample 10 and a
        // V 0.2 and 0.4 mm in at samples 30–31, sample 20 pinned.
        let mut raw: Vec<(Point3, bool)> = (0..50)
            .map(|i| {
                (
                    Point3::new(0.05 * i as f64, 0.0, 0.0),
                    i == 0 || i == 20 || i == 49,
                )
            })
            .collect();
        raw[10].0.y = 0.5;
        raw[30].0.y = -0.2;
        raw[31].0.y = -0.4;
        let (p, split) = despike(&raw, 20);
        assert_eq!(p.len(), 47);
        assert!(p.iter().all(|q| q.y == 0.0));
        assert_eq!(p[split], raw[20].0);
        // The sample marked but dropped: the nearest one left is the split.
        let (_, split) = despike(&raw, 10);
        assert_eq!(p[split].x, 0.05 * 9.0);
        // A pinned spike stays.
        raw[20].0.y = 0.5;
        let (p, split) = despike(&raw, 20);
        assert_eq!(p[split], raw[20].0);
        // Its chords to the samples beside it (0.5 mm off the line).
        let expect = 180.0 - 2.0 * (0.05f64 / 0.5).atan().to_degrees();
        assert!((turn_deg(&p, split, 0.5) - expect).abs() < 1e-9);
    }
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
    /// Set when the nadir landmark was not pinned (it would have turned
    /// the path back on itself): its distance (mm) from the path's nadir.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nadir_unpinned_mm: Option<f64>,
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
        let p = project(wall, cyl, &spec, (*ca, None, *cb), ds).points;
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
