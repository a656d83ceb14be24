//! The landmark-free VAJ plane settled onto the floor of the sinuses.
//!
//! The knee of [`super::vaj::judge`] is read on sections perpendicular to
//! the centreline marched down the ascending aorta. Where the root's axis
//! leans away from the ascending aorta's (on the real CT the nadir plane's
//! normal is 36° from the head–feet axis, the marched sections' 14°), those
//! sections cut the root slanted: the sinus on one side is still in the
//! section while the other side has reached the LVOT, so the descent seems
//! to flatten early, and the plane lay 5.6 mm above the nadir plane and
//! 25° off it (862 of the 1627 voxels missed lay in the first 10 mm above
//! the annulus).
//!
//! From the knee the march goes on down, each station turned to the
//! *least* section through it (within [`CONE_DEG`] of the last one's
//! normal). The least section through a point of a tube is square to its
//! axis, so the march turns onto the axis of the root's floor and the LVOT;
//! the annulus is the narrowest section of the LVOT–root transition, where
//! the descent of those least sections flattens. On the real CT the march
//! turned by 27° over 7 stations and the plane lies 3.7° from the nadir
//! plane, its centre 0.9 mm below the nadirs' (Dice 0.932 → 0.958, mean
//! surface distance 0.85 → 0.56 mm, as with the landmarks). On the
//! phantoms, whose march is square to the root already, it moves the plane
//! by at most a station and the masks score as before.
//!
//! Where the descent is flat from the knee on, the march has nothing to
//! settle, yet an annulus tilted to the root's axis is still cut slanted:
//! on the clinical phantoms (annulus tilted 14–23° to the knee's section)
//! the knee's plane lay 14–23° off the nadirs' and a nadir up to 3 mm
//! below it, outside the mask. The LVOT stands square to the annulus, so
//! its axis below the knee, through the centroids of its sections, gives
//! the annulus' normal, and the plane turns onto it and rises to the
//! narrowest section square to it (see [`lvot_axis`],
//! [`narrowest_above`]): on those phantoms, and with their annulus tilted
//! 10–35°, the plane then lies 1.4–3.5° off the nadirs' plane.

use super::vaj::{Cells, KNEE_FLAT, KNEE_SPAN, Plane, SINUS_RISE};
use coapt_geom::basis::orthonormal_pair;
use coapt_geom::{Point3, Vector3};

/// Step between stations (mm).
const STEP_MM: f64 = 1.0;
/// Most stations (of [`STEP_MM`]) below the knee: the perpendicular
/// sections' knee lay 5.6 mm above the annulus on the real CT; a sinus is
/// ≤ 21 mm tall.
const MAX_STATIONS: usize = 14;
/// How far a station's normal may turn from the last one's (degrees), and
/// the angular step of the search.
const CONE_DEG: f64 = 15.0;
const CONE_STEP_DEG: f64 = 3.0;
/// Most the settled normal may differ from the knee's (degrees): beyond
/// that the march has left the root.
const MAX_TURN_DEG: f64 = 45.0;
/// A narrowing of less than this share of the section over [`KNEE_SPAN`]
/// stations is read as flat: the least sections of the phantoms' LVOT vary
/// by 1.5–3 % over two stations.
const DESCENT_MIN: f64 = 0.03;

/// Stations below the settled plane over which the section must hold
/// (within [`SINUS_RISE`] of the plane's): the LVOT, not the region's end.
const LVOT_SPAN: usize = 4;

/// Depths below the knee (mm) of the two sections square to the LVOT whose
/// centroids give its axis (see [`lvot_axis`]). Shallower, the upper
/// section cuts the sinus on the high side of a steep annulus; deeper, the
/// lower one reaches where the LVOT bends towards the apex or the region
/// ends in the LV. Nadirs from the CT alone at 3–7 mm (clinical seed 1 with
/// its annulus tilted 10 / 20 / 30 / 35°, clinical seeds 2–3): every one
/// within 1.47 mm, the planes 1.4–3.5° off the nadirs'; at 2–7 mm up to
/// 1.53 mm, at 4–8 mm 1.75 mm, at 3–8 mm standard seed 2 turned past
/// [`LVOT_MIN_TURN_DEG`], at 4–10 mm every untilted sample seed did.
const LVOT_AXIS_DEPTHS_MM: (f64, f64) = (3.0, 7.0);
/// Passes of the axis onto its sections' centroids, and the turn (degrees)
/// below which it has settled (an untilted LVOT's passes alternate about
/// their limit: standard seed 2 10.1, 4.6, 7.3, 5.7, 6.6 … 6.2°).
const LVOT_AXIS_PASSES: usize = 12;
const LVOT_AXIS_SETTLED_DEG: f64 = 0.1;
/// Most the upper section square to the LVOT's axis may exceed the one
/// square to the march at the same depth. Turned onto a tilted LVOT's axis
/// it shrinks (clinical seeds 1–3 and seed 1 tilted 10–35°: by 0.1–3.2 %;
/// the lower section by 4.9–13.4 %); on sample seed 15, untilted, the
/// centroids followed the slanted end of the region 21° away and the upper
/// section grew 7.5 %.
const LVOT_SECTION_GROWTH: f64 = 0.01;
/// A turn of less than this leaves the knee's plane as it was: on untilted
/// annuli the LVOT's axis lies 0.9–6.2° off the march (sample seeds 3, 5,
/// 9, clinical seed 1 untilted, standard seed 2), on annuli tilted
/// 10–35° (clinical seeds 1–3) 13.1–24.0°.
const LVOT_MIN_TURN_DEG: f64 = 10.0;
/// The turned plane is raised to the narrowest section within this
/// height above the knee, read every [`RAISE_STEP_MM`] (see
/// [`narrowest_above`]).
const RAISE_MAX_MM: f64 = 6.0;
const RAISE_STEP_MM: f64 = 0.5;

/// The turned march below the knee, for `segment.json`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Floor {
    /// Area of each least section (mm²), the first at the knee.
    pub area_mm2: Vec<f64>,
    /// Station of the settled plane (mm below the knee along the march);
    /// None when the descent did not flatten (the plane stays at the knee).
    pub settled_mm: Option<f64>,
    /// Angle between the knee's plane and the settled one (degrees).
    pub turn_deg: f64,
    /// Where the descent was flat from the knee on: the angle (degrees)
    /// the plane turned onto the LVOT's axis below the knee ([`lvot_axis`]),
    /// or None where it kept the knee's normal.
    pub lvot_turn_deg: Option<f64>,
    /// How far that turned plane was raised above the knee's centre to the
    /// narrowest section (mm).
    pub lvot_raised_mm: Option<f64>,
}

/// Unit vectors within `max_deg` of `t` on rings `step_deg` apart, `t`
/// first (so a tie keeps the current direction).
fn cone(t: &Vector3, max_deg: f64, step_deg: f64) -> Vec<Vector3> {
    let (u, v) = orthonormal_pair(t);
    let mut out = vec![*t];
    let rings = (max_deg / step_deg).round() as usize;
    for ring in 1..=rings {
        let th = (ring as f64 * step_deg).to_radians();
        let k =
            ((std::f64::consts::TAU * th.sin() / step_deg.to_radians()).round() as usize).max(6);
        for s in 0..k {
            let ph = std::f64::consts::TAU * s as f64 / k as f64;
            out.push(t * th.cos() + (u * ph.cos() + v * ph.sin()) * th.sin());
        }
    }
    out
}

/// From the knee at `centre` (march direction `t`, toward the LV; section
/// `area` mm²) down by least sections; the plane where their descent
/// flattens (normal toward the aorta), or None (keep the knee's plane).
pub(super) fn settle(
    cells: &Cells,
    voxel_mm3: f64,
    w: f64,
    centre: Point3,
    t: Vector3,
    area: f64,
    reach_max: f64,
) -> (Option<Plane>, Floor) {
    let mut floor = Floor {
        area_mm2: Vec::new(),
        settled_mm: None,
        turn_deg: 0.0,
        lvot_turn_deg: None,
        lvot_raised_mm: None,
    };
    let (mut p, mut n, mut r) = (centre, t, (area / std::f64::consts::PI).sqrt());
    let (mut centres, mut normals) = (Vec::new(), Vec::new());
    for s in 0..=MAX_STATIONS + LVOT_SPAN {
        let q = if s == 0 { p } else { p + n * STEP_MM };
        let reach = reach_max.min(1.8 * r + 3.0);
        let mut best: Option<(f64, Vector3, Vector3)> = None;
        for c in cone(&n, CONE_DEG, CONE_STEP_DEG) {
            let (k, off) = cells.section(&q, &c, w, reach);
            if best.is_none_or(|(b, _, _)| k < b) {
                best = Some((k, c, off));
            }
        }
        let Some((k, c, off)) = best else { break };
        if k == 0.0 || c.dot(&t) < MAX_TURN_DEG.to_radians().cos() {
            break;
        }
        let a = k * voxel_mm3 / w;
        p = q + off;
        n = c;
        r = (a / std::f64::consts::PI).sqrt();
        centres.push(p);
        normals.push(n);
        floor.area_mm2.push(a);
    }
    let a = &floor.area_mm2;
    let mut steepest = 0.0f64;
    let knee = (0..a.len().saturating_sub(KNEE_SPAN)).find(|&y| {
        let drop = a[y] - a[y + KNEE_SPAN];
        let flat = drop < (KNEE_FLAT * steepest).max(DESCENT_MIN * a[y]);
        steepest = steepest.max(drop);
        flat
    });
    // Below the annulus the LVOT holds its section; a descent that goes on
    // narrowing is the taper where the IDT cut the region (sample t0 n80:
    // the region ends ~4 mm below the annulus, and the turned march
    // followed that taper 5 mm down, 2.7 mm below the annulus).
    let lvot_holds = |y: usize| {
        y + LVOT_SPAN < a.len()
            && a[y + 1..=y + LVOT_SPAN]
                .iter()
                .all(|&x| x >= (1.0 - SINUS_RISE) * a[y])
    };
    match knee {
        Some(y) if y > 0 && lvot_holds(y) => {
            floor.settled_mm = Some(y as f64 * STEP_MM);
            floor.turn_deg = normals[y].dot(&t).clamp(-1.0, 1.0).acos().to_degrees();
            // A section spans ±w along its normal: the first one with a
            // flat span ahead lies up to w below where the sinus begins to
            // widen; the plane goes half of that back up.
            let at = centres[y] - normals[y] * (0.5 * w);
            (Some(Plane::new(at, -normals[y])), floor)
        }
        _ => {
            let reach = reach_max.min(1.8 * (area / std::f64::consts::PI).sqrt() + 3.0);
            let n = lvot_axis(cells, centre, t, w, reach);
            let turn = n.dot(&t).clamp(-1.0, 1.0).acos().to_degrees();
            // Past MAX_TURN_DEG, as for the march, it has left the root.
            if !(LVOT_MIN_TURN_DEG..=MAX_TURN_DEG).contains(&turn) {
                return (None, floor);
            }
            let up = narrowest_above(cells, centre, n, w, reach);
            floor.lvot_turn_deg = Some(turn);
            floor.lvot_raised_mm = Some(up);
            (Some(Plane::new(centre - n * up, -n)), floor)
        }
    }
}

/// The LVOT's axis (toward the LV) below the knee at `centre` (march
/// direction `t`): the line through the centroids of the sections square
/// to it [`LVOT_AXIS_DEPTHS_MM`] below the knee, passed onto itself until
/// it settles. A section's centroid hardly moves as the section turns,
/// where its area changes only with the secant of the turn (1.5 % at 10°,
/// within the LVOT's own variation): the least section searched over a
/// cone of directions 4 mm below the knee lay 14.7° off the nadirs' plane
/// on clinical seed 1 with its annulus tilted 35°, where this axis lies
/// 2.6° off. `t` itself where a section is empty or holds less than the
/// knee's section less [`SINUS_RISE`] (the region ends in a taper there,
/// not in the LVOT), or where the upper section square to the axis found
/// is larger than the one square to `t` by more than
/// [`LVOT_SECTION_GROWTH`].
fn lvot_axis(cells: &Cells, centre: Point3, t: Vector3, w: f64, reach: f64) -> Vector3 {
    let knee = cells.section(&centre, &t, w, reach).0;
    let (d1, d2) = LVOT_AXIS_DEPTHS_MM;
    let sections = |n: &Vector3| {
        let (p1, p2) = (centre + n * d1, centre + n * d2);
        let (k1, o1) = cells.section(&p1, n, w, reach);
        let (k2, o2) = cells.section(&p2, n, w, reach);
        ([k1, k2], (p2 + o2) - (p1 + o1))
    };
    let (square_to_t, _) = sections(&t);
    let mut n = t;
    for _ in 0..LVOT_AXIS_PASSES {
        let (k, along) = sections(&n);
        if k[0].min(k[1]) < (1.0 - SINUS_RISE) * knee || k[0].min(k[1]) == 0.0 {
            return t;
        }
        let Some(next) = along.try_normalize(1e-9) else {
            return t;
        };
        let turn = next.dot(&n).clamp(-1.0, 1.0).acos().to_degrees();
        n = next;
        if turn < LVOT_AXIS_SETTLED_DEG {
            break;
        }
    }
    // Square to a tube's axis its sections are least: a turn onto the
    // axis of a tilted LVOT shrinks the upper one, a turn onto the slant
    // of the region's end grows it. (The lower one may reach where the
    // region ends, which cuts the march's section there short.)
    let (square_to_n, _) = sections(&n);
    if square_to_n[0] > (1.0 + LVOT_SECTION_GROWTH) * square_to_t[0] {
        t
    } else {
        n
    }
}

/// How far above `centre` (mm, along −`n`, in steps of [`RAISE_STEP_MM`]
/// up to [`RAISE_MAX_MM`]) the section square to `n` is narrowest: the
/// annulus, the narrowest section of the LVOT–root transition. The knee
/// was read on sections square to the march, which leave a tilted
/// annulus only below its low side: on the clinical phantoms the nadirs
/// lay 0.9–2.0 mm above the turned plane through the knee (one search),
/// and −0.55 to +0.98 mm about the plane raised 0.5–1 mm to the narrowest
/// section (two).
fn narrowest_above(cells: &Cells, centre: Point3, n: Vector3, w: f64, reach: f64) -> f64 {
    let steps = (RAISE_MAX_MM / RAISE_STEP_MM).round() as usize;
    let mut best = (cells.section(&centre, &n, w, reach).0, 0.0);
    for i in 1..=steps {
        let up = i as f64 * RAISE_STEP_MM;
        let (k, _) = cells.section(&(centre - n * up), &n, w, reach);
        if k < best.0 {
            best = (k, up);
        }
    }
    best.1
}
