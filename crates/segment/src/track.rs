//! Finding the ascending aorta without help: circles on the top slice, the
//! anterior lumen-like one chosen, then tracked slice by slice toward the root.

use super::hough::{Circle, CircleMap, HoughParams, circleness};
use coapt_base::{Error, Result};
use coapt_geom::{Point3, Volume};

/// Least circleness of a seed circle and of a tracked slice.
pub const C_SEED: f64 = 0.5;
pub const C_TRACK: f64 = 0.5;
/// A lumen is bright inside (contrast); a vertebral body has a brighter rim
/// (cortical bone) than its inside: ring − inside above this means bone.
const BONE_RIM_HU: f64 = 150.0;
/// Tracking window: a new centre within this fraction of r of the last,
/// and a radius change below this fraction.
const TRACK_SHIFT: f64 = 0.5;
const TRACK_DR: f64 = 0.2;

/// A circle on the top slice and what was judged of it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Candidate {
    pub centre_mm: [f64; 3],
    pub r_mm: f64,
    pub circleness: f64,
    pub inside_hu: f64,
    pub ring_hu: f64,
    pub verdict: String,
}

#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct TrackPoint {
    pub k: usize,
    pub i: f64,
    pub j: f64,
    pub r_mm: f64,
    pub c: f64,
}

pub struct Found {
    /// Slice index of the top (largest world z) unpadded slice and the step toward the feet.
    pub top_k: usize,
    pub dk: isize,
    pub candidates: Vec<Candidate>,
    pub track: Vec<TrackPoint>,
    /// Circleness of the top slice (for the debug output).
    pub top_map: CircleMap,
    /// The aorta's direction where it is known (from the commissures): its
    /// axial cuts are ellipses stretched along its horizontal part.
    pub direction: Option<coapt_geom::Vector3>,
    /// Radii (mm) of the seed vessel's lumen circles on the other searched
    /// levels (within [`SAME_VESSEL_MM`] of the seed in the axial plane):
    /// the vessel's calibre where the track is short.
    pub level_radii: Vec<f64>,
}

pub fn slice_f32(ct: &Volume<i16>, k: usize) -> Vec<f32> {
    let [ni, nj, _] = ct.dims();
    ct.as_slice()[k * ni * nj..(k + 1) * ni * nj]
        .iter()
        .map(|&v| v as f32)
        .collect()
}

/// Median of a non-empty list (sorted in place).
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_unstable_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// Pixels of `img` within radii [r0, r1) mm of (ci, cj).
pub fn annulus_values(
    img: &[f32],
    ni: usize,
    nj: usize,
    s: [f64; 2],
    c: (f64, f64),
    r0: f64,
    r1: f64,
) -> Vec<f64> {
    let (ri, rj) = ((r1 / s[0]).ceil() as i64, (r1 / s[1]).ceil() as i64);
    let mut out = Vec::new();
    for j in (c.1 as i64 - rj).max(0)..=(c.1 as i64 + rj).min(nj as i64 - 1) {
        for i in (c.0 as i64 - ri).max(0)..=(c.0 as i64 + ri).min(ni as i64 - 1) {
            if in_ring((i as f64 - c.0) * s[0], (j as f64 - c.1) * s[1], r0, r1) {
                out.push(img[i as usize + j as usize * ni] as f64);
            }
        }
    }
    out
}

/// Relative band around a radius where a² + b² cannot tell the side of
/// `a.hypot(b)` (both are within ~1e-16 of the true length): outside it
/// the squared length decides, inside it hypot itself, so these tests
/// answer exactly as hypot would, at a fraction of its cost.
const BAND: f64 = 1e-9;

/// `a.hypot(b) <= r`.
#[inline]
pub(super) fn within(a: f64, b: f64, r: f64) -> bool {
    let d2 = a * a + b * b;
    let r2 = r * r;
    if d2 > r2 * (1.0 + BAND) {
        false
    } else if d2 < r2 * (1.0 - BAND) {
        true
    } else {
        a.hypot(b) <= r
    }
}

/// `r0 <= a.hypot(b) < r1`.
#[inline]
pub(super) fn in_ring(a: f64, b: f64, r0: f64, r1: f64) -> bool {
    let d2 = a * a + b * b;
    let (lo, hi) = (r0 * r0, r1 * r1);
    if d2 > hi * (1.0 + BAND) || d2 < lo * (1.0 - BAND) {
        false
    } else if d2 < hi * (1.0 - BAND) && d2 > lo * (1.0 + BAND) {
        true
    } else {
        let d = a.hypot(b);
        d >= r0 && d < r1
    }
}

/// Least body area (mm², pixels at or above [`BODY_HU`]) of the top slice
/// searched: a neck slice holds 100–150 cm².
const MIN_BODY_MM2: f64 = 5000.0;
const BODY_HU: f32 = -500.0;

/// Top slice showing the body: walk down while less than [`MIN_BODY_MM2`]
/// of a slice is tissue. Scanner padding (−2048, −3024 HU) and the air
/// the work grid puts beyond an oblique scan's corners are not tissue; the
/// earlier rule (over half the slice equal to its first pixel) took the
/// oblique copy of the real CT's corners for data and started 80 mm low,
/// below the root.
fn top_slice(ct: &Volume<i16>) -> (usize, isize) {
    let [ni, nj, nk] = ct.dims();
    let sp = ct.spacing();
    let up = ct.index_to_world([0.0, 0.0, (nk - 1) as f64]).z > ct.index_to_world([0.0; 3]).z;
    let (mut k, dk): (isize, isize) = if up { (nk as isize - 1, -1) } else { (0, 1) };
    let need = (MIN_BODY_MM2 / (sp[0] * sp[1])).ceil() as usize;
    let top = k;
    while k >= 0 && (k as usize) < nk {
        let s = &ct.as_slice()[k as usize * ni * nj..(k as usize + 1) * ni * nj];
        if s.iter().filter(|&&v| v as f32 >= BODY_HU).count() >= need {
            return (k as usize, dk);
        }
        k += dk;
    }
    (top as usize, dk)
}

/// Spacing of the axial levels searched (mm) and how far below the top
/// slice the search goes: a chest CT's top slice may lie above the arch
/// (neck vessels only) or in it (no circle), and the ascending aorta is
/// a circle beside the descending aorta just below the arch.
const LEVEL_STEP_MM: f64 = 5.0;
const SEARCH_DEPTH_MM: f64 = 150.0;
/// Below a level holding one lumen, how far a level holding two is sought
/// to tell which of the two the first one was (mm).
const PAIR_LOOKAHEAD_MM: f64 = 40.0;
/// The descending aorta lies at least this far posterior of the ascending
/// aorta (mm; 40–90 mm in adults).
const PAIR_MIN_POSTERIOR_MM: f64 = 25.0;
/// Two circles of successive levels within this distance (mm, in the axial
/// plane) are the same vessel.
const SAME_VESSEL_MM: f64 = 15.0;

/// The circles of one axial level and what was judged of them.
struct Level {
    k: usize,
    candidates: Vec<Candidate>,
    /// The lumens, with their world centres, anterior first.
    lumens: Vec<(Point3, Circle)>,
    map: CircleMap,
}

impl Level {
    /// The most anterior lumen and, if one lies well posterior of it, the
    /// descending aorta.
    fn pair(&self) -> Option<(usize, usize)> {
        let (w0, _) = self.lumens.first()?;
        let da = self
            .lumens
            .iter()
            .position(|(w, _)| w.y - w0.y >= PAIR_MIN_POSTERIOR_MM)?;
        Some((0, da))
    }
}

fn judge_level(ct: &Volume<i16>, k: usize, hp: &HoughParams) -> Level {
    let [ni, nj, _] = ct.dims();
    let sp = ct.spacing();
    let img = slice_f32(ct, k);
    let map = circleness(&img, ni, nj, sp[0], sp[1], hp);
    let peaks = map.peaks(sp[0], sp[1], 0.25, 8);
    let mut candidates = Vec::new();
    let mut lumens = Vec::new();
    for p in &peaks {
        let inside = median(&mut annulus_values(
            &img,
            ni,
            nj,
            [sp[0], sp[1]],
            (p.i, p.j),
            0.0,
            0.6 * p.r_mm,
        ));
        let ring_v = annulus_values(
            &img,
            ni,
            nj,
            [sp[0], sp[1]],
            (p.i, p.j),
            0.8 * p.r_mm,
            0.95 * p.r_mm,
        );
        let ring = ring_v.iter().sum::<f64>() / ring_v.len().max(1) as f64;
        let w = ct.index_to_world([p.i, p.j, k as f64]);
        let verdict = if p.c < C_SEED {
            format!("circleness {:.2} < {C_SEED}", p.c)
        } else if inside < hp.bright_min {
            format!(
                "inside {inside:.0} HU < {:.0} HU: not a contrast lumen",
                hp.bright_min
            )
        } else if ring > inside + BONE_RIM_HU {
            format!("rim {ring:.0} HU brighter than inside {inside:.0} HU: bone")
        } else {
            lumens.push((w, *p));
            "lumen".to_string()
        };
        candidates.push(Candidate {
            centre_mm: [w.x, w.y, w.z],
            r_mm: p.r_mm,
            circleness: p.c,
            inside_hu: inside,
            ring_hu: ring,
            verdict,
        });
    }
    lumens.sort_by(|a, b| a.0.y.total_cmp(&b.0.y));
    Level {
        k,
        candidates,
        lumens,
        map,
    }
}

fn near_bone(w: &Point3, bone: &[(f64, f64)]) -> bool {
    bone.iter()
        .any(|&(x, y)| (w.x - x).hypot(w.y - y) <= SAME_VESSEL_MM)
}

/// Takes out of `level`'s lumens those at a place judged bone-rimmed on
/// some level, and says so in their candidates' verdicts.
fn drop_bone_columns(level: &mut Level, bone: &[(f64, f64)]) {
    let (keep, gone): (Vec<_>, Vec<_>) = level
        .lumens
        .drain(..)
        .partition(|(w, _)| !near_bone(w, bone));
    level.lumens = keep;
    for (w, _) in gone {
        if let Some(c) = level
            .candidates
            .iter_mut()
            .find(|c| c.centre_mm == [w.x, w.y, w.z])
        {
            c.verdict =
                "bright inside, but bone-rimmed at this place on another level: a vertebral body"
                    .into();
        }
    }
}

/// Find the ascending aorta on the highest axial level that shows it and
/// track it toward the root.
///
/// Levels are searched from the top slice down. Where a level shows two
/// lumens, one well posterior of the other, the anterior one is the
/// ascending aorta and the posterior one the descending aorta. A level with
/// a single lumen is ambiguous (a cardiac CTA's top slice shows the
/// ascending aorta alone; a chest CT's may show the descending aorta
/// alone): the levels below it tell, where the pair appears, which of the
/// two it continues; with no pair below, it is taken as the ascending aorta.
pub fn find_aorta(ct: &Volume<i16>, hp: &HoughParams) -> Result<Found> {
    let nk = ct.dims()[2];
    let sp = ct.spacing();
    let (top_k, dk) = top_slice(ct);
    let step = ((LEVEL_STEP_MM / sp[2]).round() as usize).max(1);
    let depth = (SEARCH_DEPTH_MM / sp[2]).round() as usize;
    let lookahead = (PAIR_LOOKAHEAD_MM / sp[2]).round() as usize;
    let level_k = |n: usize| -> Option<usize> {
        let k = top_k as isize + dk * (n * step) as isize;
        (k >= 0 && (k as usize) < nk && n * step <= depth).then_some(k as usize)
    };
    let mut searched = Vec::new();
    let mut first: Option<Level> = None;
    // Where the levels after `first` begin in `searched`.
    let mut first_at = 0;
    let mut chosen: Option<(Level, usize, String)> = None;
    let mut n = 0;
    // Where a circle was judged bone-rimmed: a vertebral body's inside
    // (cancellous bone, 200–400 HU) passes for contrast on levels where its
    // cortical rim is thin, and it lies at the same place on every level.
    let mut bone: Vec<(f64, f64)> = Vec::new();
    while let Some(k) = level_k(n) {
        n += 1;
        let mut level = judge_level(ct, k, hp);
        bone.extend(
            level
                .candidates
                .iter()
                .filter(|c| c.verdict.contains("bone"))
                .map(|c| (c.centre_mm[0], c.centre_mm[1])),
        );
        drop_bone_columns(&mut level, &bone);
        if first
            .as_ref()
            .is_some_and(|one| near_bone(&one.lumens[0].0, &bone))
        {
            // The single lumen above was a vertebral body after all: look
            // on, as if it had not been seen.
            let mut one = first.take().expect("checked");
            drop_bone_columns(&mut one, &bone);
            searched.push(one);
        }
        if let Some(one) = &first {
            if k.abs_diff(one.k) > lookahead {
                searched.push(level);
                break;
            }
            let Some((aa, da)) = level.pair() else {
                searched.push(level);
                continue;
            };
            // Which of the pair does the single lumen above continue?
            let (w1, _) = one.lumens[0];
            let near = |w: &Point3| (w.x - w1.x).hypot(w.y - w1.y) <= SAME_VESSEL_MM;
            let one = first.take().expect("checked");
            if near(&level.lumens[da].0) {
                let verdict = format!(
                    "ascending aorta, anterior of the descending aorta, which the single lumen {:.0} mm higher was",
                    one.k.abs_diff(k) as f64 * sp[2]
                );
                searched.push(one);
                chosen = Some((level, aa, verdict));
            } else {
                searched.push(level);
                let (lv, at) = seed_on_chain(one, &mut searched, first_at);
                chosen = Some((
                    lv,
                    at,
                    "ascending aorta (the single lumen of a higher level, continued here; the levels below show the descending aorta posterior of it)".into(),
                ));
            }
            break;
        }
        match level.pair() {
            Some((aa, _)) => {
                chosen = Some((
                    level,
                    aa,
                    "ascending aorta (anterior of the descending aorta on the same level)".into(),
                ));
                break;
            }
            None if !level.lumens.is_empty() => {
                first_at = searched.len();
                first = Some(level);
            }
            None => searched.push(level),
        }
    }
    if let Some(one) = first {
        // The descending aorta runs beside the spine: where the same
        // circle is judged bone-rimmed on other levels, the only lumen is
        // that vessel, and taking it would segment the wrong aorta.
        let (w1, c1) = one.lumens[0];
        let beside_bone = searched.iter().flat_map(|l| &l.candidates).find(|c| {
            c.verdict.contains("bone")
                && (c.centre_mm[0] - w1.x).hypot(c.centre_mm[1] - w1.y) <= SAME_VESSEL_MM
        });
        if let Some(b) = beside_bone {
            return Err(Error::failed(
                "segment",
                format!(
                    "the only contrast lumen found on the axial levels (r {:.1} mm at {:.0}, {:.0}, {:.0} mm LPS) has a bone-bright rim {:.0} mm lower or higher: it is the descending aorta beside the spine, and no ascending aorta was found; give the landmarks C1–C3 on the aortic root",
                    c1.r_mm,
                    w1.x,
                    w1.y,
                    w1.z,
                    (b.centre_mm[2] - w1.z).abs()
                ),
            ));
        }
        let (lv, at) = seed_on_chain(one, &mut searched, first_at);
        chosen = Some((
            lv,
            at,
            "ascending aorta (a single lumen from a higher level down, and no descending aorta seen below it)".into(),
        ));
    }
    let mut candidates: Vec<Candidate> =
        searched.iter().flat_map(|l| l.candidates.clone()).collect();
    let Some((level, pick, verdict)) = chosen else {
        let seen = if candidates.is_empty() {
            "no circle at all".to_string()
        } else {
            candidates
                .iter()
                .filter(|c| c.circleness >= 0.3)
                .map(|c| {
                    format!(
                        "z {:.0} mm r {:.1} mm C {:.2}: {}",
                        c.centre_mm[2], c.r_mm, c.circleness, c.verdict
                    )
                })
                .collect::<Vec<_>>()
                .join("; ")
        };
        return Err(Error::failed(
            "segment",
            format!(
                "looked for the ascending aorta on {n} axial levels from the top slice down to {:.0} mm below it (a circle of radius {:.0}–{:.0} mm, circleness ≥ {C_SEED}, contrast lumen ≥ {:.0} HU inside) and found none ({seen}); is this a contrast CT angiogram of the chest? Landmarks C1–C3 on the aortic root let segment start there instead",
                ((n.max(1) - 1) * step) as f64 * sp[2],
                hp.r_min_mm,
                hp.r_max_mm,
                hp.bright_min
            ),
        ));
    };
    let seed = level.lumens[pick].1;
    let seed_w = level.lumens[pick].0;
    let mut level_c = level.candidates.clone();
    for c in &mut level_c {
        if c.verdict == "lumen" {
            c.verdict = if c.centre_mm == [seed_w.x, seed_w.y, seed_w.z] {
                verdict.clone()
            } else if c.centre_mm[1] > seed_w.y {
                "lumen, posterior to the ascending aorta (descending aorta?)".into()
            } else {
                "lumen, anterior to the ascending aorta".into()
            };
        }
    }
    candidates.extend(level_c);
    let level_radii: Vec<f64> = searched
        .iter()
        .flat_map(|l| &l.lumens)
        .filter(|(w, _)| (w.x - seed_w.x).hypot(w.y - seed_w.y) <= SAME_VESSEL_MM)
        .map(|(_, c)| c.r_mm)
        .collect();
    let k0 = level.k;
    let mut track = vec![TrackPoint {
        k: k0,
        i: seed.i,
        j: seed.j,
        r_mm: seed.r_mm,
        c: seed.c,
    }];
    // Track toward the feet.
    let mut k = k0 as isize + dk;
    while k >= 0 && (k as usize) < nk {
        let last = *track.last().expect("seeded");
        let Some(next) = track_step(ct, k as usize, &last, hp) else {
            break;
        };
        track.push(next);
        k += dk;
    }
    Ok(Found {
        top_k: k0,
        dk,
        candidates,
        track,
        top_map: level.map,
        direction: None,
        level_radii,
    })
}

/// Levels without the followed lumen that a chain bridges.
const CHAIN_GAP: usize = 2;
/// A seed circle this round is kept; a less round one is followed down.
const C_ROUND: f64 = 0.6;

/// The seed on the single lumen of level `one` followed down the levels
/// after it (`searched` from index `from`, in search order; one lumen
/// within [`SAME_VESSEL_MM`] of the last continues it): the first circle
/// at least [`C_ROUND`] round, else the roundest, taken out of `searched`
/// (`one` goes in its place). The first circle where the ascending aorta
/// bends into the arch can be a marginal ellipse (the real CT at 1 and
/// 2 mm: circleness 0.52–0.56, r 10 mm, at 2 mm its centre under the
/// contrast threshold, so no seed voxel); 15 mm lower the same vessel is
/// round (0.71–0.75, r 13.7 mm). Not the roundest of all: a seed in the
/// middle of the ascending aorta (0.88, 35 mm lower) led the 1 mm copy's
/// region into the left atrium.
fn seed_on_chain(one: Level, searched: &mut [Level], from: usize) -> (Level, usize) {
    if one.lumens[0].1.c >= C_ROUND {
        return (one, 0);
    }
    let mut at = one.lumens[0].0;
    let mut best: Option<(f64, usize, usize)> = None;
    let mut missed = 0;
    for (x, l) in searched.iter().enumerate().skip(from) {
        let near: Vec<usize> = (0..l.lumens.len())
            .filter(|&i| {
                let w = l.lumens[i].0;
                (w.x - at.x).hypot(w.y - at.y) <= SAME_VESSEL_MM
            })
            .collect();
        match near[..] {
            [i] => {
                missed = 0;
                at = l.lumens[i].0;
                let c = l.lumens[i].1.c;
                if best.is_none_or(|(b, _, _)| c > b) {
                    best = Some((c, x, i));
                }
                if c >= C_ROUND {
                    break;
                }
            }
            // Up to [`CHAIN_GAP`] levels without the lumen (its circle
            // under the circleness threshold in the bend: two levels on
            // the real CT's 1 mm copy) are bridged; a second lumen near it
            // ends the chain.
            [] if missed < CHAIN_GAP => missed += 1,
            _ => break,
        }
    }
    match best.filter(|&(c, _, _)| c > one.lumens[0].1.c) {
        Some((_, x, i)) => {
            let lv = std::mem::replace(&mut searched[x], one);
            (lv, i)
        }
        None => (one, 0),
    }
}

/// The circle in slice `k` continuing `last`, if there is one.
pub(super) fn track_step(
    ct: &Volume<i16>,
    k: usize,
    last: &TrackPoint,
    hp: &HoughParams,
) -> Option<TrackPoint> {
    let r = last.r_mm;
    let w = best_circle_near(
        ct,
        k,
        (last.i, last.j),
        (TRACK_SHIFT + 1.0 + TRACK_DR) * r + 3.0 * hp.sigma_mm,
        (r * (1.0 - TRACK_DR), r * (1.0 + TRACK_DR)),
        TRACK_SHIFT * r,
        hp,
    )?;
    let rr = w.map.r_mm[w.v] as f64;
    if (w.c as f64) < C_TRACK || (rr - r).abs() / r >= TRACK_DR {
        return None;
    }
    let circ = w.map.refine(w.v % w.wi, w.v / w.wi, rr);
    Some(TrackPoint {
        k,
        i: circ.i + w.i0 as f64,
        j: circ.j + w.j0 as f64,
        r_mm: circ.r_mm,
        c: w.c as f64,
    })
}

/// The circleness peak nearest a point of a slice, searched in a window.
pub(super) struct WindowPeak {
    /// The window's HU (i fastest), its origin in the slice and its width.
    pub win: Vec<f32>,
    pub i0: usize,
    pub j0: usize,
    pub wi: usize,
    pub wj: usize,
    pub map: CircleMap,
    /// The peak's circleness and window index.
    pub c: f32,
    pub v: usize,
}

/// Circleness of radii `r_mm` in a window of slice `k` reaching `half_mm`
/// around index point `at`, and its highest value within `shift_mm` of it;
/// None when the window is under 3 pixels wide (the point at the scan's
/// edge) or no pixel lies that near.
pub(super) fn best_circle_near(
    ct: &Volume<i16>,
    k: usize,
    at: (f64, f64),
    half_mm: f64,
    r_mm: (f64, f64),
    shift_mm: f64,
    hp: &HoughParams,
) -> Option<WindowPeak> {
    let [ni, nj, _] = ct.dims();
    let sp = ct.spacing();
    let (hi, hj) = (
        (half_mm / sp[0]).ceil() as i64,
        (half_mm / sp[1]).ceil() as i64,
    );
    let i0 = (at.0.round() as i64 - hi).clamp(0, ni as i64 - 1) as usize;
    let i1 = (at.0.round() as i64 + hi).clamp(0, ni as i64 - 1) as usize;
    let j0 = (at.1.round() as i64 - hj).clamp(0, nj as i64 - 1) as usize;
    let j1 = (at.1.round() as i64 + hj).clamp(0, nj as i64 - 1) as usize;
    let (wi, wj) = (i1 - i0 + 1, j1 - j0 + 1);
    if wi < 3 || wj < 3 {
        return None;
    }
    let full = &ct.as_slice()[k * ni * nj..(k + 1) * ni * nj];
    let mut win = vec![0f32; wi * wj];
    for j in 0..wj {
        for i in 0..wi {
            win[i + j * wi] = full[i0 + i + (j0 + j) * ni] as f32;
        }
    }
    let p = HoughParams {
        r_min_mm: r_mm.0,
        r_max_mm: r_mm.1,
        ..*hp
    };
    let map = circleness(&win, wi, wj, sp[0], sp[1], &p);
    let (ci, cj) = (at.0 - i0 as f64, at.1 - j0 as f64);
    let mut best: Option<(f32, usize)> = None;
    for j in 0..wj {
        for i in 0..wi {
            let v = i + j * wi;
            let (a, b) = ((i as f64 - ci) * sp[0], (j as f64 - cj) * sp[1]);
            if within(a, b, shift_mm) && best.is_none_or(|(b, _)| map.peak[v] > b) {
                best = Some((map.peak[v], v));
            }
        }
    }
    let (_, v) = best?;
    let c = map.c[v];
    Some(WindowPeak {
        win,
        i0,
        j0,
        wi,
        wj,
        map,
        c,
        v,
    })
}

/// World position of a track point.
pub fn world(ct: &Volume<i16>, t: &TrackPoint) -> Point3 {
    ct.index_to_world([t.i, t.j, t.k as f64])
}
