//! Valve frame from snapped landmarks and the wall: axis ⟂ the commissure
//! plane (oriented LV → aorta by the surface), annulus level and centre,
//! radii measured by radial ray casting.

use std::f64::consts::PI;

use serde::Serialize;

use coapt_geom::wall::Wall;
use coapt_geom::{Point3, TriMesh, ValveFrame, Vector3};

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

/// What decided the axis direction (LV → aorta).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Orientation {
    /// The commissures lie above the nadirs: the leaflets hang from the
    /// commissures down to the annulus, whatever else the surface holds.
    Nadirs,
    /// The wall within two commissure radii of the commissure circle: the
    /// ascending aorta continues above the commissures, while the LV side
    /// ends at the annulus (a cut at the VAJ or a short LVOT stub). The
    /// whole surface would not do: an arch and a descending aorta put its
    /// centroid anywhere.
    WallNearRoot,
}

impl Orientation {
    pub fn name(self) -> &'static str {
        match self {
            Orientation::Nadirs => "nadirs below the commissures",
            Orientation::WallNearRoot => "wall within two commissure radii",
        }
    }
}

/// The commissure cylinder with its axis oriented LV → aorta.
pub fn commissure_cylinder(
    mesh: &TriMesh,
    c: &[Point3; 3],
    nadirs: Option<&[Point3; 3]>,
) -> Option<(CommissureCylinder, Orientation)> {
    let (centre, mut axis, radius) = circle3(c)?;
    let mut how = Orientation::WallNearRoot;
    let mut s = 0.0;
    if let Some(n) = nadirs {
        let mean = |p: &[Point3; 3]| (p[0].coords + p[1].coords + p[2].coords) / 3.0;
        s = (mean(c) - mean(n)).dot(&axis);
        how = Orientation::Nadirs;
    }
    // Nadirs level with the commissures say nothing: fall back to the wall.
    if s.abs() < 1e-3 * radius {
        how = Orientation::WallNearRoot;
        let region = mesh.cell_data.get("region").and_then(|a| a.values.to_f64());
        s = 0.0;
        for t in 0..mesh.triangles.len() {
            if region
                .as_ref()
                .is_some_and(|r| r.get(t).is_some_and(|&x| x != 0.0))
            {
                continue;
            }
            let p = mesh.corners(t);
            let g = Point3::from((p[0].coords + p[1].coords + p[2].coords) / 3.0);
            if (g - centre).norm() <= 2.0 * radius {
                s += mesh.area(t) * (g - centre).dot(&axis);
            }
        }
    }
    if s < 0.0 {
        axis = -axis;
    }
    let d = c[0] - centre;
    let e1 = (d - axis * d.dot(&axis)).normalize();
    Some((
        CommissureCylinder {
            centre,
            axis,
            e1,
            radius,
        },
        how,
    ))
}

/// A face whose normal lies within this angle's cosine of a section
/// plane's normal faces the plane: a cap, the rounded end of a mask or a
/// ledge, not the wall that bounds the section. 39°: a VAJ cap tilted up to
/// 35° to the commissure plane still faces the axial sections.
const FACING_COS: f64 = 0.78;

/// A crossing that bounds a section of normal `n`: not facing the plane.
/// The `region` labels are not asked: a flat stretch of real wall can be
/// labelled a cut cap (it was on the root-only TotalSegmentator surface,
/// beside the STJ), and a cap across the lumen faces the plane anyway.
fn bounding(wall: &Wall, o: &Point3, d: &Vector3, n: &Vector3, max_t: f64) -> Option<f64> {
    wall.lumen_exit(o, d, max_t)
        .filter(|x| x.normal.dot(n).abs() < FACING_COS)
        .map(|x| x.t)
}

/// A cross-section of the lumen by rays from a centre in a plane.
#[derive(Debug, Clone, Serialize)]
pub struct Section {
    /// Height of the plane's centre along the commissure axis.
    pub height_mm: f64,
    /// Mean ray length from the centre.
    pub mean_radius_mm: f64,
    /// Area of the polygon of the ray hits.
    pub area_mm2: f64,
    /// Diameter of the circle of that area.
    pub equivalent_diameter_mm: f64,
    /// Largest distance between two hits (a caliper diameter).
    pub max_diameter_mm: f64,
    /// Width of the polygon perpendicular to the largest diameter.
    pub perpendicular_diameter_mm: f64,
    /// How far the plane was lifted along its normal to be bounded by the
    /// wall all round (annulus only).
    pub lift_mm: f64,
    /// Rays that met no bounding wall and took their neighbours' length
    /// (at most one in [`MAX_MISSED_FRACTION`]).
    pub rays_interpolated: usize,
}

/// A section is measured when at most one ray in this many misses the wall.
pub const MAX_MISSED_FRACTION: usize = 12;

/// Section in the plane through `o` with unit normal `n`, `k` rays. When
/// some ray meets no bounding wall, the whole plane is lifted along `n` by
/// the next step of `lifts` (the segmentation may end at the plane itself:
/// rays there graze its cap or its ragged end); `Err` gives the angle of a
/// ray that met no wall at the last lift.
pub fn plane_section(
    wall: &Wall,
    o: &Point3,
    n: &Vector3,
    e1: &Vector3,
    k: usize,
    lifts: &[f64],
    max_t: f64,
    height_mm: f64,
) -> Result<Section, f64> {
    let e1 = (e1 - n * e1.dot(n)).normalize();
    let e2 = n.cross(&e1);
    let mut failed = 0.0;
    for &lift in lifts {
        let ol = o + n * lift;
        let ts: Vec<Option<f64>> = (0..k)
            .map(|j| {
                let a = 2.0 * PI * j as f64 / k as f64;
                bounding(wall, &ol, &(e1 * a.cos() + e2 * a.sin()), n, max_t)
            })
            .collect();
        let missed = ts.iter().filter(|t| t.is_none()).count();
        if missed > k / MAX_MISSED_FRACTION {
            failed = 2.0 * PI * ts.iter().position(|t| t.is_none()).unwrap_or(0) as f64 / k as f64;
            continue;
        }
        // A few rays grazing the rim of a cap or a mask's ragged end take
        // the length between their neighbours'.
        let ts: Vec<f64> = (0..k)
            .map(|j| {
                ts[j].unwrap_or_else(|| {
                    let step = |dir: usize| {
                        (1..k).find_map(|m| ts[(j + dir * m) % k].map(|t| (m as f64, t)))
                    };
                    let ((ma, ta), (mb, tb)) = (
                        step(1).expect("some ray hit"),
                        step(k - 1).expect("some ray hit"),
                    );
                    (ta * mb + tb * ma) / (ma + mb)
                })
            })
            .collect();
        let pts: Vec<[f64; 2]> = (0..k)
            .map(|j| {
                let a = 2.0 * PI * j as f64 / k as f64;
                [ts[j] * a.cos(), ts[j] * a.sin()]
            })
            .collect();
        let mut sec = section_stats(&pts, ts.iter().sum::<f64>() / k as f64, height_mm, lift);
        sec.rays_interpolated = missed;
        return Ok(sec);
    }
    Err(failed)
}

fn section_stats(pts: &[[f64; 2]], mean: f64, height_mm: f64, lift: f64) -> Section {
    let k = pts.len();
    let mut area = 0.0;
    for j in 0..k {
        let (p, q) = (pts[j], pts[(j + 1) % k]);
        area += 0.5 * (p[0] * q[1] - p[1] * q[0]);
    }
    let (mut dmax, mut dir) = (0.0, [1.0, 0.0]);
    for i in 0..k {
        for j in i + 1..k {
            let (dx, dy) = (pts[j][0] - pts[i][0], pts[j][1] - pts[i][1]);
            let d = dx.hypot(dy);
            if d > dmax {
                dmax = d;
                dir = [dx / d, dy / d];
            }
        }
    }
    let w: Vec<f64> = pts.iter().map(|p| -p[0] * dir[1] + p[1] * dir[0]).collect();
    let width = w.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - w.iter().copied().fold(f64::INFINITY, f64::min);
    Section {
        height_mm,
        mean_radius_mm: mean,
        area_mm2: area,
        equivalent_diameter_mm: 2.0 * (area.max(0.0) / PI).sqrt(),
        max_diameter_mm: dmax,
        perpendicular_diameter_mm: width,
        lift_mm: lift,
        rays_interpolated: 0,
    }
}

/// Section perpendicular to the commissure axis at height `h`.
pub fn axial_section(wall: &Wall, cyl: &CommissureCylinder, h: f64, k: usize) -> Option<Section> {
    plane_section(
        wall,
        &cyl.axis_point(h),
        &cyl.axis,
        &cyl.e1,
        k,
        &[0.0],
        20.0 * cyl.radius,
        h,
    )
    .ok()
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
    /// Angle between the annulus (nadir) plane and the commissure plane.
    pub annulus_tilt_deg: f64,
    pub annulus_section: Section,
    /// The largest section perpendicular to the axis between the highest
    /// nadir and the lowest commissure.
    pub sinus_section: Option<Section>,
    pub stj_section: Option<Section>,
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

/// Lifts (mm, along the annulus plane's normal) tried for a ray of the
/// annulus section that meets no bounding wall in the plane itself: the
/// segmentation usually ends at the annulus, so the plane runs along its
/// cap or its rounded end. 5 mm is a quarter of a typical h_comm.
const ANNULUS_LIFTS: [f64; 21] = [
    0.05, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 2.75, 3.0, 3.25, 3.5, 3.75, 4.0,
    4.25, 4.5, 4.75, 5.0,
];

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
    let max_t = 20.0 * cyl.radius;
    let (annulus_from, h_ann, origin, plane_n) = match nadirs {
        Some(n) => {
            let (centre, mut nn, _) =
                circle3(n).ok_or("the three nadirs are collinear: no annulus circle")?;
            if nn.dot(&cyl.axis) < 0.0 {
                nn = -nn;
            }
            ("nadirs", cyl.height_angle(&centre).0, centre, nn)
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
            ("narrowest section", h, p, cyl.axis)
        }
    };
    // In the annulus plane itself, from the nadirs' circumcentre: a plane
    // perpendicular to the commissure axis at the nadirs' mean height cuts
    // a root tilted 15–35° through the LVOT cap on one side and the sinus on
    // the other.
    let annulus_section = plane_section(
        wall,
        &origin,
        &plane_n,
        &cyl.e1,
        72,
        &ANNULUS_LIFTS,
        max_t,
        h_ann,
    )
    .map_err(|a| {
        format!(
            "the annulus section is not bounded by the wall: the ray at {:.0}° from C1's side meets no wall within {} mm above the annulus plane",
            a.to_degrees(),
            ANNULUS_LIFTS[ANNULUS_LIFTS.len() - 1]
        )
    })?;
    let annulus_tilt_deg = plane_n.dot(&cyl.axis).clamp(-1.0, 1.0).acos().to_degrees();
    let ang: Vec<f64> = c.iter().map(|p| cyl.height_angle(p).1).collect();
    // Each sinus from just above its own nadir (on a tilted root the nadirs
    // sit at different heights along the commissure axis, and below a
    // nadir the ray leaves the lumen through the annulus) up to its two
    // commissures.
    let mut sinus = [0.0; 3];
    for k in 0..3 {
        let a0 = ang[k];
        let d = wrap(ang[(k + 1) % 3] - a0);
        let mid = a0 + d / 2.0;
        let bottom = match nadirs {
            Some(n) => cyl.height_angle(&n[k]).0 + 0.5,
            None => h_ann,
        };
        let top = (hc[k] + hc[(k + 1) % 3]) / 2.0;
        let mut h = bottom.max(lo + 0.05);
        while h < top {
            if let Some(t) = bounding(wall, &cyl.axis_point(h), &cyl.dir(mid), &cyl.axis, max_t) {
                sinus[k] = f64::max(sinus[k], t);
            }
            h += step;
        }
    }
    let sinus_bottom = match nadirs {
        Some(n) => {
            n.iter()
                .map(|p| cyl.height_angle(p).0)
                .fold(f64::NEG_INFINITY, f64::max)
                + 0.5
        }
        None => h_ann + 0.5,
    };
    let mut sinus_section: Option<Section> = None;
    let mut h = sinus_bottom.max(lo + 0.05);
    while h < h_comm_min {
        if let Some(s) = axial_section(wall, cyl, h, 72) {
            if sinus_section
                .as_ref()
                .is_none_or(|b| s.area_mm2 > b.area_mm2)
            {
                sinus_section = Some(s);
            }
        }
        h += 0.5;
    }
    let mut stj_section: Option<Section> = None;
    let mut h = h_comm_mean;
    while h < (h_comm_mean + 10.0).min(hi - 0.5) {
        if let Some(s) = axial_section(wall, cyl, h, 72) {
            if stj_section
                .as_ref()
                .is_none_or(|b| s.mean_radius_mm < b.mean_radius_mm)
            {
                stj_section = Some(s);
            }
        }
        h += step;
    }
    let stj = stj_section
        .as_ref()
        .map_or(f64::INFINITY, |s| s.mean_radius_mm);
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
            annulus_mm: annulus_section.mean_radius_mm,
            sinus_mm: sinus,
            stj_mm: stj,
            commissure_circumradius_mm: cyl.radius,
        },
        commissure_angles_deg: [0.0, deg(a1), deg(a2)],
        annulus_tilt_deg,
        annulus_section,
        sinus_section,
        stj_section,
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
