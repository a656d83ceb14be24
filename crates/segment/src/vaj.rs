//! Separating the left ventricle at the ventriculo-aortic junction (VAJ).
//!
//! With nadir landmarks the VAJ is their plane (the annulus, where the truth
//! and the valve stage put it). Without them it is measured on the region:
//! a centreline is marched from the tracked ascending aorta toward the root,
//! each station re-centred on the centroid of its cross-section
//! *perpendicular to the local axis* (the centroid of any planar cut of a
//! straight tube lies on its axis, so the march corrects its own direction),
//! and the area of those sections is read: the sinuses are the widest
//! sections, and below them the lumen narrows into the LVOT, whose area is
//! about constant. The VAJ is where that descent flattens (see [`judge`]),
//! and the plane is the section there, settled onto the sinus floor by
//! [`super::vaj_floor`] where the root leans away from the march.
//!
//! An earlier version cut sections along geodesic shells from the top
//! slice. Past the bend of a tilted root those shells are slanted (the
//! shortest paths hug the inner side of the bend: at 60° tilt one shell
//! spanned 15 mm of valve-axis height), so their centroids gave an axis
//! 60° off and the cut missed (full preset, tilt 60°, noise 50: Dice 0.959).

use super::track::TrackPoint;
use coapt_geom::{Point3, Vector3, Volume};

/// A plane with its normal pointing into the aorta.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Plane {
    pub point_mm: [f64; 3],
    pub normal: [f64; 3],
}

impl Plane {
    pub fn new(p: Point3, n: Vector3) -> Self {
        Plane {
            point_mm: [p.x, p.y, p.z],
            normal: [n.x, n.y, n.z],
        }
    }
    pub fn height(&self, q: &Point3) -> f64 {
        let p = Point3::from(self.point_mm);
        (q - p).dot(&Vector3::from(self.normal))
    }
}

/// Plane through the nadirs, normal toward the centroid of `above` (the
/// commissures, or a point in the ascending aorta); by the nadirs' order
/// when `above` is empty.
pub fn plane_from_landmarks(nadirs: &[Point3; 3], above: &[Point3]) -> Option<Plane> {
    let c = Point3::from((nadirs[0].coords + nadirs[1].coords + nadirs[2].coords) / 3.0);
    let mut n = (nadirs[1] - nadirs[0]).cross(&(nadirs[2] - nadirs[0]));
    if n.norm() < 1e-9 {
        return None;
    }
    n.normalize_mut();
    if !above.is_empty() {
        let cc = above.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / above.len() as f64;
        if (cc - c.coords).dot(&n) < 0.0 {
            n = -n;
        }
    }
    Some(Plane::new(c, n))
}

/// Where the march starts: the tracked centre about [`START_ABOVE_MM`]
/// above the end of the track (or the seed), heading along the track's
/// chord over the next 10 mm (or straight down to the feet when the track
/// is shorter); the radius there.
pub fn march_start(ct: &Volume<i16>, track: &[TrackPoint]) -> (Point3, Vector3, f64) {
    let w: Vec<Point3> = track.iter().map(|t| super::track::world(ct, t)).collect();
    let Some(last) = w.last() else {
        return (Point3::origin(), -Vector3::z(), 0.0);
    };
    let i = (0..w.len())
        .rev()
        .find(|&i| w[i].z - last.z >= START_ABOVE_MM)
        .unwrap_or(0);
    let dir = (i + 1..w.len())
        .find(|&j| (w[j] - w[i]).norm() >= 10.0)
        .and_then(|j| (w[j] - w[i]).try_normalize(1e-9))
        .unwrap_or(-Vector3::z());
    (w[i], dir, track[i].r_mm)
}

/// Where a march from the commissures starts (given them but not the
/// nadirs): [`ABOVE_COMMISSURES_MM`] above their circle's centre, heading
/// down its axis (to the feet), at its radius; `None` when they are
/// collinear. It is the fallback for a march along the track that left the
/// root ([`off_the_root`]).
pub fn march_start_at_commissures(c: &[Point3; 3]) -> Option<(Point3, Vector3, f64)> {
    let (centre, axis, r) = super::anchor::circumcircle(c)?;
    let up = if axis.z < 0.0 { -axis } else { axis };
    Some((centre + up * ABOVE_COMMISSURES_MM, -up, r))
}

/// Whether a VAJ plane found along the track lies off the root of the
/// commissures `c`: its centre farther from their circle's axis than the
/// circle's radius, or less than half that radius below their centre (the
/// annulus lies 15–20 mm below the commissures). The track's chord is the
/// ascending aorta's course, not the root's. On the real CT with only C1–C3
/// given the two lie 40° apart, and the march along the chord left the
/// root at the commissures for the ventricle the region had reached
/// through the annulus (sections of 2000–2700 mm² for 400 mm): its plane's
/// centre lay 38 mm off the axis and the mask was refused as a leak. On
/// the clinical phantom (seeds 2 and 3) the march began in the arch and
/// put the plane 48 mm above the commissures, which it then cut away.
pub fn off_the_root(plane: &Plane, c: &[Point3; 3]) -> bool {
    let Some((centre, axis, r)) = super::anchor::circumcircle(c) else {
        return false;
    };
    let up = if axis.z < 0.0 { -axis } else { axis };
    let d = Point3::from(plane.point_mm) - centre;
    let height = d.dot(&up);
    (d - up * height).norm() > r || height > -0.5 * r
}

/// A march from the commissures sees the region within this many
/// commissure radii of their axis: past the sinuses (about 1.3), short of
/// a chamber beside the root. It keeps to that axis, the root's, rather
/// than following its sections' centres into a chamber the region reached
/// through the annulus.
const ANCHORED_REACH_RADII: f64 = 1.6;

/// How far above the commissures' centre a march from them starts (mm):
/// in the ascending aorta above the STJ (the commissures lie 0–3 mm below
/// it), so that the profile holds the STJ, the sinus bulge and the LVOT
/// below, as a march from the track does.
const ABOVE_COMMISSURES_MM: f64 = 10.0;

/// How far above the end of the axial track the march starts (mm): the
/// track may run through the whole root into the LVOT (an untilted valve),
/// so this reaches back above the sinuses (LVOT ≤ 20 mm + root ≤ 21 mm in
/// an adult).
const START_ABOVE_MM: f64 = 60.0;

/// Result of the measured VAJ.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Profile {
    /// Arc length (mm) of each station along the marched centreline, from
    /// its start in the ascending aorta.
    pub station_mm: Vec<f64>,
    /// Cross-section area (mm²) perpendicular to the centreline there.
    pub area_mm2: Vec<f64>,
    /// Centre of each section (LPS mm).
    pub centre_mm: Vec<[f64; 3]>,
    /// Area (3-station mean) at the VAJ, the top of the LVOT (mm²); at the
    /// last station when no VAJ was found.
    pub plateau_mm2: f64,
    /// Station of the VAJ; None when no sinus rise above the LVOT was seen.
    pub vaj_mm: Option<f64>,
    /// The least-section march from the knee down to the sinus floor.
    pub floor: Option<super::vaj_floor::Floor>,
}

/// Step between stations (mm).
const STEP_MM: f64 = 1.0;
/// Least half-width of a section's tent-weighted slab (mm); it is at least
/// two voxels wide along the grid's coarsest axis, so that the weights of a
/// lattice of voxels sum to the same area whatever the plane's offset (a
/// sharp slab counted 3 or 4 slices of 0.6 mm: ±15 %).
const SLAB_MM: f64 = 1.0;
/// Reach of a section: never beyond this (mm), nor beyond 1.8 radii of
/// the previous section + 3 mm (so a plane through a bend does not pick up
/// a far part of the tube).
const REACH_MM: f64 = 30.0;
/// Chord over which the axis direction is measured (stations).
const TANGENT_CHORD: usize = 8;
/// Stations this close to the far end of the march are not searched for
/// the LVOT: their slab leaves the region where the IDT cut it.
const END_MARGIN_MM: f64 = 6.0;
/// Relative rise above the LVOT that marks the start of the sinuses.
pub const PLATEAU_RISE: f64 = 0.05;
/// The sinus' descent has flattened into the LVOT where it narrows over
/// [`KNEE_SPAN`] stations by less than this share of its steepest
/// narrowing. Chosen on the area profiles of 18 sample phantoms (tilt
/// 0–60°, noise 10–80 HU, the three spacings, seeds 1–3) against the truth
/// nadir plane: 0.3 over 2 stations put every plane 0.0–1.1 mm above it;
/// 0.35–0.4 up to 2.1 mm, 0.25 one 4.9 mm below, 3 stations up to 1.4 mm.
/// Known miss: where the region ends within ~4 mm below the annulus
/// (tilt 0°, 0.4/1 mm, calcium) the look-ahead reaches the end taper, no
/// knee is seen and the plane falls to the region's end, 3.8 mm below
/// (no leak; Dice 0.973–0.976 in the factorial).
pub(super) const KNEE_FLAT: f64 = 0.3;
pub(super) const KNEE_SPAN: usize = 2;
/// Fewest stations judged.
const MIN_STATIONS: usize = 15;
/// A sinus must rise at least this much above the plateau to be believed.
pub(super) const SINUS_RISE: f64 = 0.15;
/// Relative dip the walk up to the sinus' top crosses (see [`judge`]).
const SHELF: f64 = 0.01;
/// The march stops where a section falls below this share of the median so
/// far (the end of the region) or after this length.
const END_FRACTION: f64 = 0.5;
const MAX_LENGTH_MM: f64 = 400.0;
/// Coarse cells holding the region's points (mm).
const CELL_MM: f64 = 8.0;

/// Region voxel centres (world mm) sorted into coarse cells.
pub(super) struct Cells {
    lo: Point3,
    dims: [usize; 3],
    start: Vec<usize>,
    points: Vec<Point3>,
}

impl Cells {
    pub(super) fn new(points: Vec<Point3>) -> Option<Self> {
        let first = *points.first()?;
        let (mut lo, mut hi) = (first, first);
        for p in &points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let dims = [0, 1, 2].map(|a| ((hi[a] - lo[a]) / CELL_MM).floor() as usize + 1);
        let cell = |p: &Point3| -> usize {
            let c = [0, 1, 2].map(|a| (((p[a] - lo[a]) / CELL_MM) as usize).min(dims[a] - 1));
            c[0] + dims[0] * (c[1] + dims[1] * c[2])
        };
        // Counting sort: keeps the voxel order inside a cell (deterministic).
        let n_cells = dims[0] * dims[1] * dims[2];
        let mut start = vec![0usize; n_cells + 1];
        for p in &points {
            start[cell(p) + 1] += 1;
        }
        for c in 0..n_cells {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut sorted = vec![first; points.len()];
        for p in &points {
            let c = cell(p);
            sorted[fill[c]] = *p;
            fill[c] += 1;
        }
        Some(Cells {
            lo,
            dims,
            start,
            points: sorted,
        })
    }

    /// Tent-weighted count (weight 1 − |x|/w at distance x < w from the
    /// plane through `p` normal to `t`, within `reach` of `p`) and the
    /// weighted in-plane mean offset. The count divided by w is the section's
    /// voxel count per unit thickness.
    pub(super) fn section(&self, p: &Point3, t: &Vector3, w: f64, reach: f64) -> (f64, Vector3) {
        let half_diag = 0.5 * CELL_MM * 3f64.sqrt();
        let lo =
            [0, 1, 2].map(|a| ((p[a] - reach - self.lo[a]) / CELL_MM).floor().max(0.0) as usize);
        let hi = [0, 1, 2].map(|a| {
            (((p[a] + reach - self.lo[a]) / CELL_MM).floor().max(0.0) as usize)
                .min(self.dims[a] - 1)
        });
        let (mut n, mut sum) = (0.0, Vector3::zeros());
        for k in lo[2]..=hi[2] {
            for j in lo[1]..=hi[1] {
                for i in lo[0]..=hi[0] {
                    let centre = self.lo
                        + Vector3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * CELL_MM;
                    if (centre - p).dot(t).abs() > w + half_diag {
                        continue;
                    }
                    let c = i + self.dims[0] * (j + self.dims[1] * k);
                    for q in &self.points[self.start[c]..self.start[c + 1]] {
                        let d = q - p;
                        let along = d.dot(t);
                        if along.abs() < w && d.norm_squared() < reach * reach {
                            let wt = 1.0 - along.abs() / w;
                            n += wt;
                            sum += (d - t * along) * wt;
                        }
                    }
                }
            }
        }
        (n, if n > 0.0 { sum / n } else { sum })
    }
}

/// VAJ of `region` (its voxel centres in world mm, `voxel_mm3` each) by the
/// march from `start` along `dir` (toward the root; `r0_mm` the radius
/// there). The plane is None when no sinus descent is seen; the profile is None when the march is too short to have one.
pub fn measure(
    points: Vec<Point3>,
    voxel_mm3: f64,
    start: Point3,
    dir: Vector3,
    r0_mm: f64,
    spacing: [f64; 3],
    anchored: bool,
) -> (Option<Plane>, Option<Profile>) {
    let w = spacing.iter().fold(SLAB_MM, |a, &s| a.max(2.0 * s));
    // A march from the commissures sees only the cylinder about their axis
    // that holds the root: not a chamber beside it, in its sections nor in
    // the floor's least sections (`vaj_floor::settle`).
    let points = if anchored {
        let axis = dir.try_normalize(1e-9).unwrap_or_else(Vector3::z);
        let r_max = ANCHORED_REACH_RADII * r0_mm;
        points
            .into_iter()
            .filter(|q| {
                let d = q - start;
                (d - axis * d.dot(&axis)).norm() <= r_max
            })
            .collect()
    } else {
        points
    };
    let Some(cells) = Cells::new(points) else {
        return (None, None);
    };
    let Some(mut t) = dir.try_normalize(1e-9) else {
        return (None, None);
    };
    let mut c = start;
    let mut r = r0_mm;
    let (mut centres, mut tangents, mut area) = (Vec::new(), Vec::new(), Vec::<f64>::new());
    let mut sorted: Vec<f64> = Vec::new();
    while (centres.len() as f64) * STEP_MM < MAX_LENGTH_MM {
        let p = if centres.is_empty() {
            c
        } else {
            c + t * STEP_MM
        };
        let (n, off) = cells.section(&p, &t, w, REACH_MM.min(1.8 * r + 3.0));
        let a = n * voxel_mm3 / w;
        if n == 0.0 || (area.len() >= 5 && a < END_FRACTION * sorted[sorted.len() / 2]) {
            break;
        }
        c = if anchored { p } else { p + off };
        r = (a / std::f64::consts::PI).sqrt();
        centres.push(c);
        tangents.push(t);
        area.push(a);
        let at = sorted.partition_point(|&x| x < a);
        sorted.insert(at, a);
        let m = centres.len();
        if m > TANGENT_CHORD && !anchored {
            if let Some(u) = (centres[m - 1] - centres[m - 1 - TANGENT_CHORD]).try_normalize(1e-9) {
                t = u;
            }
        }
    }
    let stations: Vec<f64> = (0..area.len()).map(|x| x as f64 * STEP_MM).collect();
    let vaj = judge(&area, w);
    let Some((vaj, plateau)) = vaj else {
        return (None, None);
    };
    // Normal toward the aorta: against the march; settled onto the sinus
    // floor when the least sections below the knee still narrow.
    let mut floor = None;
    let plane = vaj.map(|b| {
        let (settled, f) = super::vaj_floor::settle(
            &cells,
            voxel_mm3,
            w,
            centres[b],
            tangents[b],
            area[b],
            REACH_MM,
        );
        floor = Some(f);
        settled.unwrap_or_else(|| Plane::new(centres[b], -tangents[b]))
    });
    let profile = Profile {
        vaj_mm: vaj.map(|b| stations[b]),
        station_mm: stations,
        area_mm2: area,
        centre_mm: centres.iter().map(|c| [c.x, c.y, c.z]).collect(),
        plateau_mm2: plateau,
        floor,
    };
    (plane, Some(profile))
}

/// The VAJ station of an area profile (one section per [`STEP_MM`], `w` the
/// slab half-width) and the area there (mm²), or None (no judgement) when
/// the march is too short; the station is None when no sinus is seen.
///
/// The LVOT is first found as before, the least section (3-station mean)
/// of the march short of its last [`END_MARGIN_MM`], and the sinus as the
/// bulge above it (a rise of [`SINUS_RISE`] beyond the band of
/// [`PLATEAU_RISE`]). The VAJ is then read going down from the sinus' top:
/// the first station, [`SINUS_RISE`] narrower than that top, where the
/// lumen narrows over the next [`KNEE_SPAN`] stations by less than
/// [`KNEE_FLAT`] of the steepest such narrowing of the descent so far:
/// where the descent flattens into the LVOT. The last station always has
/// a flat span ahead, so a descent that runs into the region's end is cut
/// there. Without an LVOT short of the end (the region stopped at the
/// annulus) the sinus is the widest section below the least judged one.
///
/// The least section alone put the plane in the region's end taper when
/// the IDT cut the LVOT slanted (tilt 35°, 0.44/0.6 mm: 6.7 mm below the
/// annulus, Dice 0.969) or the LVOT narrowed below the annulus (0.4/1 mm:
/// 5.9 mm below); the knee is read from the sinus side, which the cut never
/// reaches. The first stations are not judged: their slab may leave the
/// region's top, and where the region stopped at the annulus that
/// truncated first section was the least one, so no plane was found and
/// 28 voxels stayed in the LV (tilt 0°, noise 80).
pub fn judge(area: &[f64], w: f64) -> Option<(Option<usize>, f64)> {
    let s0 = (w / STEP_MM).ceil() as usize;
    let n = area.len();
    let m = n.saturating_sub((END_MARGIN_MM / STEP_MM).round() as usize);
    if m < s0 + MIN_STATIONS {
        return None;
    }
    // Mean over the stations within `k` of `x`, none before `s0` nor at or
    // past `end`.
    let mean = |x: usize, k: usize, end: usize| {
        // Stations before `s0` read the first judged ones (a slab wider
        // than two stations, voxels over 1 mm, put s0 past x + k).
        let lo = x.saturating_sub(k).max(s0);
        let hi = (x + k).min(end - 1).max(lo);
        area[lo..=hi].iter().sum::<f64>() / (hi - lo + 1) as f64
    };
    let judged: Vec<f64> = (0..m).map(|x| mean(x, 1, m)).collect();
    let sm: Vec<f64> = (0..n).map(|x| mean(x, 1, n)).collect();
    let wide: Vec<f64> = (0..n).map(|x| mean(x, 2, n)).collect();
    // The LVOT is the narrowest lumen short of the end (the STJ is 5–20 %
    // wider, the LV entrance wider still).
    let k_min = (s0..m)
        .min_by(|&a, &b| judged[a].total_cmp(&judged[b]).then(a.cmp(&b)))
        .unwrap_or(s0);
    let plateau = judged[k_min];
    let rise = (s0..k_min)
        .rev()
        .find(|&x| judged[x] > (1.0 + PLATEAU_RISE) * plateau)
        .filter(|&rise| {
            let peak = judged[s0..=rise].iter().copied().fold(0.0, f64::max);
            peak >= (1.0 + SINUS_RISE) * plateau
        });
    let top = match rise {
        // The sinus' top: up from the rise while the lumen widens (5-station
        // mean, so section noise does not stop the walk on the flank), over
        // shelves flat to within [`SHELF`]: the clinical phantom's LVOT
        // narrows again 2–7 mm below the annulus, and the walk stopped on
        // the flat top of that step (402.6 against 402.8 mm²), so the knee
        // was read below it, 11 mm under the annulus.
        Some(rise) => {
            let mut top = rise;
            while top > s0 && wide[top - 1] >= wide[top] * (1.0 - SHELF) {
                top -= 1;
            }
            top
        }
        // No LVOT short of the end: the region stops at the annulus (tilt
        // 0°, noise 80: its last section lay 0.4 mm above it) and the least
        // judged section is the STJ; the sinus is the widest section below.
        None => (k_min..n)
            .max_by(|&a, &b| sm[a].total_cmp(&sm[b]).then(b.cmp(&a)))
            .unwrap_or(k_min),
    };
    let mut steepest = 0.0f64;
    let knee = (top + 1..n).find(|&y| {
        let drop = sm[y] - sm[(y + KNEE_SPAN).min(n - 1)];
        let found = sm[y] * (1.0 + SINUS_RISE) <= sm[top] && drop < KNEE_FLAT * steepest;
        steepest = steepest.max(drop);
        found
    });
    // The last station always has a flat span ahead, so a descent that
    // runs into the region's end is cut there. No knee at all (no descent
    // of SINUS_RISE below the top): the station just below the band.
    match knee.or(rise.map(|r| r + 1)) {
        Some(vaj) => Some((Some(vaj), sm[vaj])),
        None => Some((None, plateau)),
    }
}
