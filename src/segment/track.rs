//! Finding the ascending aorta without help: circles on the top slice, the
//! anterior lumen-like one chosen, then tracked slice by slice toward the root.

use super::hough::{Circle, CircleMap, HoughParams, circleness};
use crate::geom::{Point3, Volume};
use crate::{Error, Result};

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

/// Top unpadded slice: walk down while more than half of a slice equals its
/// first pixel (scanner padding).
fn top_slice(ct: &Volume<i16>) -> (usize, isize) {
    let nk = ct.dims()[2];
    let up = ct.index_to_world([0.0, 0.0, (nk - 1) as f64]).z > ct.index_to_world([0.0; 3]).z;
    let (mut k, dk): (isize, isize) = if up { (nk as isize - 1, -1) } else { (0, 1) };
    for _ in 0..nk / 2 {
        let s = slice_f32(ct, k as usize);
        let same = s.iter().filter(|&&v| v == s[0]).count();
        if same * 2 <= s.len() {
            break;
        }
        k += dk;
    }
    (k as usize, dk)
}

/// Find the ascending aorta on the top slice and track it toward the root.
pub fn find_aorta(ct: &Volume<i16>, hp: &HoughParams) -> Result<Found> {
    let [ni, nj, nk] = ct.dims();
    let sp = ct.spacing();
    let (top_k, dk) = top_slice(ct);
    let img = slice_f32(ct, top_k);
    let map = circleness(&img, ni, nj, sp[0], sp[1], hp);
    let peaks = map.peaks(sp[0], sp[1], 0.25, 8);
    let mut candidates = Vec::new();
    let mut best: Option<(f64, Circle)> = None;
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
        let w = ct.index_to_world([p.i, p.j, top_k as f64]);
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
            "lumen".to_string()
        };
        if verdict == "lumen" && best.is_none_or(|(y, _)| w.y < y) {
            best = Some((w.y, *p));
        }
        candidates.push(Candidate {
            centre_mm: [w.x, w.y, w.z],
            r_mm: p.r_mm,
            circleness: p.c,
            inside_hu: inside,
            ring_hu: ring,
            verdict,
        });
    }
    for c in &mut candidates {
        if c.verdict == "lumen" {
            c.verdict = if best.is_some_and(|(y, _)| y == c.centre_mm[1]) {
                "ascending aorta (most anterior lumen)".into()
            } else {
                "lumen, posterior to the ascending aorta (descending aorta?)".into()
            };
        }
    }
    let Some((_, seed)) = best else {
        let seen = if candidates.is_empty() {
            "no circle at all".to_string()
        } else {
            candidates
                .iter()
                .map(|c| format!("r {:.1} mm C {:.2}: {}", c.r_mm, c.circleness, c.verdict))
                .collect::<Vec<_>>()
                .join("; ")
        };
        return Err(Error::failed(
            "segment",
            format!(
                "looked for the ascending aorta on the top slice (a circle of radius {:.0}–{:.0} mm, circleness ≥ {C_SEED}, contrast lumen ≥ {:.0} HU inside) and found none ({seen}); is this a contrast CT angiogram of the chest?",
                hp.r_min_mm, hp.r_max_mm, hp.bright_min
            ),
        ));
    };
    let mut track = vec![TrackPoint {
        k: top_k,
        i: seed.i,
        j: seed.j,
        r_mm: seed.r_mm,
        c: seed.c,
    }];
    // Track toward the feet.
    let mut k = top_k as isize + dk;
    while k >= 0 && (k as usize) < nk {
        let last = *track.last().expect("seeded");
        let Some(next) = track_step(ct, k as usize, &last, hp) else {
            break;
        };
        track.push(next);
        k += dk;
    }
    Ok(Found {
        top_k,
        dk,
        candidates,
        track,
        top_map: map,
    })
}

/// The circle in slice `k` continuing `last`, if there is one.
pub(super) fn track_step(
    ct: &Volume<i16>,
    k: usize,
    last: &TrackPoint,
    hp: &HoughParams,
) -> Option<TrackPoint> {
    let [ni, nj, _] = ct.dims();
    let sp = ct.spacing();
    let r = last.r_mm;
    let half = (TRACK_SHIFT + 1.0 + TRACK_DR) * r + 3.0 * hp.sigma_mm;
    let (hi, hj) = ((half / sp[0]).ceil() as i64, (half / sp[1]).ceil() as i64);
    let i0 = (last.i.round() as i64 - hi).max(0) as usize;
    let i1 = (last.i.round() as i64 + hi).min(ni as i64 - 1) as usize;
    let j0 = (last.j.round() as i64 - hj).max(0) as usize;
    let j1 = (last.j.round() as i64 + hj).min(nj as i64 - 1) as usize;
    let (wi, wj) = (i1 - i0 + 1, j1 - j0 + 1);
    let full = &ct.as_slice()[k * ni * nj..(k + 1) * ni * nj];
    let mut win = vec![0f32; wi * wj];
    for j in 0..wj {
        for i in 0..wi {
            win[i + j * wi] = full[i0 + i + (j0 + j) * ni] as f32;
        }
    }
    let p = HoughParams {
        r_min_mm: r * (1.0 - TRACK_DR),
        r_max_mm: r * (1.0 + TRACK_DR),
        ..*hp
    };
    let map = circleness(&win, wi, wj, sp[0], sp[1], &p);
    let (ci, cj) = (last.i - i0 as f64, last.j - j0 as f64);
    let mut best: Option<(f32, usize)> = None;
    for j in 0..wj {
        for i in 0..wi {
            let v = i + j * wi;
            let (a, b) = ((i as f64 - ci) * sp[0], (j as f64 - cj) * sp[1]);
            if within(a, b, TRACK_SHIFT * r) && best.is_none_or(|(b, _)| map.c[v] > b) {
                best = Some((map.c[v], v));
            }
        }
    }
    let (c, v) = best?;
    let rr = map.r_mm[v] as f64;
    if (c as f64) < C_TRACK || (rr - r).abs() / r >= TRACK_DR {
        return None;
    }
    let circ = map.refine(v % wi, v / wi, rr);
    Some(TrackPoint {
        k,
        i: circ.i + i0 as f64,
        j: circ.j + j0 as f64,
        r_mm: circ.r_mm,
        c: c as f64,
    })
}

/// World position of a track point.
pub fn world(ct: &Volume<i16>, t: &TrackPoint) -> Point3 {
    ct.index_to_world([t.i, t.j, t.k as f64])
}
