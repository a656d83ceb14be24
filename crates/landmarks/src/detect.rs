//! Commissures and nadirs from the segmented root, the way a user places
//! them by hand (`../shared/real/README.md`):
//!
//! 1. **Axis.** Start on the annulus plane's normal through the annulus
//!    centre (the centroid of the lumen 1–3 mm above the plane, put back
//!    onto it). Along it, the mean lumen radius against height: its largest
//!    value between 3 and 25 mm is mid-sinus, the first local minimum above
//!    is the STJ (the narrowing above the sinuses). The axis is turned onto
//!    the line from the annulus centre to the STJ section's centroid, and
//!    the profile is read again, until the turn is under 0.2°: the annulus
//!    plane of a real root is tilted 15–26° to the commissure plane, so its
//!    normal is not the root's axis (on `../shared/real/` the first turn is
//!    7.5°).
//! 2. **Pillars and sinuses.** At mid-sinus, the radius against angle
//!    (averaged over ±2 mm of height, smoothed over 9°): its three deepest
//!    minima at least 75° apart are the commissural pillars; in each
//!    sector the maximum of the profile smoothed over 21° is the sinus.
//! 3. **Points.** Commissures on the wall at the centres of the pillars'
//!    troughs, [`COMMISSURE_ABOVE_KNEE_MM`] above the knee of the
//!    narrowing, read on the rays clear of the pillars, where a closed
//!    valve's hinge lines do not dent the mask (not above the STJ, nor less than
//!    [`COMMISSURE_BELOW_WAIST_MM`] below a clear waist); nadirs on the
//!    wall where it meets the annulus plane, at the middle of each sinus'
//!    sector between its commissures, or up on their sinus floor where the
//!    plane is tilted to them.
//!
//! Everything is in world LPS millimetres; one thread, so the result does
//! not depend on the thread count.

use std::f64::consts::TAU;

use serde::Serialize;

use super::angular::{self, SAMPLES};
use super::lumen_rays::LumenProbe;
use super::ostia::{self, NamedBy, Ostium, RootFrame};
use coapt_geom::basis::orthonormal_pair;
use coapt_geom::landmarks::SINUS_NAMES;
use coapt_geom::{Point3, Vector3, Volume};

/// Height of the commissures above the knee of the narrowing (mm): the
/// level where the mean radius has come within [`KNEE_SHARE`] of the
/// narrowing's depth (at least [`KNEE_MIN_MM`]) of its value at the STJ.
/// The STJ itself, the first minimum above the sinuses, is no height to
/// hang the commissures from where the ascending aorta is as narrow as
/// the STJ: the mean radius is then flat for several millimetres and its
/// lowest sample lies anywhere on the flat (sample-preset phantom seed 13:
/// 14.32–14.36 mm from 16 to 22 mm, the minimum at 20.5 mm, the
/// commissures at 16.5). Over 30 cases (sample-preset seeds 1–20 and
/// standard seeds 1–2 from the CT alone, the sample's truth mask, the
/// clinical phantom's three truth masks and three CTs, the real CT) the
/// commissures stood 0.68 mm above the knee on average (SD 0.55 mm; −0.40
/// to +1.96), against 0.79 mm below the STJ minimum (SD 1.03; −0.96 to
/// +3.84). Read on the sectors' middle half ([`PILLAR_CLEAR_DEG`]), they
/// stand 0.31 mm above it (SD 0.43); 0.5 mm keeps the largest misses on
/// either side about even (sample seed 9 1.08 mm low, clinical seed 1
/// tilted 30° 1.06 mm high).
pub const COMMISSURE_ABOVE_KNEE_MM: f64 = 0.5;
/// Where the STJ is a clear waist (the mean radius rises again by
/// [`WAIST_RISE_MM`] within [`WAIST_SPAN_MM`] above it), the commissures
/// stand this far below it, if that is lower than the knee's rule. The
/// real CT's STJ is one (+0.22 mm in 2 mm); its hand-placed commissures lie
/// 17.2–20.5 mm above the annulus, 1.2 mm below its STJ on average, and the
/// knee's rule put them 0.7 mm above their mean. No phantom's STJ is a
/// waist: their ascending aortas widen by under 0.1 mm over 2 mm.
pub const COMMISSURE_BELOW_WAIST_MM: f64 = 1.0;
const WAIST_RISE_MM: f64 = 0.1;
const WAIST_SPAN_MM: f64 = 2.0;
/// The knee: this share of the narrowing from mid-sinus to the STJ is left.
const KNEE_SHARE: f64 = 0.05;
const KNEE_MIN_MM: f64 = 0.03;
/// A pillar's angle is the centre of its trough at this share of its depth
/// (the shallower neighbouring lobe over the pillar's floor); see
/// [`angular::trough_centre`]. On the clinical phantom's truth masks the
/// lowest sample of the 9°-smoothed profile lay up to 11° off the true
/// commissure (a 1.5 mm mask of a pillar whose lobes meet with zero slope);
/// the trough's centre at 40 % of its depth lies within 3.8° on every
/// phantom case measured (mean 1.4°, against 2.5°).
const PILLAR_LEVEL: f64 = 0.4;
/// Rays this close to a commissural pillar (degrees; a quarter of a
/// 120° sector) are left out of the profile the commissures' height is
/// read on: see where it is read. On the phantoms' masks from their CT
/// the cusps' hinge dents lie within 25° of the pillars at the knee's
/// heights. Over 30 cases from their CT (sample seeds 1–20, standard 1–2,
/// clinical 1–3, clinical seed 1 with its annulus tilted 0, 10, 30, 35°,
/// the real CT) the commissures stand 0.31 mm above the knee so read
/// (SD 0.43), against 0.83 (SD 0.63) over every ray; on the eight with
/// closed cusps 0.06 (SD 0.25) against 1.31 (SD 0.67).
const PILLAR_CLEAR_DEG: f64 = 30.0;
/// Heights read along the axis (mm above the annulus centre) and their step.
const H_MIN_MM: f64 = 1.0;
const H_MAX_MM: f64 = 45.0;
const H_STEP_MM: f64 = 0.5;
/// Mid-sinus is sought between these heights (mm): the first local
/// maximum of the mean radius above the lower bound.
const SINUS_SEARCH_MM: (f64, f64) = (3.0, 25.0);
/// The STJ is sought at most this far above mid-sinus (mm).
const STJ_SEARCH_MM: f64 = 20.0;
/// Rays per turn for the axial profile (every 2°).
const AXIAL_RAYS: usize = 180;
/// Longest ray (mm): twice the largest adult sinus radius.
const REACH_MM: f64 = 40.0;
/// Height band about mid-sinus averaged into the angular profile (mm).
const BAND_MM: f64 = 2.0;
/// Smoothing widths of the angular profile (degrees): pillars, sinuses.
const PILLAR_SMOOTH: usize = 9;
const SINUS_SMOOTH: usize = 21;
/// Most the wall's slope between 1 and 2 mm above the annulus plane may
/// move a nadir in or out when carried down to the plane (mm). From the
/// CT alone the plane lies 0.6–1.2 mm above the true nadirs and the sinus
/// wall there already leans out: read 1 mm above, the nadirs of sample
/// seeds 1–20 lay 0.8–1.5 mm too far out (12 of 60 over 1.5 mm; carried
/// down, 5); a full 1 mm carry pushed one truth-mask nadir 1.5 mm inside
/// the wall.
const PLANE_CARRY_MAX_MM: f64 = 0.5;
/// Stop turning the axis below this turn (degrees) or after this many turns.
const AXIS_TOL_DEG: f64 = 0.2;
const AXIS_ITERS: usize = 8;
/// Nadir rays run this far above the annulus plane (mm), and the point is
/// put back into the plane: a mask cut at the plane is ragged within a
/// voxel of it (≤ 1 mm on segment's work grid), and rays 0.5 mm above it
/// left the real CT's mask through that staircase 4–10 mm short of the
/// wall.
const NADIR_LIFT_MM: f64 = 1.0;
/// How far the wall at a nadir's angle widens between [`NADIR_LIFT_MM`]
/// and this height above the annulus plane (mm) says whether the sinus
/// begins there. At a nadir the sinus bulge starts: 1.5–3.5 mm on the
/// sample and standard phantoms from their CT (nadirs within 1.2 mm of
/// the plane). Where the plane lies under the sinus floor the wall there
/// is still the LVOT's and widens 0–0.5 mm: on the clinical phantom from
/// its CT alone, whose VAJ plane is square to the aorta but whose nadirs
/// are tilted 20° to it, the nadirs 2.6–6.1 mm above the plane.
const FLOOR_PROBE_MM: f64 = 4.0;
/// A widening of this much (mm) up to [`FLOOR_PROBE_MM`] is a sure sinus
/// floor; less lowers the nadir's confidence in proportion, unless the
/// floor is found higher up ([`floor_above`]).
const FLOOR_RISE_MM: f64 = 1.5;
/// Highest a sinus floor is sought above the annulus plane (mm): a 35°
/// tilt of the nadirs to a plane square to the root puts them up to 8 mm
/// above its centre.
const FLOOR_SEARCH_MM: f64 = 10.0;
/// A nadir goes up onto a sinus floor higher up only when its wall widens
/// less than this (mm) above the plane, and less than
/// [`TILTED_RISE_SHARE`] of the widest-rising nadir's. The nadirs a tilted
/// plane missed on the clinical phantom from its CT widen −0.03–0.61 mm;
/// nadirs on their plane that merely begin slowly, 1.07–1.37 mm (sample
/// seeds 8, 11, 16, 17 from their CT; seed 8's N2 went up 7.5 mm, 8.4 mm
/// off).
const LIFT_BELOW_RISE_MM: f64 = 1.0;
/// A plane tilted to the nadirs meets some of them on their sinus floor
/// and misses others: on the clinical phantom from its CT the wall widens
/// 1.7–2.1 mm at the nadirs it meets. A nadir goes up only when its wall
/// widens less than this share of the widest-rising nadir's; a root whose
/// three floors all widen slowly is not tilted.
const TILTED_RISE_SHARE: f64 = 0.5;
/// Confidence factor of a nadir lifted onto its sinus floor: found, but off
/// the plane the other points stand on (a finding; see the stage).
const LIFTED_CONFIDENCE: f64 = 0.7;

/// The first level above the annulus plane, every 0.5 mm from
/// [`NADIR_LIFT_MM`] up to [`FLOOR_SEARCH_MM`], where the wall at `dp`
/// widens by [`FLOOR_RISE_MM`] over the next `FLOOR_PROBE_MM −
/// NADIR_LIFT_MM`: the sinus floor; its height and the wall's radius there.
/// On the clinical phantom from its CT alone it lies 0.1–1.2 mm below the
/// true nadirs that the plane had missed by 1.8–6.1 mm. `rise`: the root
/// axis per millimetre above the plane (see [`detect`]).
fn floor_above(probe: &LumenProbe, o: &Point3, rise: &Vector3, dp: &Vector3) -> Option<(f64, f64)> {
    let span = FLOOR_PROBE_MM - NADIR_LIFT_MM;
    let levels = ((FLOOR_SEARCH_MM - NADIR_LIFT_MM) / 0.5).round() as usize;
    (1..=levels).find_map(|i| {
        let h = NADIR_LIFT_MM + 0.5 * i as f64;
        let r = probe.exit(&(o + rise * h), dp, REACH_MM)?;
        let above = probe.exit(&(o + rise * (h + span)), dp, REACH_MM)?;
        (above - r >= FLOOR_RISE_MM).then_some((h, r))
    })
}

/// The direction in the annulus plane (normal `n0`) that keeps the angle
/// `d` (a unit vector ⟂ `axis`) about the root axis: where the half-plane
/// of `axis` and `d` meets the annulus plane. A nadir's angle is read about
/// the root axis (the sector's middle between the commissures), and the
/// nadirs of a tilted annulus lie at their angles about that axis. Dropping
/// `d` straight onto the plane instead turns it about the axis, by up to
/// 3.6° / 8.2° / 11.4° at tilts of 20° / 30° / 35° (clinical seed 1 with
/// its annulus tilted 30°, from its CT: N1 2.00 → 1.62 mm; 35°: N2 3.77 →
/// 3.49 mm). `None` when the axis lies in the plane.
fn in_plane_at_angle(d: &Vector3, axis: &Vector3, n0: &Vector3) -> Option<Vector3> {
    let across = axis.dot(n0);
    if across.abs() < 1e-9 {
        return None;
    }
    (d - axis * (d.dot(n0) / across)).try_normalize(1e-9)
}

/// The annulus centre is the centroid of the lumen between these heights
/// above the annulus plane (mm), put back onto the plane: the first
/// millimetre alone, cut in steps by a tilted plane, put the real CT's
/// centre 5.7 mm off the circle through its nadirs.
const CENTRE_SLAB_MM: (f64, f64) = (1.0, 3.0);
/// Each nadir's angle lies this far from its sinus maximum toward the
/// middle of its sector between the commissures (0: the maximum, 1: the
/// middle). The cusp's hinge line runs down from one commissure and up to
/// the other, so its lowest point lies between them; the lobe's maximum
/// is pulled towards a coronary ostium. From the CT alone (sample seeds
/// 1–20, standard 1–2, clinical 1–3) the sector middle lay within 2.6° of
/// every true nadir's angle, the maximum up to 23° off (sample seed 8's
/// N2, 2.56 mm off when halfway). On the real CT, whose nadirs were placed
/// by hand "at the sinus maxima", the middle lies 1.1°, 0.1° and 14.1°
/// from them, our maxima 2.3°, 5.0° and 11.3°. Moving from halfway to the
/// middle took the sample's nadirs over 1.5 mm from 5 of 60 to 3 (max 2.56
/// → 1.82 mm; those three are 1.2–1.8 mm too high: the VAJ plane's error).
const SECTOR_MIDDLE_WEIGHT: f64 = 1.0;
/// Passes of the annulus centre onto its section's area centroid.
const ANNULUS_CENTRE_ITERS: usize = 3;

/// The annulus (VAJ) plane: a point on it and its unit normal toward the
/// aorta.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct AnnulusPlane {
    pub point_mm: Point3,
    pub normal: Vector3,
}

/// One detected point with how sure the detector is and why.
#[derive(Debug, Clone, Serialize)]
pub struct Found {
    pub label: String,
    pub point_mm: Point3,
    /// 0–1: the product of the evidence factors below.
    pub confidence: f64,
    pub evidence: serde_json::Value,
}

/// What the detector found, for `landmarks.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Detection {
    pub annulus_plane: AnnulusPlane,
    /// Annulus centre and root axis (annulus → STJ).
    pub origin_mm: Point3,
    pub axis: Vector3,
    pub axis_turns_deg: Vec<f64>,
    /// Angle between the root axis and the annulus plane's normal.
    pub annulus_tilt_deg: f64,
    pub sinus_height_mm: f64,
    pub stj_height_mm: f64,
    /// Where the narrowing above the sinuses is all but done (the
    /// commissures' reference; see [`COMMISSURE_ABOVE_KNEE_MM`]), read on
    /// [`Detection::sector_profile_mm`], and that profile's STJ.
    pub knee_height_mm: f64,
    pub commissure_stj_height_mm: f64,
    /// Mean radius at mid-sinus and at the STJ (mm).
    pub sinus_mean_radius_mm: f64,
    pub stj_mean_radius_mm: f64,
    /// Whether the STJ is a local minimum of the mean radius (else the
    /// search ended at its limit or at the mask's end).
    pub stj_is_minimum: bool,
    pub commissure_height_mm: f64,
    /// Mean radius against height along the final axis (mm; heights from
    /// [`H_MIN_MM`] every [`H_STEP_MM`]; null where the rays leave the mask).
    pub axial_profile_mm: Vec<Option<f64>>,
    /// The same over the rays at least [`PILLAR_CLEAR_DEG`] from every
    /// commissural pillar: the profile the commissure height is read on.
    pub sector_profile_mm: Vec<Option<f64>>,
    /// Radius against angle at mid-sinus (mm, one per degree from `e1`).
    pub angular_profile_mm: Vec<f64>,
    /// The profile's zero angle: a unit vector ⟂ the axis.
    pub e1: Vector3,
    pub points: Vec<Found>,
    /// N1, N2, N3's sinuses: their names and the coronary ostia seen.
    pub sinuses: Vec<Sinus>,
    pub sinus_naming: SinusNaming,
}

impl Detection {
    /// A detection about the z axis through the origin holding `points`
    /// and `sinuses`, its other measures plausible: for unit tests of what
    /// is done with a detection.
    #[cfg(test)]
    pub(crate) fn on_z_axis(points: Vec<Found>, sinuses: Vec<Sinus>, stj_is_minimum: bool) -> Self {
        Detection {
            annulus_plane: AnnulusPlane {
                point_mm: Point3::origin(),
                normal: Vector3::z(),
            },
            origin_mm: Point3::origin(),
            axis: Vector3::z(),
            axis_turns_deg: Vec::new(),
            annulus_tilt_deg: 0.0,
            sinus_height_mm: 9.0,
            stj_height_mm: 18.0,
            knee_height_mm: 16.5,
            commissure_stj_height_mm: 18.0,
            sector_profile_mm: Vec::new(),
            sinus_mean_radius_mm: 14.0,
            stj_mean_radius_mm: 13.0,
            stj_is_minimum,
            commissure_height_mm: 17.0,
            axial_profile_mm: Vec::new(),
            angular_profile_mm: Vec::new(),
            e1: Vector3::x(),
            points,
            sinuses,
            sinus_naming: SinusNaming {
                by: super::ostia::NamedBy::Position,
                confidence: 0.5,
                agrees_with_position: true,
                ct_searched: false,
                lumen_hu: None,
                threshold_hu: None,
                other_patches: 0,
            },
        }
    }

    /// Angle of `p` about the detected axis (degrees from `e1`, in [0, 360)).
    pub fn angle_deg(&self, p: &Point3) -> f64 {
        let r = p - self.origin_mm;
        let e2 = self.axis.cross(&self.e1);
        r.dot(&e2)
            .atan2(r.dot(&self.e1))
            .to_degrees()
            .rem_euclid(360.0)
    }
}

/// One sinus: its nadir's label, its name and its coronary ostium if the
/// CT shows one.
#[derive(Debug, Clone, Serialize)]
pub struct Sinus {
    pub nadir: String,
    pub name: &'static str,
    pub ostium: Option<Ostium>,
}

/// How the sinuses were named (see [`ostia`]).
#[derive(Debug, Clone, Serialize)]
pub struct SinusNaming {
    pub by: NamedBy,
    pub confidence: f64,
    pub agrees_with_position: bool,
    /// Whether a CT was searched for ostia; its lumen's median HU and the
    /// brightness threshold; patches that did not count as an ostium.
    pub ct_searched: bool,
    pub lumen_hu: Option<f64>,
    pub threshold_hu: Option<f64>,
    pub other_patches: usize,
}

/// Mean lumen radius against height along (origin, axis), over the rays
/// whose angle (degrees from [`orthonormal_pair`]'s first vector) `keep` admits; NaN
/// where fewer than half of them find the wall.
fn axial_profile(
    probe: &LumenProbe,
    o: &Point3,
    n: &Vector3,
    hs: &[f64],
    keep: &dyn Fn(f64) -> bool,
) -> Vec<f64> {
    let (u, v) = orthonormal_pair(n);
    let rays: Vec<Vector3> = (0..AXIAL_RAYS)
        .filter(|&i| keep(360.0 * i as f64 / AXIAL_RAYS as f64))
        .map(|i| {
            let t = TAU * i as f64 / AXIAL_RAYS as f64;
            u * t.cos() + v * t.sin()
        })
        .collect();
    hs.iter()
        .map(|&h| {
            let c = o + n * h;
            let (mut sum, mut cnt) = (0.0, 0usize);
            for d in &rays {
                if let Some(r) = probe.exit(&c, d, REACH_MM) {
                    sum += r;
                    cnt += 1;
                }
            }
            if cnt > 0 && cnt * 2 >= rays.len() {
                sum / cnt as f64
            } else {
                f64::NAN
            }
        })
        .collect()
}

/// Five-point moving average that keeps NaN where any sample is NaN.
fn smooth5(r: &[f64]) -> Vec<f64> {
    (0..r.len())
        .map(|i| {
            let lo = i.saturating_sub(2);
            let hi = (i + 2).min(r.len() - 1);
            r[lo..=hi].iter().sum::<f64>() / (hi - lo + 1) as f64
        })
        .collect()
}

/// Centroid of the lumen voxels in the slab |height − h| < half, within
/// `radius` of the axis.
fn slab_centroid(
    voxels: &[Point3],
    o: &Point3,
    n: &Vector3,
    h: f64,
    half: f64,
    radius: f64,
) -> Option<Point3> {
    let (mut s, mut k) = (Vector3::zeros(), 0usize);
    for p in voxels {
        let d = p - o;
        let z = d.dot(n);
        if (z - h).abs() < half && (d - n * z).norm() < radius {
            s += p.coords;
            k += 1;
        }
    }
    (k > 0).then(|| Point3::from(s / k as f64))
}

/// Area centroid of the lumen's section through `c` normal to `n`, by
/// [`AXIAL_RAYS`] rays from `c` (a star-shaped polygon about it); `None`
/// when a ray finds no wall.
fn section_centroid(probe: &LumenProbe, c: &Point3, n: &Vector3) -> Option<Point3> {
    let (u, v) = orthonormal_pair(n);
    let pts: Vec<(f64, f64)> = (0..AXIAL_RAYS)
        .map(|i| {
            let t = TAU * i as f64 / AXIAL_RAYS as f64;
            probe
                .exit(c, &(u * t.cos() + v * t.sin()), REACH_MM)
                .map(|r| (r * t.cos(), r * t.sin()))
        })
        .collect::<Option<_>>()?;
    let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for i in 0..pts.len() {
        let (x0, y0) = pts[i];
        let (x1, y1) = pts[(i + 1) % pts.len()];
        let w = x0 * y1 - x1 * y0;
        a += w;
        cx += (x0 + x1) * w;
        cy += (y0 + y1) * w;
    }
    (a > 0.0).then(|| c + u * (cx / (3.0 * a)) + v * (cy / (3.0 * a)))
}

/// Why detection could not proceed (the stage turns it into an error that
/// names the mask).
pub type Failure = String;

struct Levels {
    sinus: usize,
    stj: usize,
    /// The first level from mid-sinus up whose mean radius lies within
    /// [`KNEE_SHARE`] of the narrowing of its value at the STJ.
    knee: usize,
    is_min: bool,
    /// The STJ is a clear waist: see [`COMMISSURE_BELOW_WAIST_MM`].
    waist: bool,
}

fn levels(hs: &[f64], r: &[f64]) -> Option<Levels> {
    // Mid-sinus: walking up from the bottom of the search, the first level
    // past which the mean radius falls (not the widest level of the
    // search: a wide ascending aorta can exceed the sinuses, as on sample
    // seed 5 at 25 mm).
    let start = (0..hs.len()).find(|&i| hs[i] >= SINUS_SEARCH_MM.0 && r[i].is_finite())?;
    Some(levels_from(hs, r, start))
}

/// [`levels`] with the walk up to mid-sinus starting at level `start`.
fn levels_from(hs: &[f64], r: &[f64], start: usize) -> Levels {
    let mut sinus = start;
    while sinus + 1 < hs.len() && hs[sinus + 1] <= SINUS_SEARCH_MM.1 && r[sinus + 1] >= r[sinus] {
        sinus += 1;
    }
    let mut k = sinus;
    let mut is_min = false;
    while k + 1 < hs.len() && hs[k + 1] - hs[sinus] <= STJ_SEARCH_MM {
        if !r[k + 1].is_finite() {
            break;
        }
        if r[k + 1] > r[k] {
            is_min = true;
            break;
        }
        k += 1;
    }
    let left = (KNEE_SHARE * (r[sinus] - r[k])).max(KNEE_MIN_MM);
    let knee = (sinus..=k).find(|&i| r[i] <= r[k] + left).unwrap_or(k);
    let above = k + (WAIST_SPAN_MM / H_STEP_MM).round() as usize;
    let waist = is_min && above < r.len() && r[above] - r[k] >= WAIST_RISE_MM;
    Levels {
        sinus,
        stj: k,
        knee,
        is_min,
        waist,
    }
}

/// The annulus centre: the lumen's centroid in the first millimetre above
/// `plane` (unit normal `n0`), put back on the plane, then moved onto the
/// area centroid of the section just above it.
fn annulus_centre(
    probe: &LumenProbe,
    voxels: &[Point3],
    plane: &AnnulusPlane,
    n0: &Vector3,
) -> Result<Point3, Failure> {
    // Annulus centre: the lumen's centroid in the first millimetre above
    // the plane, put back on the plane.
    let (mut s, mut k) = (Vector3::zeros(), 0usize);
    for p in voxels {
        let z = (p - plane.point_mm).dot(n0);
        if z > CENTRE_SLAB_MM.0 && z < CENTRE_SLAB_MM.1 {
            s += p.coords;
            k += 1;
        }
    }
    if k == 0 {
        return Err("the mask has no lumen in the first millimetre above the annulus plane".into());
    }
    let c = Point3::from(s / k as f64);
    let mut o = c - n0 * (c - plane.point_mm).dot(n0);
    // Then onto the area centroid of the section just above the plane: a
    // slab of voxels under a tilted plane holds more of the sinus on the
    // high side (the clinical phantom's axis was 7.5° off its own).
    for _ in 0..ANNULUS_CENTRE_ITERS {
        match section_centroid(probe, &(o + n0 * NADIR_LIFT_MM), n0) {
            Some(q) => o = q - n0 * NADIR_LIFT_MM,
            None => break,
        }
    }
    Ok(o)
}

/// The root axis from the annulus centre `o`: the lumen's mean radius
/// against height `hs` along the axis gives the STJ, the axis turns to the
/// lumen's centroid there, until it turns less than [`AXIS_TOL_DEG`]. The
/// axis, its turns (degrees), the levels and the radius profile.
fn root_axis(
    probe: &LumenProbe,
    voxels: &[Point3],
    o: &Point3,
    n0: Vector3,
    hs: &[f64],
) -> Result<(Vector3, Vec<f64>, Levels, Vec<f64>), Failure> {
    let mut n = n0;
    let mut turns = Vec::new();
    let mut lv;
    let mut r;
    let mut iter = 0;
    loop {
        r = smooth5(&axial_profile(probe, o, &n, hs, &|_| true));
        lv = levels(hs, &r).ok_or(
            "no lumen section 3–25 mm above the annulus plane: the mask does not hold the sinuses",
        )?;
        let h_stj = hs[lv.stj];
        let cs = slab_centroid(voxels, o, &n, h_stj, 0.75, 1.5 * r[lv.stj])
            .ok_or("no lumen at the STJ level")?;
        let next = (cs - *o)
            .try_normalize(1e-9)
            .ok_or("the STJ centroid lies on the annulus centre")?;
        let turn = next.dot(&n).clamp(-1.0, 1.0).acos().to_degrees();
        iter += 1;
        if turn < AXIS_TOL_DEG || iter > AXIS_ITERS {
            break;
        }
        turns.push(turn);
        n = next;
    }
    Ok((n, turns, lv, r))
}

/// The lumen's radius against angle (one sample a degree) at mid-sinus
/// height `h_sinus` above `o` along `n`, averaged over ±[`BAND_MM`]; `dir`
/// turns an angle into a direction square to `n`.
fn mid_sinus_profile(
    probe: &LumenProbe,
    o: &Point3,
    n: &Vector3,
    h_sinus: f64,
    dir: &dyn Fn(f64) -> Vector3,
) -> Result<Vec<f64>, Failure> {
    let band: Vec<f64> = (0..)
        .map(|i| h_sinus - BAND_MM + i as f64 * H_STEP_MM)
        .take_while(|&h| h <= h_sinus + BAND_MM + 1e-9)
        .collect();
    let mut profile = vec![0.0; SAMPLES];
    for (i, pr) in profile.iter_mut().enumerate() {
        let d = dir(i as f64);
        let hits: Vec<f64> = band
            .iter()
            .filter_map(|&h| probe.exit(&(o + n * h), &d, REACH_MM))
            .collect();
        if hits.is_empty() {
            return Err(format!(
                "at mid-sinus ({h_sinus:.1} mm above the annulus) a ray at {i}° never meets the wall"
            ));
        }
        *pr = hits.iter().sum::<f64>() / hits.len() as f64;
    }
    Ok(profile)
}

/// The mid-sinus radius against angle read into three sinus lobes and the
/// three pillars between them. Sector k runs from pillar k to pillar k+1
/// (increasing angle, i.e. counter-clockwise about the axis).
struct Lobes {
    /// Each pillar's lowest sample of the pillar-smoothed profile `rp`.
    p: [usize; 3],
    rp: Vec<f64>,
    /// Each sector's sinus maximum: its angle, radius, and height over the
    /// higher of its two pillars (mm).
    sinus_deg: [f64; 3],
    sinus_r: [f64; 3],
    lobe_mm: [f64; 3],
    /// Each pillar's angle: the centre of its trough (a flat floor's
    /// lowest sample says little).
    pillar_deg: [f64; 3],
}

impl Lobes {
    fn new(profile: &[f64]) -> Result<Lobes, Failure> {
        let rp = angular::smooth(profile, PILLAR_SMOOTH);
        let rs = angular::smooth(profile, SINUS_SMOOTH);
        let p = angular::pillars(&rp).ok_or(
            "the radius at mid-sinus has no three minima 75° apart: no sinus lobes to find the commissures by",
        )?;
        let mut sinus_deg = [0.0; 3];
        let mut sinus_r = [0.0; 3];
        let mut lobe_mm = [0.0; 3];
        for k in 0..3 {
            let (a, b) = (p[k], p[(k + 1) % 3]);
            let m = angular::sector_max(&rs, a, b, 3).ok_or("a sinus sector is empty")?;
            sinus_deg[k] = angular::refine(&rs, m);
            sinus_r[k] = rs[m];
            lobe_mm[k] = rs[m] - rs[a].max(rs[b]);
        }
        let mut lobes = Lobes {
            p,
            rp,
            sinus_deg,
            sinus_r,
            lobe_mm,
            pillar_deg: [0.0; 3],
        };
        lobes.pillar_deg = std::array::from_fn(|k| {
            let [before, after] = lobes.sectors_beside(k);
            let gap = before.min(after);
            angular::trough_centre(
                &lobes.rp,
                p[k],
                lobes.rp[p[k]] + PILLAR_LEVEL * lobes.pillar_depth(k),
                gap / 2,
            )
        });
        Ok(lobes)
    }

    /// How far pillar k lies below the shallower lobe beside it (mm).
    fn pillar_depth(&self, k: usize) -> f64 {
        let prev = (k + 2) % 3;
        (self.sinus_r[k].min(self.sinus_r[prev]) - self.rp[self.p[k]]).max(0.0)
    }

    /// The sectors on either side of pillar k (degrees).
    fn sectors_beside(&self, k: usize) -> [usize; 2] {
        let p = &self.p;
        [
            angular::forward(p[(k + 2) % 3], p[k], SAMPLES),
            angular::forward(p[k], p[(k + 1) % 3], SAMPLES),
        ]
    }
}

/// Which sector is the right-coronary sinus, and the sinuses named from
/// it. Sector `first` starts at C1 (the phantom's and the hand-placed
/// landmarks' convention: sinus k lies between C_k and C_k+1): the one
/// whose sinus faces anterior (−y in LPS), unless the CT's coronary ostia
/// say otherwise.
#[allow(clippy::too_many_arguments)]
fn name_sinuses(
    ct: Option<&Volume<i16>>,
    mask: &Volume<u8>,
    plane: (&Point3, &Vector3),
    frame: RootFrame,
    h_stj: f64,
    lobes: &Lobes,
    dir: &impl Fn(f64) -> Vector3,
) -> (usize, Vec<Sinus>, SinusNaming) {
    let anterior = (0..3)
        .min_by(|&a, &b| {
            dir(lobes.sinus_deg[a])
                .y
                .partial_cmp(&dir(lobes.sinus_deg[b]).y)
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .unwrap_or(0);
    let found_ostia = ct.map(|ct| {
        let pillars_deg = lobes.p.map(|k| k as f64);
        ostia::search(ct, mask, &frame, plane, h_stj, &pillars_deg)
    });
    let with_ostium = std::array::from_fn(|k| {
        found_ostia
            .as_ref()
            .is_some_and(|f| f.per_sector[k].is_some())
    });
    let naming = ostia::name(with_ostium, anterior);
    let first = naming.right_sector;
    let sinuses = (0..3)
        .map(|j| Sinus {
            nadir: format!("N{}", j + 1),
            name: SINUS_NAMES[j],
            ostium: found_ostia
                .as_ref()
                .and_then(|f| f.per_sector[(first + j) % 3].clone()),
        })
        .collect();
    let sinus_naming = SinusNaming {
        by: naming.by,
        confidence: naming.confidence,
        agrees_with_position: naming.agrees_with_position,
        ct_searched: found_ostia.is_some(),
        lumen_hu: found_ostia.as_ref().map(|f| f.lumen_hu),
        threshold_hu: found_ostia.as_ref().map(|f| f.threshold_hu),
        other_patches: found_ostia.as_ref().map_or(0, |f| f.other_patches),
    };
    (first, sinuses, sinus_naming)
}

/// How the STJ narrowing the commissures hang below was found: how much
/// the mean radius narrows from mid-sinus to it, whether it is a minimum,
/// and the confidence factor those give.
struct Narrowing {
    mm: f64,
    is_min: bool,
    factor: f64,
}

/// C1–C3 on the wall at the pillars' angles, `h_c` above the annulus
/// centre `o` along the root axis `n`, C1 at the start of sector `first`.
fn commissures(
    probe: &LumenProbe,
    (o, n): (&Point3, &Vector3),
    h_c: f64,
    first: usize,
    lobes: &Lobes,
    stj: &Narrowing,
    dir: &impl Fn(f64) -> Vector3,
) -> Result<Vec<Found>, Failure> {
    let mut points = Vec::with_capacity(3);
    for j in 0..3 {
        let k = (first + j) % 3;
        let ang = lobes.pillar_deg[k];
        let d = dir(ang);
        let from = o + n * h_c;
        let rr = probe.exit(&from, &d, REACH_MM).ok_or(format!(
            "no wall at the pillar angle {ang:.1}° at the commissure height"
        ))?;
        // How clearly the pillar stands out: the shallower of its two
        // neighbouring lobes over it (mm); 1.5 mm and more is a clear pillar.
        let depth = lobes.pillar_depth(k);
        let gaps = lobes.sectors_beside(k);
        let gap_factor = if gaps.iter().all(|&g| (80..=160).contains(&g)) {
            1.0
        } else {
            0.6
        };
        let conf = (depth / 1.5).clamp(0.0, 1.0) * stj.factor * gap_factor;
        points.push(Found {
            label: format!("C{}", j + 1),
            point_mm: from + d * rr,
            confidence: conf,
            evidence: serde_json::json!({
                "angle_deg": ang.rem_euclid(360.0),
                "height_mm": h_c,
                "radius_mm": rr,
                "pillar_depth_mm": depth,
                "sectors_deg": gaps,
                "stj_narrowing_mm": stj.mm,
                "stj_is_minimum": stj.is_min,
            }),
        });
    }
    Ok(points)
}

/// N1–N3: in the annulus plane (normal `n0`), at each sector's middle
/// between the commissures as placed, N1 in sector `first`; lifted onto
/// the sinus floor where the plane is tilted to the nadirs.
fn nadirs(
    probe: &LumenProbe,
    (o, n, n0): (&Point3, &Vector3, &Vector3),
    first: usize,
    lobes: &Lobes,
    dir: &impl Fn(f64) -> Vector3,
) -> Result<Vec<Found>, Failure> {
    // First where each one's wall meets the plane and how much it widens
    // above.
    #[derive(Clone, Copy)]
    struct OnPlane {
        k: usize,
        mid: f64,
        dp: Vector3,
        rr: f64,
        r_plane: f64,
        floor_rise: Option<f64>,
    }
    // Rays at a height above the plane start on the root axis, not on the
    // plane's normal through the annulus centre: on a plane tilted 35° to
    // the axis that normal leaves the axis by 0.57 mm per millimetre up,
    // towards one sinus and away from another, and the wall's widening
    // over 3 mm read −0.2 mm at clinical seed 1's lowest nadir (0.79 mm
    // from the truth, confidence 0) and 6.3 mm at its highest.
    let across = n.dot(n0);
    if across < 0.1 {
        return Err("the root axis lies in the annulus plane".into());
    }
    let rise = n / across;
    let sinus_deg = &lobes.sinus_deg;
    let mut on_plane = Vec::with_capacity(3);
    for j in 0..3 {
        let k = (first + j) % 3;
        // The sector between the commissures as placed (the troughs'
        // centres), not between the pillars' lowest samples.
        let (a, b) = (lobes.pillar_deg[k], lobes.pillar_deg[(k + 1) % 3]);
        let mid = a + 0.5 * ((b - a).rem_euclid(360.0));
        let dd = sinus_deg[k]
            + SECTOR_MIDDLE_WEIGHT * ((mid - sinus_deg[k] + 540.0).rem_euclid(360.0) - 180.0);
        let dp =
            in_plane_at_angle(&dir(dd), n, n0).ok_or("the root axis lies in the annulus plane")?;
        let from = o + rise * NADIR_LIFT_MM;
        let rr = probe.exit(&from, &dp, REACH_MM).ok_or(format!(
            "no wall in the annulus plane at the sinus angle {:.1}°",
            sinus_deg[k]
        ))?;
        let floor_rise = probe
            .exit(&(o + rise * FLOOR_PROBE_MM), &dp, REACH_MM)
            .map(|r4| r4 - rr);
        // The wall where it meets the plane: read 1 and 2 mm above it (a
        // mask cut at the plane is ragged) and carried down the line
        // through them.
        let r_plane = probe
            .exit(&(o + rise * (2.0 * NADIR_LIFT_MM)), &dp, REACH_MM)
            .map_or(rr, |r2| {
                rr - (r2 - rr).clamp(-PLANE_CARRY_MAX_MM, PLANE_CARRY_MAX_MM)
            });
        on_plane.push(OnPlane {
            k,
            mid,
            dp,
            rr,
            r_plane,
            floor_rise,
        });
    }
    let widest_rise = on_plane
        .iter()
        .filter_map(|q| q.floor_rise)
        .fold(0.0f64, f64::max);
    let mut points = Vec::with_capacity(3);
    for (j, q) in on_plane.iter().enumerate() {
        let OnPlane {
            k,
            mid,
            dp,
            rr,
            r_plane,
            floor_rise,
        } = *q;
        let off_mid = ((sinus_deg[k] - mid + 540.0).rem_euclid(360.0) - 180.0).abs();
        // Where the wall does not widen above the plane while another
        // nadir's does, the sinus floor lies higher: the plane is tilted to
        // the nadirs. The nadir goes up onto the floor, and says so. A root
        // whose three floors all widen slowly is not tilted.
        let lifted = floor_rise
            .filter(|&w| w < LIFT_BELOW_RISE_MM && w < TILTED_RISE_SHARE * widest_rise)
            .and_then(|_| floor_above(probe, o, &rise, &dp));
        // A clear lobe (≥ 1.5 mm over its pillars) whose maximum lies near
        // the middle of its sector is a sure sinus; a lopsided one less so;
        // a wall that does not widen above the point is no sinus floor, and
        // one found higher up is a point off the plane the rest stand on.
        let floor_factor = match lifted {
            Some(_) => LIFTED_CONFIDENCE,
            None => floor_rise.map_or(0.0, |w| (w / FLOOR_RISE_MM).clamp(0.0, 1.0)),
        };
        let conf = (lobes.lobe_mm[k] / 1.5).clamp(0.0, 1.0)
            * (1.0 - off_mid / 45.0).clamp(0.0, 1.0)
            * floor_factor;
        let point_mm = match lifted {
            Some((h, r)) => o + rise * h + dp * r,
            None => o + dp * r_plane,
        };
        points.push(Found {
            label: format!("N{}", j + 1),
            point_mm,
            confidence: conf,
            evidence: serde_json::json!({
                "sinus_angle_deg": sinus_deg[k].rem_euclid(360.0),
                "sector_middle_deg": mid.rem_euclid(360.0),
                "off_middle_deg": off_mid,
                "lobe_mm": lobes.lobe_mm[k],
                "radius_mm": rr,
                "floor_rise_mm": floor_rise,
                "lifted_mm": lifted.map(|(h, _)| h),
            }),
        });
    }
    Ok(points)
}

/// Detect C1–C3 and N1–N3 in `mask` above `plane`; with the CT, name the
/// sinuses by the coronary ostia it shows.
pub fn detect(
    mask: &Volume<u8>,
    plane: &AnnulusPlane,
    ct: Option<&Volume<i16>>,
) -> Result<Detection, Failure> {
    let probe = LumenProbe::new(mask);
    let n0 = plane
        .normal
        .try_normalize(1e-12)
        .ok_or("annulus plane normal is zero")?;
    let voxels: Vec<Point3> = mask
        .data()
        .indexed_iter()
        .filter(|(_, v)| **v > 0)
        .map(|((i, j, k), _)| mask.index_to_world([i as f64, j as f64, k as f64]))
        .collect();
    let o = annulus_centre(&probe, &voxels, plane, &n0)?;

    let hs: Vec<f64> = (0..)
        .map(|i| H_MIN_MM + i as f64 * H_STEP_MM)
        .take_while(|&h| h <= H_MAX_MM + 1e-9)
        .collect();
    let (n, turns, lv, r) = root_axis(&probe, &voxels, &o, n0, &hs)?;
    let h_sinus = hs[lv.sinus];
    let h_stj = hs[lv.stj];
    if h_stj - h_sinus < 2.0 {
        return Err(format!(
            "no narrowing above the sinuses: the mean radius falls no further than {:.1} mm above its widest level",
            h_stj - h_sinus
        ));
    }

    // Radius against angle at mid-sinus.
    let (u, v) = orthonormal_pair(&n);
    let dir = |deg: f64| {
        let t = deg.to_radians();
        u * t.cos() + v * t.sin()
    };
    let profile = mid_sinus_profile(&probe, &o, &n, h_sinus, &dir)?;
    let lobes = Lobes::new(&profile)?;
    let frame = RootFrame {
        origin: o,
        axis: n,
        e1: u,
    };
    let (first, sinuses, sinus_naming) =
        name_sinuses(ct, mask, (&plane.point_mm, &n0), frame, h_stj, &lobes, &dir);
    // The commissures' height, read on the sinus sectors' middle half: a
    // closed native valve hangs from the wall along its hinge lines,
    // which rise from the nadirs to the commissures, and the mask leaves
    // out a dent 0.4–1.3 mm deep and 6–30° wide along them (the cusp's
    // partial volume at the wall). At the heights of the STJ narrowing the
    // hinges lie within 25° of the pillars and stop at the commissures, so
    // the mean over every ray is lowered below them and not above: the
    // narrowing seemed to end 1–2 mm low (sample seed 1 drawn with its
    // cusps: knee 15.0 mm, without 16.0; the clinical phantoms' commissures
    // 0.7–1.6 mm low).
    let clear = |deg: f64| {
        lobes
            .pillar_deg
            .iter()
            .all(|&p| angular::apart_deg(deg, p) >= PILLAR_CLEAR_DEG)
    };
    let rc = smooth5(&axial_profile(&probe, &o, &n, &hs, &clear));
    let lc = levels_from(&hs, &rc, lv.sinus);
    let h_c = (hs[lc.knee] + COMMISSURE_ABOVE_KNEE_MM).min(if lc.waist {
        hs[lc.stj] - COMMISSURE_BELOW_WAIST_MM
    } else {
        hs[lc.stj]
    });
    let stj_narrowing = r[lv.sinus] - r[lv.stj];
    let stj = Narrowing {
        mm: stj_narrowing,
        is_min: lv.is_min,
        factor: if lv.is_min {
            (stj_narrowing / 0.5).clamp(0.0, 1.0)
        } else {
            0.5 * (stj_narrowing / 0.5).clamp(0.0, 1.0)
        },
    };
    let mut points = commissures(&probe, (&o, &n), h_c, first, &lobes, &stj, &dir)?;
    points.extend(nadirs(&probe, (&o, &n, &n0), first, &lobes, &dir)?);
    Ok(Detection {
        annulus_plane: AnnulusPlane {
            point_mm: plane.point_mm,
            normal: n0,
        },
        origin_mm: o,
        axis: n,
        axis_turns_deg: turns,
        annulus_tilt_deg: n.dot(&n0).clamp(-1.0, 1.0).acos().to_degrees(),
        sinus_height_mm: h_sinus,
        stj_height_mm: h_stj,
        knee_height_mm: hs[lc.knee],
        commissure_stj_height_mm: hs[lc.stj],
        sector_profile_mm: rc.iter().map(|x| x.is_finite().then_some(*x)).collect(),
        sinus_mean_radius_mm: r[lv.sinus],
        stj_mean_radius_mm: r[lv.stj],
        stj_is_minimum: lv.is_min,
        commissure_height_mm: h_c,
        axial_profile_mm: r.iter().map(|x| x.is_finite().then_some(*x)).collect(),
        angular_profile_mm: profile,
        e1: u,
        points,
        sinuses,
        sinus_naming,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The report reads landmarks.json's sinuses and their naming into its
    /// own types (`io::report_json`); what this stage writes reads back to
    /// the same JSON, so the report's copy is the file's.
    #[test]
    fn the_sinuses_as_written_read_into_the_report_unchanged() {
        use coapt_io::report_json;
        let sinuses = vec![
            Sinus {
                nadir: "N1".into(),
                name: SINUS_NAMES[0],
                ostium: Some(Ostium {
                    point_mm: Point3::new(10.25, -201.5, 678.75),
                    height_mm: 20.5,
                    angle_deg: 201.125,
                    area_mm2: 8.5,
                }),
            },
            Sinus {
                nadir: "N3".into(),
                name: SINUS_NAMES[2],
                ostium: None,
            },
        ];
        let naming = SinusNaming {
            by: NamedBy::CoronaryOstia,
            confidence: 1.0,
            agrees_with_position: true,
            ct_searched: true,
            lumen_hu: Some(469.0),
            threshold_hu: None,
            other_patches: 6,
        };
        let written = (
            serde_json::to_value(&sinuses).unwrap(),
            serde_json::to_value(&naming).unwrap(),
        );
        let read: (Vec<report_json::Sinus>, report_json::SinusNaming) = (
            serde_json::from_value(written.0.clone()).unwrap(),
            serde_json::from_value(written.1.clone()).unwrap(),
        );
        assert_eq!(read.0[0].ostium.as_ref().unwrap().height_mm, 20.5);
        assert_eq!(read.1.by, "coronary_ostia");
        assert_eq!(
            (
                serde_json::to_string(&read.0).unwrap(),
                serde_json::to_string(&read.1).unwrap()
            ),
            (
                serde_json::to_string(&written.0).unwrap(),
                serde_json::to_string(&written.1).unwrap()
            )
        );
    }

    /// On an annulus plane tilted 35° to the root axis, every angle keeps
    /// its direction about the axis and lies in the plane; square to the
    /// axis the direction is the angle itself. Dropped straight onto the
    /// plane, an angle 45° from the fall line turned by 11.1°.
    #[test]
    fn a_nadir_direction_keeps_its_angle_about_the_axis() {
        let axis = Vector3::z();
        let tilt = 35f64.to_radians();
        let n0 = Vector3::new(tilt.sin(), 0.0, tilt.cos());
        for deg in (0..360).step_by(15) {
            let t = (deg as f64).to_radians();
            let d = Vector3::new(t.cos(), t.sin(), 0.0);
            let dp = in_plane_at_angle(&d, &axis, &n0).unwrap();
            assert!(dp.dot(&n0).abs() < 1e-12, "{deg}°: off the plane");
            let across = (dp - axis * dp.dot(&axis)).normalize();
            assert!((across - d).norm() < 1e-12, "{deg}°: turned to {across:?}");
            let flat = in_plane_at_angle(&d, &axis, &axis).unwrap();
            assert!((flat - d).norm() < 1e-12);
        }
        let d = Vector3::new(1.0, 1.0, 0.0).normalize();
        let dropped = (d - n0 * d.dot(&n0)).normalize();
        let turned = (dropped.y.atan2(dropped.x) - d.y.atan2(d.x)).to_degrees();
        assert!((turned.abs() - 11.1).abs() < 0.1, "{turned}");
        assert!(in_plane_at_angle(&d, &axis, &Vector3::x()).is_none());
    }

    /// Sample seed 13's shape: the sinus narrows onto a flat as wide as the
    /// STJ, whose lowest sample (a 0.01 mm ripple) lies 6 mm up the flat.
    /// The STJ is that minimum; the knee is where the narrowing ends.
    #[test]
    fn the_knee_is_where_the_narrowing_ends_not_the_flat_minimum() {
        let hs: Vec<f64> = (0..60).map(|i| H_MIN_MM + i as f64 * H_STEP_MM).collect();
        let r: Vec<f64> = hs
            .iter()
            .map(|&h| {
                // Widest at 9 mm, narrowing by 0.8 mm until 16 mm, then flat.
                let fall = ((h - 9.0) / 7.0).clamp(0.0, 1.0);
                let sinus = if h < 9.0 {
                    15.1 - 0.02 * (9.0 - h).powi(2)
                } else {
                    15.1
                };
                let ripple = if (h - 22.0).abs() < 0.1 { -0.01 } else { 0.0 };
                sinus - 0.8 * (1.0 - (1.0 - fall).powi(3)) + ripple
            })
            .collect();
        let lv = levels(&hs, &r).expect("levels");
        assert_eq!(hs[lv.sinus], 9.0);
        assert_eq!(hs[lv.stj], 22.0, "the STJ is the flat's lowest sample");
        assert!(lv.is_min);
        // Within 5 % of the 0.81 mm narrowing (0.04 mm) of the STJ's 14.29:
        // 0.8 (1 − fall)³ ≤ 0.03, fall ≥ 0.664, 13.65 mm; the first level
        // of the half-millimetre grid past it.
        assert_eq!(hs[lv.knee], 14.0);
        assert!(!lv.waist, "a flat is no waist");
        // The same root with an ascending aorta that widens again above
        // 17 mm: the STJ is a clear waist there.
        let widening: Vec<f64> = hs
            .iter()
            .zip(&r)
            .map(|(&h, &x)| x + 0.1 * (h - 17.0).max(0.0))
            .collect();
        let lv = levels(&hs, &widening).expect("levels");
        assert_eq!(hs[lv.stj], 17.0);
        assert!(lv.waist);
    }
}
