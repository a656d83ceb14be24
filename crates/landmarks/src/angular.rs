//! The lumen radius against angle around the root axis: its three pillars
//! (minima) and its three sinus lobes (maxima).
//!
//! Profiles are sampled at whole degrees, index i = i degrees; every
//! operation wraps around.

/// Samples per turn (one per degree).
pub const SAMPLES: usize = 360;

/// Least angle between two commissures (degrees). Real roots have 90–150°
/// sectors (141° between C2 and C3 on `../shared/real/`), the phantoms
/// 112–128°; a dent inside a sinus (a coronary ostium cut by the opening,
/// a dent where the segmentation lost a little of the sinus) lies within
/// 70° of a true pillar.
pub const MIN_SECTOR_DEG: usize = 75;

/// Circular moving average over `width` samples (odd).
pub fn smooth(r: &[f64], width: usize) -> Vec<f64> {
    let n = r.len();
    let h = width / 2;
    (0..n)
        .map(|i| (0..width).map(|j| r[(i + n + j - h) % n]).sum::<f64>() / width as f64)
        .collect()
}

fn local_minima(r: &[f64]) -> Vec<usize> {
    let n = r.len();
    (0..n)
        .filter(|&i| r[i] < r[(i + n - 1) % n] && r[i] <= r[(i + 1) % n])
        .collect()
}

/// Sub-sample position of an extremum at `i` by the parabola through it
/// and its two neighbours (degrees, may be outside 0–360).
pub fn refine(r: &[f64], i: usize) -> f64 {
    let n = r.len();
    let (y0, y1, y2) = (r[(i + n - 1) % n], r[i], r[(i + 1) % n]);
    let den = y0 - 2.0 * y1 + y2;
    let off = if den.abs() > 1e-12 {
        (0.5 * (y0 - y2) / den).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    i as f64 + off
}

/// Centre of the trough about the minimum at `i`: the midpoint of the two
/// angles where the profile climbs back to `level` on either side
/// (interpolated; degrees, may be outside 0–360), searching at most
/// `reach` samples each way. A sinus lobe meets its neighbour at a pillar
/// that may be flat-bottomed (a smooth root, a ragged 1.5 mm mask): its
/// lowest sample then lies anywhere along the flat, while the flanks
/// still say where the trough is.
pub fn trough_centre(r: &[f64], i: usize, level: f64, reach: usize) -> f64 {
    let n = r.len();
    if level <= r[i] {
        return refine(r, i);
    }
    let at = |k: isize| r[k.rem_euclid(n as isize) as usize];
    let crossing = |dir: isize| {
        let mut k = 0isize;
        while k < reach as isize && at(i as isize + dir * (k + 1)) < level {
            k += 1;
        }
        let (inner, outer) = (at(i as isize + dir * k), at(i as isize + dir * (k + 1)));
        let f = if outer > inner {
            ((level - inner) / (outer - inner)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        dir as f64 * (k as f64 + f)
    };
    i as f64 + 0.5 * (crossing(-1) + crossing(1))
}

/// The angle between directions `a` and `b` (degrees), in 0–180.
pub fn apart_deg(a: f64, b: f64) -> f64 {
    ((a - b + 540.0).rem_euclid(360.0) - 180.0).abs()
}

/// Angular distance from `a` forward to `b` in samples.
pub fn forward(a: usize, b: usize, n: usize) -> usize {
    (b + n - a) % n
}

/// The three pillars: of all triples of local minima whose sectors are at
/// least [`MIN_SECTOR_DEG`] wide, the one with the smallest summed radius,
/// in increasing angle. `None` when no such triple exists.
pub fn pillars(r: &[f64]) -> Option<[usize; 3]> {
    let n = r.len();
    let m = local_minima(r);
    let mut best: Option<(f64, [usize; 3])> = None;
    for a in 0..m.len() {
        for b in a + 1..m.len() {
            for c in b + 1..m.len() {
                let t = [m[a], m[b], m[c]];
                let ok = (0..3).all(|k| forward(t[k], t[(k + 1) % 3], n) >= MIN_SECTOR_DEG);
                if !ok {
                    continue;
                }
                let s = r[t[0]] + r[t[1]] + r[t[2]];
                if best.is_none_or(|(b, _)| s < b) {
                    best = Some((s, t));
                }
            }
        }
    }
    best.map(|(_, t)| t)
}

/// The largest value strictly inside the sector from `a` forward to `b`,
/// keeping `margin` samples off each end; its index.
pub fn sector_max(r: &[f64], a: usize, b: usize, margin: usize) -> Option<usize> {
    let n = r.len();
    let w = forward(a, b, n);
    (margin..w.saturating_sub(margin).max(margin))
        .map(|j| (a + j) % n)
        .fold(None, |best: Option<usize>, i| match best {
            Some(k) if r[k] >= r[i] => Some(k),
            _ => Some(i),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn apart_is_the_short_way_round() {
        assert_eq!(apart_deg(350.0, 10.0), 20.0);
        assert_eq!(apart_deg(10.0, 350.0), 20.0);
        assert_eq!(apart_deg(0.0, 180.0), 180.0);
        assert_eq!(apart_deg(-90.0, 270.0), 0.0);
    }

    /// A flat-bottomed trough with a ripple on its floor: the lowest sample
    /// lies 12° off the trough's centre, the flanks' midpoint on it.
    #[test]
    fn a_flat_trough_is_centred_by_its_flanks() {
        let centre = 100.0f64;
        let r: Vec<f64> = (0..SAMPLES)
            .map(|i| {
                let d = (i as f64 - centre).abs();
                let floor = if d < 20.0 { 0.0 } else { 0.1 * (d - 20.0) };
                let ripple = if i == 112 { -0.05 } else { 0.0 };
                12.0 + floor.min(3.0) + ripple
            })
            .collect();
        let lowest = (0..SAMPLES).min_by(|&a, &b| r[a].total_cmp(&r[b])).unwrap();
        assert_eq!(lowest, 112);
        let c = trough_centre(&r, lowest, 12.0 + 0.4 * 3.0, 90);
        assert!((c - centre).abs() < 0.01, "{c}");
        // At or below the minimum it falls back to the parabola.
        assert_eq!(trough_centre(&r, lowest, 11.0, 90), refine(&r, lowest));
    }

    /// Three lobes of unequal depth and sectors, plus a dent inside one
    /// sinus deeper than a true pillar: the dent is not taken.
    #[test]
    fn pillars_skip_a_dent_inside_a_sinus() {
        let comm = [10.0f64, 135.0, 250.0];
        let r: Vec<f64> = (0..SAMPLES)
            .map(|i| {
                let th = i as f64;
                let k = if th >= comm[0] && th < comm[1] {
                    0
                } else if th >= comm[1] && th < comm[2] {
                    1
                } else {
                    2
                };
                let start = comm[k];
                let end = if k == 2 { comm[0] + 360.0 } else { comm[k + 1] };
                let t = ((th - start).rem_euclid(360.0)) / (end - start);
                let lobe = (std::f64::consts::PI * t).sin().powi(2);
                let dent = if (i as f64 - 300.0).abs() < 4.0 {
                    3.5
                } else {
                    0.0
                };
                12.0 + [3.0, 2.5, 3.2][k] * lobe - dent
            })
            .collect();
        let p = pillars(&smooth(&r, 5)).unwrap();
        assert_eq!(p.map(|i| i as i64), [10, 135, 250]);
        let m = sector_max(&smooth(&r, 21), p[0], p[1], 3).unwrap();
        assert!((m as f64 - 72.5).abs() <= 1.0, "{m}");
    }
}
