//! Valve frame from snapped landmarks and the wall: axis ⟂ the commissure
//! plane (oriented LV → aorta by the surface), annulus level and centre,
//! radii measured by radial ray casting.

use std::f64::consts::PI;

use serde::Serialize;

use super::wall::Wall;
use crate::geom::{Point3, TriMesh, ValveFrame, Vector3};

/// The cylinder of the commissures: centre, axis, circumradius.
#[derive(Debug, Clone, Copy)]
pub struct CommissureCylinder {
    pub centre: Point3,
    pub axis: Vector3,
    pub e1: Vector3,
    pub radius: f64,
}

impl CommissureCylinder {
    pub fn e2(&self) -> Vector3 {
        self.axis.cross(&self.e1)
    }

    /// (height along the axis from the centre, angle from e1).
    pub fn height_angle(&self, p: &Point3) -> (f64, f64) {
        let d = p - self.centre;
        (d.dot(&self.axis), d.dot(&self.e2()).atan2(d.dot(&self.e1)))
    }

    pub fn dir(&self, angle: f64) -> Vector3 {
        self.e1 * angle.cos() + self.e2() * angle.sin()
    }

    pub fn axis_point(&self, h: f64) -> Point3 {
        self.centre + self.axis * h
    }
}

/// Circumcentre, unit normal (unoriented) and circumradius of a triangle.
pub fn circle3(c: &[Point3; 3]) -> Option<(Point3, Vector3, f64)> {
    let (a, b) = (c[1] - c[0], c[2] - c[0]);
    let n = a.cross(&b);
    let n2 = n.norm_squared();
    if n2 < 1e-18 {
        return None;
    }
    let off =
        (b * a.norm_squared()).cross(&n) * 0.5 / n2 + (n.cross(&(a * b.norm_squared()))) * 0.5 / n2;
    let centre = c[0] + off;
    Some((centre, n / n2.sqrt(), off.norm()))
}

/// Axis oriented towards the side where the surface extends further: the
/// ascending aorta is long, the LV outflow stub is short, so the
/// area-weighted centroid of the surface lies on the aortic side.
pub fn commissure_cylinder(mesh: &TriMesh, c: &[Point3; 3]) -> Option<CommissureCylinder> {
    let (centre, mut axis, radius) = circle3(c)?;
    let mut s = 0.0;
    for t in 0..mesh.triangles.len() {
        let p = mesh.corners(t);
        let g = Point3::from((p[0].coords + p[1].coords + p[2].coords) / 3.0);
        s += mesh.area(t) * (g - centre).dot(&axis);
    }
    if s < 0.0 {
        axis = -axis;
    }
    let d = c[0] - centre;
    let e1 = (d - axis * d.dot(&axis)).normalize();
    Some(CommissureCylinder {
        centre,
        axis,
        e1,
        radius,
    })
}

/// Mean radial distance from the axis to the wall at height `h` (rays in
/// `n` directions) and the mean hit point; `None` when a ray misses.
pub fn section(wall: &Wall, cyl: &CommissureCylinder, h: f64, n: usize) -> Option<(f64, Point3)> {
    let o = cyl.axis_point(h);
    let mut r = 0.0;
    let mut c = Vector3::zeros();
    for k in 0..n {
        let a = 2.0 * PI * k as f64 / n as f64;
        let t = first_hit(wall, cyl, &o, a)?;
        let d = cyl.dir(a);
        r += t;
        c += (o + d * t).coords;
    }
    Some((r / n as f64, Point3::from(c / n as f64)))
}

#[derive(Debug, Clone, Serialize)]
pub struct Radii {
    pub annulus_mm: f64,
    /// Per sinus (between C_k and C_{k+1}), the largest radius at its centre angle.
    pub sinus_mm: [f64; 3],
    pub stj_mm: f64,
    pub commissure_circumradius_mm: f64,
}

/// The frame and the measurements of `valve.json`.
#[derive(Debug, Clone)]
pub struct Measured {
    pub frame: ValveFrame,
    pub annulus_from: &'static str,
    pub annulus_height_mm: f64,
    pub radii: Radii,
    pub commissure_angles_deg: [f64; 3],
    pub h_comm_mm: f64,
}

/// Lowest and highest heights of wall triangles along the axis.
fn wall_span(mesh: &TriMesh, cyl: &CommissureCylinder) -> (f64, f64) {
    let region = mesh.cell_data.get("region").and_then(|a| a.values.to_f64());
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if region.as_ref().is_some_and(|r| r[t] != 0.0) {
            continue;
        }
        for &v in tri {
            let h = (mesh.vertices[v as usize] - cyl.centre).dot(&cyl.axis);
            lo = lo.min(h);
            hi = hi.max(h);
        }
    }
    (lo, hi)
}

pub fn measure(
    mesh: &TriMesh,
    wall: &Wall,
    cyl: &CommissureCylinder,
    c: &[Point3; 3],
    nadirs: Option<&[Point3; 3]>,
) -> Result<Measured, String> {
    let (lo, hi) = wall_span(mesh, cyl);
    let hc: Vec<f64> = c.iter().map(|p| cyl.height_angle(p).0).collect();
    let h_comm_min = hc.iter().copied().fold(f64::INFINITY, f64::min);
    let h_comm_mean = hc.iter().sum::<f64>() / 3.0;
    let step = 0.25;
    let (annulus_from, h_ann, origin) = match nadirs {
        Some(n) => {
            let (centre, _, _) =
                circle3(n).ok_or("the three nadirs are collinear: no annulus circle")?;
            ("nadirs", cyl.height_angle(&centre).0, centre)
        }
        None => {
            // Narrowest section between the bottom of the wall and the commissures.
            let mut best: Option<(f64, f64, Point3)> = None;
            let mut h = lo + 0.5;
            while h < h_comm_min {
                if let Some((r, p)) = section(wall, cyl, h, 36) {
                    if best.as_ref().is_none_or(|b| r < b.1) {
                        best = Some((h, r, p));
                    }
                }
                h += step;
            }
            let (h, _, p) =
                best.ok_or("no closed cross-section of the wall below the commissures")?;
            ("narrowest section", h, p)
        }
    };
    let annulus = section(wall, cyl, h_ann.max(lo + 0.05), 72)
        .map(|s| s.0)
        .ok_or("the annulus section is not closed by the wall")?;
    let ang: Vec<f64> = c.iter().map(|p| cyl.height_angle(p).1).collect();
    let mut sinus = [0.0; 3];
    for k in 0..3 {
        let a0 = ang[k];
        let d = wrap(ang[(k + 1) % 3] - a0);
        let mid = a0 + d / 2.0;
        let mut h = h_ann.max(lo + 0.05);
        while h < h_comm_mean {
            if let Some(t) = first_hit(wall, cyl, &cyl.axis_point(h), mid) {
                sinus[k] = f64::max(sinus[k], t);
            }
            h += step;
        }
    }
    let mut stj = f64::INFINITY;
    let mut h = h_comm_mean;
    while h < (h_comm_mean + 10.0).min(hi - 0.5) {
        if let Some((r, _)) = section(wall, cyl, h, 36) {
            stj = stj.min(r);
        }
        h += step;
    }
    let frame = ValveFrame::new(origin, cyl.axis, *c, nadirs.copied())
        .ok_or("commissure C1 lies on the valve axis")?;
    let (_, a1, _) = frame.to_cylindrical(&c[1]);
    let (_, a2, _) = frame.to_cylindrical(&c[2]);
    let deg = |a: f64| a.rem_euclid(2.0 * PI).to_degrees();
    Ok(Measured {
        h_comm_mm: hc.iter().map(|h| h - h_ann).sum::<f64>() / 3.0,
        frame,
        annulus_from,
        annulus_height_mm: h_ann,
        radii: Radii {
            annulus_mm: annulus,
            sinus_mm: sinus,
            stj_mm: stj,
            commissure_circumradius_mm: cyl.radius,
        },
        commissure_angles_deg: [0.0, deg(a1), deg(a2)],
    })
}

/// First wall crossing of the radial ray at `angle` from `o`. A ray that
/// grazes a mesh edge exactly can slip between its two triangles; then
/// the angle is nudged by a microradian.
pub fn first_hit(wall: &Wall, cyl: &CommissureCylinder, o: &Point3, angle: f64) -> Option<f64> {
    for nudge in [0.0, 1e-6, -1e-6, 3e-6] {
        if let Some(t) = wall
            .hits(o, &cyl.dir(angle + nudge), 20.0 * cyl.radius)
            .first()
        {
            return Some(*t);
        }
    }
    None
}

/// Angle difference wrapped to (−π, π].
pub fn wrap(a: f64) -> f64 {
    let mut a = a.rem_euclid(2.0 * PI);
    if a > PI {
        a -= 2.0 * PI;
    }
    a
}
