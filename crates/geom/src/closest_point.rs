//! Closest point on a triangle (Ericson, *Real-Time Collision Detection*
//! §5.1.5): Voronoi-region tests, returning the point, its barycentric
//! coordinates and the feature it lies on.

use super::Vector3 as V3;

/// The feature of triangle ABC (vertices 0, 1, 2) that holds the closest
/// point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feature {
    /// Vertex `i`.
    Vertex(u8),
    /// Edge opposite vertex `i`, i.e. between vertices `i+1` and `i+2`
    /// (mod 3); the barycentric `w[i]` is 0.
    Edge(u8),
    /// Interior of the face.
    Face,
}

/// Result of [`closest_point`].
#[derive(Debug, Clone, Copy)]
pub struct Closest {
    /// Closest point p = Σ w_i v_i.
    pub point: V3,
    /// Barycentric coordinates of p (each in [0, 1], sum 1).
    pub w: [f64; 3],
    pub feature: Feature,
}

/// Closest point of the closed triangle `(a, b, c)` to `x`.
///
/// Degenerate (collinear or coincident) triangles never divide by zero: the
/// face region is only entered with a positive denominator, otherwise the
/// answer is the closest point on the three edges.
pub fn closest_point(x: &V3, a: &V3, b: &V3, c: &V3) -> Closest {
    let ab = b - a;
    let ac = c - a;
    let ap = x - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return vertex(0, a);
    }
    let bp = x - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return vertex(1, b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 && d1 - d3 > 0.0 {
        let v = d1 / (d1 - d3);
        return Closest {
            point: a + ab * v,
            w: [1.0 - v, v, 0.0],
            feature: Feature::Edge(2),
        };
    }
    let cp = x - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return vertex(2, c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 && d2 - d6 > 0.0 {
        let w = d2 / (d2 - d6);
        return Closest {
            point: a + ac * w,
            w: [1.0 - w, 0.0, w],
            feature: Feature::Edge(1),
        };
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 && (d4 - d3) + (d5 - d6) > 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return Closest {
            point: b + (c - b) * w,
            w: [0.0, 1.0 - w, w],
            feature: Feature::Edge(0),
        };
    }
    let sum = va + vb + vc;
    if sum > 0.0 && va >= 0.0 && vb >= 0.0 && vc >= 0.0 {
        let denom = 1.0 / sum;
        let v = vb * denom;
        let w = vc * denom;
        if v.is_finite() && w.is_finite() {
            return Closest {
                point: a + ab * v + ac * w,
                w: [1.0 - v - w, v, w],
                feature: Feature::Face,
            };
        }
    }
    degenerate(x, [a, b, c])
}

fn vertex(i: u8, p: &V3) -> Closest {
    let mut w = [0.0; 3];
    w[i as usize] = 1.0;
    Closest {
        point: *p,
        w,
        feature: Feature::Vertex(i),
    }
}

/// Fallback for degenerate triangles (and round-off at region borders):
/// the closest point over the three closed edges.
fn degenerate(x: &V3, v: [&V3; 3]) -> Closest {
    let mut best: Option<(f64, Closest)> = None;
    for k in 0..3u8 {
        let (i, j) = (((k + 1) % 3) as usize, ((k + 2) % 3) as usize);
        let e = v[j] - v[i];
        let l2 = e.norm_squared();
        let t = if l2 > 0.0 {
            ((x - v[i]).dot(&e) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let c = if t <= 0.0 {
            vertex(i as u8, v[i])
        } else if t >= 1.0 {
            vertex(j as u8, v[j])
        } else {
            let mut w = [0.0; 3];
            w[i] = 1.0 - t;
            w[j] = t;
            Closest {
                point: v[i] + e * t,
                w,
                feature: Feature::Edge(k),
            }
        };
        let d2 = (x - c.point).norm_squared();
        if best.as_ref().is_none_or(|(bd, _)| d2 < *bd) {
            best = Some((d2, c));
        }
    }
    best.unwrap().1
}

#[cfg(test)]
mod tests {
    use super::*;
    use coapt_base::rng::SplitMix64;

    fn rv(r: &mut SplitMix64, s: f64) -> V3 {
        V3::new(r.range(-s, s), r.range(-s, s), r.range(-s, s))
    }

    /// Brute force: dense barycentric sampling plus exact edge projections.
    #[test]
    fn matches_brute_force() {
        let mut r = SplitMix64::new(11);
        let mut counts = [0usize; 3];
        for _ in 0..400 {
            let (a, b, c) = (rv(&mut r, 1.0), rv(&mut r, 1.0), rv(&mut r, 1.0));
            let x = if r.uniform() < 0.3 {
                // Above the face: a point of the plane plus a normal offset.
                let (u, v) = (r.uniform(), r.uniform());
                let nrm = (b - a).cross(&(c - a));
                a + (b - a) * (0.5 * u) + (c - a) * (0.5 * v) + nrm * r.range(-1.0, 1.0)
            } else {
                rv(&mut r, 2.0)
            };
            let cp = closest_point(&x, &a, &b, &c);
            let d = (x - cp.point).norm();
            // Barycentrics consistent with the point, in [0,1], sum 1.
            let p2 = a * cp.w[0] + b * cp.w[1] + c * cp.w[2];
            assert!((p2 - cp.point).norm() < 1e-12);
            assert!(cp.w.iter().all(|&w| (-1e-15..=1.0 + 1e-15).contains(&w)));
            assert!((cp.w.iter().sum::<f64>() - 1.0).abs() < 1e-14);
            match cp.feature {
                Feature::Vertex(_) => counts[0] += 1,
                Feature::Edge(k) => {
                    counts[1] += 1;
                    assert_eq!(cp.w[k as usize], 0.0);
                }
                Feature::Face => counts[2] += 1,
            }
            // Sampling never finds a closer point.
            let n = 60;
            let mut best = f64::INFINITY;
            for i in 0..=n {
                for j in 0..=(n - i) {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    let p = a * (1.0 - u - v) + b * u + c * v;
                    best = best.min((x - p).norm());
                }
            }
            let deg = degenerate(&x, [&a, &b, &c]);
            best = best.min((x - deg.point).norm());
            assert!(d <= best + 1e-12, "closest {d} > sampled {best}");
            // And sampling gets close (the grid spacing bounds the error).
            assert!(best - d < 0.05, "{best} vs {d}");
            // Face region: x − p is normal to the triangle.
            if cp.feature == Feature::Face {
                let nrm = (b - a).cross(&(c - a)).normalize();
                assert!((x - cp.point - nrm * nrm.dot(&(x - cp.point))).norm() < 1e-12);
            }
        }
        assert!(counts.iter().all(|&c| c > 20), "{counts:?}");
    }

    #[test]
    fn degenerate_triangles() {
        let a = V3::new(0.0, 0.0, 0.0);
        let b = V3::new(1.0, 0.0, 0.0);
        let c = V3::new(2.0, 0.0, 0.0);
        let x = V3::new(0.5, 1.0, 0.0);
        let cp = closest_point(&x, &a, &b, &c);
        assert!((cp.point - V3::new(0.5, 0.0, 0.0)).norm() < 1e-15);
        // All three coincident.
        let cp = closest_point(&x, &a, &a, &a);
        assert_eq!(cp.point, a);
        assert!(cp.w.iter().all(|w| w.is_finite()));
        // Two coincident.
        let cp = closest_point(&V3::new(3.0, 1.0, 0.0), &a, &a, &b);
        assert_eq!(cp.point, b);
    }
}
