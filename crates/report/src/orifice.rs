//! The regurgitant orifice: the part of the lumen's cross-section that the
//! closed leaflets leave uncovered, seen along the valve axis.
//!
//! The lumen outline is where the leaflets are sutured to the wall: per
//! degree of angle about the axis, the largest distance from the axis of a
//! sutured node, bridged linearly across angles without sutures (the gaps
//! at the commissures). Both the lumen and the leaflets' shadow are
//! rasterised on one grid in the plane perpendicular to the axis (pixel
//! centres inside the outline / inside a projected triangle).

use super::ClosedValve;

/// Areas on the plane perpendicular to the axis, mm².
#[derive(Debug, Clone)]
pub struct Orifice {
    pub lumen_mm2: f64,
    pub uncovered_mm2: f64,
    pub pixel_mm: f64,
    /// Raster (row-major, `n × n`, centred on the axis): 0 outside the
    /// lumen, 1 covered lumen, 2 uncovered lumen.
    pub raster: Vec<u8>,
    pub n: usize,
}

const BINS: usize = 360;

/// Lumen radius per degree, or `None` without sutured nodes.
fn outline(v: &ClosedValve) -> Option<Vec<f64>> {
    let mut r = vec![f64::NAN; BINS];
    for (k, p) in v.x.iter().enumerate() {
        if v.boundary[k] != 1 {
            continue;
        }
        let (_, a, rad) = v.frame.to_cylindrical(p);
        if !rad.is_finite() {
            continue;
        }
        let b = (((a.to_degrees() + 360.0) % 360.0) as usize).min(BINS - 1);
        if !(r[b] >= rad) {
            r[b] = rad;
        }
    }
    let known: Vec<usize> = (0..BINS).filter(|&b| r[b].is_finite()).collect();
    if known.is_empty() {
        return None;
    }
    // Bridge empty bins linearly between the nearest known bins (circularly).
    let filled = (0..BINS)
        .map(|b| {
            if r[b].is_finite() {
                return r[b];
            }
            let next = known
                .iter()
                .copied()
                .find(|&k| k > b)
                .unwrap_or(known[0] + BINS);
            let prev = known
                .iter()
                .rev()
                .copied()
                .find(|&k| k < b)
                .map_or(known[known.len() - 1] as i64 - BINS as i64, |k| k as i64);
            let (rp, rn) = (r[prev.rem_euclid(BINS as i64) as usize], r[next % BINS]);
            let t = (b as i64 - prev) as f64 / (next as i64 - prev) as f64;
            rp + (rn - rp) * t
        })
        .collect();
    Some(filled)
}

/// Rasterise the lumen and the leaflets' shadow with pixels of `pixel_mm`;
/// a leaflet is a solid `2 half_t` thick about its mid-surface, so a
/// pixel within `half_t` of a projected triangle is covered too.
pub fn measure(v: &ClosedValve, pixel_mm: f64, half_t: f64) -> Orifice {
    let Some(rad) = outline(v) else {
        return Orifice {
            lumen_mm2: 0.0,
            uncovered_mm2: 0.0,
            pixel_mm,
            raster: Vec::new(),
            n: 0,
        };
    };
    let rmax = rad.iter().cloned().fold(0.0, f64::max);
    let n = ((2.0 * rmax / pixel_mm).ceil() as usize + 2).min(4096);
    let px = 2.0 * rmax / (n as f64 - 2.0).max(1.0);
    let origin = -(n as f64) * 0.5 * px;
    let centre = |i: usize| origin + (i as f64 + 0.5) * px;
    let mut raster = vec![0u8; n * n];
    for row in 0..n {
        for col in 0..n {
            let (x, y) = (centre(col), centre(row));
            let a = (y.atan2(x).to_degrees() + 360.0) % 360.0;
            // Interpolate the outline between bin centres.
            let f = a - 0.5;
            let b0 = f.floor().rem_euclid(BINS as f64) as usize;
            let t = f - f.floor();
            let r = rad[b0] * (1.0 - t) + rad[(b0 + 1) % BINS] * t;
            if x.hypot(y) <= r {
                raster[row * n + col] = 2;
            }
        }
    }
    let local: Vec<[f64; 2]> =
        v.x.iter()
            .map(|p| {
                let l = v.frame.to_local(p);
                [l.x, l.y]
            })
            .collect();
    for t in &v.tris {
        let [a, b, c] = t.map(|k| local[k as usize]);
        if ![a, b, c].iter().flatten().all(|q| q.is_finite()) {
            continue;
        }
        let det = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if det == 0.0 && half_t <= 0.0 {
            continue;
        }
        let lo = |k: usize| {
            (([a[k], b[k], c[k]]
                .iter()
                .cloned()
                .fold(f64::INFINITY, f64::min)
                - half_t
                - origin)
                / px
                - 0.5)
                .ceil()
                .max(0.0) as usize
        };
        let hi = |k: usize| {
            ((([a[k], b[k], c[k]]
                .iter()
                .cloned()
                .fold(f64::NEG_INFINITY, f64::max)
                + half_t
                - origin)
                / px
                - 0.5)
                .floor()
                .max(-1.0)
                + 1.0)
                .min(n as f64) as usize
        };
        let s = det.signum();
        for row in lo(1)..hi(1) {
            for col in lo(0)..hi(0) {
                let p = [centre(col), centre(row)];
                let e = |u: [f64; 2], w: [f64; 2]| {
                    s * ((w[0] - u[0]) * (p[1] - u[1]) - (w[1] - u[1]) * (p[0] - u[0]))
                };
                if raster[row * n + col] != 2 {
                    continue;
                }
                let inside = det != 0.0 && e(a, b) >= 0.0 && e(b, c) >= 0.0 && e(c, a) >= 0.0;
                if inside
                    || (half_t > 0.0
                        && [(a, b), (b, c), (c, a)]
                            .iter()
                            .any(|&(u, w)| segment_distance(p, u, w) <= half_t))
                {
                    raster[row * n + col] = 1;
                }
            }
        }
    }
    let count = |k: u8| raster.iter().filter(|&&q| q == k).count() as f64 * px * px;
    Orifice {
        lumen_mm2: count(1) + count(2),
        uncovered_mm2: count(2),
        pixel_mm: px,
        raster,
        n,
    }
}

/// Distance from `p` to the segment `u`–`w` in the plane.
fn segment_distance(p: [f64; 2], u: [f64; 2], w: [f64; 2]) -> f64 {
    let (dx, dy) = (w[0] - u[0], w[1] - u[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((p[0] - u[0]) * dx + (p[1] - u[1]) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - u[0] - t * dx).hypot(p[1] - u[1] - t * dy)
}
