//! How long three free edges must be to meet. To close, the free edges
//! must pass through one point P, each from its commissure C_k to P and on
//! to C_k+1, so free edge k must be at least |C_k P| + |P C_k+1|. P may as
//! well lie in the commissures' plane (projecting it there shortens every
//! leg), and the best P is the one that asks the least stretch of the
//! worst leaflet: min over P of max_k (|C_k P| + |P C_k+1|) / L_k, a convex
//! function of P, found on a grid refined twice. The `leaflets` stage warns
//! with it before a closure is spent; the report judges with it.

use super::Point3;

/// How much longer than its free edge a leaflet's way to the meeting point
/// may be and still count as meeting: within the placement's and the
/// mesh's error. The `leaflets` stage warns beyond it; the report does not
/// take a closure beyond it as a prediction.
pub const MAX_SHORTFALL: f64 = 0.02;

/// Per leaflet k (between C_k and C_k+1, free edge `free[k]`), the length
/// its free edge needs to reach the best meeting point (see the module).
pub fn needed_free_edges(c: &[Point3; 3], free: &[f64; 3]) -> [f64; 3] {
    let p = meeting_point(c, free);
    std::array::from_fn(|k| (c[k] - p).norm() + (p - c[(k + 1) % 3]).norm())
}

/// The point of the commissures' plane that asks the least stretch of the
/// worst free edge (see the module note).
pub fn meeting_point(c: &[Point3; 3], free: &[f64; 3]) -> Point3 {
    let g = Point3::from((c[0].coords + c[1].coords + c[2].coords) / 3.0);
    let u = (c[1] - c[0]).normalize();
    let n = (c[1] - c[0]).cross(&(c[2] - c[0]));
    let w = n.normalize().cross(&u);
    let at = |x: f64, y: f64| g + u * x + w * y;
    let worst = |p: &Point3| {
        (0..3)
            .map(|k| ((c[k] - p).norm() + (p - c[(k + 1) % 3]).norm()) / free[k])
            .fold(0.0, f64::max)
    };
    // The commissures span at most a few centimetres: 0.5 mm steps over
    // their extent, then 0.02 and 0.001 mm steps around the best.
    let half = c.iter().map(|p| (p - g).norm()).fold(0.0, f64::max);
    let (mut x0, mut y0) = (0.0, 0.0);
    let mut span = half;
    for step in [0.5, 0.02, 0.001] {
        let n = (span / step).ceil() as i64;
        let mut best = (f64::INFINITY, x0, y0);
        for i in -n..=n {
            for j in -n..=n {
                let (x, y) = (x0 + i as f64 * step, y0 + j as f64 * step);
                let v = worst(&at(x, y));
                if v < best.0 {
                    best = (v, x, y);
                }
            }
        }
        (x0, y0) = (best.1, best.2);
        span = 2.0 * step;
    }
    at(x0, y0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ring;

    #[test]
    fn a_symmetric_root_needs_twice_its_radius() {
        let c = [0.0, 120.0, 240.0].map(|d| ring(13.9, d, 15.0));
        for n in needed_free_edges(&c, &[24.3; 3]) {
            assert!((n - 27.8).abs() < 1e-5, "{n}");
        }
    }

    /// No nearby point of the commissures' plane asks less of the worst
    /// leaflet (convex, so local is global), on an uneven root.
    #[test]
    fn the_meeting_point_minimises_the_worst_stretch() {
        let c = [
            ring(13.0, 0.0, 15.0),
            ring(13.0, 105.0, 19.0),
            ring(13.0, 240.0, 15.0),
        ];
        let free = [22.0, 31.0, 27.0];
        let p = meeting_point(&c, &free);
        let worst = |p: &Point3| {
            (0..3)
                .map(|k| ((c[k] - p).norm() + (p - c[(k + 1) % 3]).norm()) / free[k])
                .fold(0.0, f64::max)
        };
        let n = (c[1] - c[0]).cross(&(c[2] - c[0])).normalize();
        assert!((p - c[0]).dot(&n).abs() < 1e-9, "in the commissures' plane");
        let u = (c[1] - c[0]).normalize();
        let w = n.cross(&u);
        let best = worst(&p);
        for k in 0..16 {
            let a = k as f64 * std::f64::consts::PI / 8.0;
            for d in [0.005, 0.1, 2.0] {
                let q = p + (u * a.cos() + w * a.sin()) * d;
                assert!(worst(&q) >= best - 1e-9, "{k} {d}: {} < {best}", worst(&q));
            }
        }
        let need = needed_free_edges(&c, &free);
        let max = (0..3).map(|k| need[k] / free[k]).fold(0.0, f64::max);
        assert!((max - best).abs() < 1e-12);
    }
}
