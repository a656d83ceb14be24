//! Clipping a small convex polygon by a scalar field: keep where the field is
//! ≤ 0, placing the cut by linear interpolation along each edge
//! (Sutherland–Hodgman against one level set). Used to cut triangles of a
//! leaflet at the coaptation margin, and zone pieces into axial columns.

use coapt_geom::Point3;

/// A polygon vertex with the field value there.
pub type Vertex = (Point3, f64);

/// Part of `poly` where the (linearly interpolated) field is ≤ 0, and the
/// cut segment when the field changes sign inside (the piece of the level
/// set). A vertex exactly on the level set is kept.
pub fn clip_below(poly: &[Vertex]) -> (Vec<Point3>, Option<[Point3; 2]>) {
    let n = poly.len();
    let mut out = Vec::with_capacity(n + 2);
    let mut cuts = Vec::with_capacity(2);
    for k in 0..n {
        let (p, fp) = poly[k];
        let (q, fq) = poly[(k + 1) % n];
        if fp <= 0.0 {
            out.push(p);
        }
        if (fp <= 0.0) != (fq <= 0.0) {
            // fp and fq have opposite signs (one may be 0 only on the kept side).
            let t = fp / (fp - fq);
            let c = p + (q - p) * t.clamp(0.0, 1.0);
            out.push(c);
            cuts.push(c);
        }
    }
    let cut = (cuts.len() == 2).then(|| [cuts[0], cuts[1]]);
    if out.len() < 3 {
        out.clear();
    }
    (out, cut)
}

/// Area of a planar convex polygon (fan from the first vertex), mm².
pub fn area(poly: &[Point3]) -> f64 {
    if poly.len() < 3 {
        return 0.0;
    }
    let mut s = nalgebra::Vector3::zeros();
    for k in 1..poly.len() - 1 {
        s += (poly[k] - poly[0]).cross(&(poly[k + 1] - poly[0]));
    }
    0.5 * s.norm()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Point3 {
        Point3::new(x, y, 0.0)
    }

    #[test]
    fn half_of_a_unit_square_by_a_linear_field() {
        // f = x − 0.25 on the unit square: keep x ≤ 0.25, area 0.25.
        let sq = [p(0., 0.), p(1., 0.), p(1., 1.), p(0., 1.)];
        let v: Vec<Vertex> = sq.iter().map(|q| (*q, q.x - 0.25)).collect();
        let (poly, cut) = clip_below(&v);
        assert!((area(&poly) - 0.25).abs() < 1e-15);
        let c = cut.expect("field changes sign");
        assert!((c[0].x - 0.25).abs() < 1e-15 && (c[1].x - 0.25).abs() < 1e-15);
        assert!(((c[0] - c[1]).norm() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn all_in_all_out_and_touching() {
        let tri = [p(0., 0.), p(1., 0.), p(0., 1.)];
        let inside: Vec<Vertex> = tri.iter().map(|q| (*q, -1.0)).collect();
        let (poly, cut) = clip_below(&inside);
        assert_eq!(poly.len(), 3);
        assert!(cut.is_none());
        assert!((area(&poly) - 0.5).abs() < 1e-15);
        let outside: Vec<Vertex> = tri.iter().map(|q| (*q, 1.0)).collect();
        assert!(clip_below(&outside).0.is_empty());
        // Touching the level set at one vertex only: no area.
        let touch: Vec<Vertex> = tri.iter().map(|q| (*q, q.x + q.y)).collect();
        let (poly, _) = clip_below(&touch);
        assert_eq!(area(&poly), 0.0);
    }
}
