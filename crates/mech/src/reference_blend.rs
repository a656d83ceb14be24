//! Reference triangles part-way from the sutured leaflet to the flat
//! template: the continuation that lets a closure rest on the cut
//! pericardium without starting from the absurd stress of a placement that
//! was never meant to be isometric to it.
//!
//! A triangle's squared edge lengths are linear in its metric, and the
//! positive-definite metrics form a convex set, so the squared lengths
//! (1 − s) ℓ²_from + s ℓ²_to always make a triangle: the one whose metric is
//! the blend of the two. It is laid in the plane z = 0 (a membrane's energy
//! depends only on its reference metric). Fibres keep their coordinates in
//! the basis of the triangle's edges, so they turn with the blend.

use super::element::{RefTri, V3};

/// A planar triangle with squared edge lengths `l2` (edge k opposite
/// vertex k); `None` when they make no triangle of positive area.
fn triangle_from_lengths(l2: [f64; 3]) -> Option<[V3; 3]> {
    let base = l2[2].sqrt();
    if !(base > 0.0) {
        return None;
    }
    let x = (l2[2] + l2[1] - l2[0]) / (2.0 * base);
    let y2 = l2[1] - x * x;
    if !(y2 > 0.0) {
        return None;
    }
    Some([
        V3::zeros(),
        V3::new(base, 0.0, 0.0),
        V3::new(x, y2.sqrt(), 0.0),
    ])
}

/// Coordinates (α, β) of `v` in the basis (e₁, e₂) of a triangle's edges
/// (least squares in the triangle's plane).
fn edge_coordinates(v: &V3, e1: &V3, e2: &V3) -> (f64, f64) {
    let (a, b, c) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (p, q) = (v.dot(e1), v.dot(e2));
    let det = a * c - b * b;
    ((c * p - b * q) / det, (a * q - b * p) / det)
}

/// The fibres per triangle and the positions they are tangent to (the
/// placed leaflets: `coapt leaflets` pushes the template's fibres forward
/// onto them).
pub type Fibres<'a> = (&'a [[V3; 2]], &'a [V3]);

/// Reference triangles at blend `s` ∈ [0, 1] between the positions `from`
/// (s = 0) and `to` (s = 1).
pub fn blended(
    from: &[V3],
    to: &[V3],
    tris: &[[u32; 3]],
    s: f64,
    thickness: f64,
    fibers: Option<Fibres>,
) -> Result<Vec<RefTri>, String> {
    tris.iter()
        .enumerate()
        .map(|(t, tri)| {
            let [a, b, c] = tri.map(|i| i as usize);
            let len2 = |x: &[V3]| {
                [
                    (x[c] - x[b]).norm_squared(),
                    (x[a] - x[c]).norm_squared(),
                    (x[b] - x[a]).norm_squared(),
                ]
            };
            let (l0, l1) = (len2(from), len2(to));
            let p = triangle_from_lengths([0, 1, 2].map(|k| (1.0 - s) * l0[k] + s * l1[k]))
                .ok_or_else(|| format!("triangle {t} is degenerate in the blended reference"))?;
            let fib = fibers.map(|(f, on)| {
                let (e1, e2) = (on[b] - on[a], on[c] - on[a]);
                f[t].map(|m| {
                    let (al, be) = edge_coordinates(&m, &e1, &e2);
                    (p[1] - p[0]) * al + (p[2] - p[0]) * be
                })
            });
            RefTri::new(p, thickness, fib)
                .ok_or_else(|| format!("triangle {t} is degenerate in the blended reference"))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lengths2(r: &RefTri) -> [f64; 3] {
        r.rest_len2
    }

    #[test]
    fn the_blend_interpolates_squared_edge_lengths_and_its_ends_are_the_two_triangles() {
        let from = vec![
            V3::new(0.0, 0.0, 0.0),
            V3::new(2.0, 0.3, 1.0),
            V3::new(0.4, 1.5, -0.5),
        ];
        let to = vec![
            V3::new(5.0, 5.0, 0.0),
            V3::new(8.0, 5.0, 0.0),
            V3::new(5.2, 6.0, 0.0),
        ];
        let tris = [[0u32, 1, 2]];
        let l = |x: &[V3]| {
            [
                (x[2] - x[1]).norm_squared(),
                (x[0] - x[2]).norm_squared(),
                (x[1] - x[0]).norm_squared(),
            ]
        };
        for s in [0.0, 0.3, 1.0] {
            let r = &blended(&from, &to, &tris, s, 0.5, None).unwrap()[0];
            for k in 0..3 {
                let want = (1.0 - s) * l(&from)[k] + s * l(&to)[k];
                assert!(
                    (lengths2(r)[k] - want).abs() < 1e-12 * want,
                    "s {s} edge {k}"
                );
            }
        }
        // At the ends the reference is the triangle itself, up to a rigid
        // motion: the same area and the same metric G.
        let own = RefTri::new([from[0], from[1], from[2]], 0.5, None).unwrap();
        let r = &blended(&from, &to, &tris, 0.0, 0.5, None).unwrap()[0];
        assert!((r.area - own.area).abs() < 1e-12);
        assert!((r.g - own.g).amax() < 1e-12);
    }

    #[test]
    fn fibres_keep_their_edge_coordinates() {
        let from = vec![
            V3::new(0.0, 0.0, 0.0),
            V3::new(2.0, 0.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
        ];
        // The target doubles the second edge direction: a fibre along the
        // bisector of the first two edges turns towards the stretched one.
        let to = vec![
            V3::new(0.0, 0.0, 0.0),
            V3::new(2.0, 0.0, 0.0),
            V3::new(0.0, 2.0, 0.0),
        ];
        let m = V3::new(1.0, 1.0, 0.0).normalize();
        let fib = [[m, V3::new(1.0, 0.0, 0.0)]];
        let r = &blended(&from, &to, &[[0, 1, 2]], 1.0, 0.5, Some((&fib, &from))).unwrap()[0];
        // In the blended triangle (laid with edge 0→1 on x): m = e₁/4 + e₂/2
        // of the source maps to (0.5, 1.0), normalised.
        let want = V3::new(0.5, 1.0, 0.0).normalize();
        assert!((r.fiber[0] - want).norm() < 1e-12, "{:?}", r.fiber[0]);
        assert!((r.fiber[1] - V3::new(1.0, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn lengths_that_make_no_triangle_are_refused() {
        assert!(triangle_from_lengths([9.0, 1.0, 1.0]).is_none());
        assert!(triangle_from_lengths([1.0, 1.0, 0.0]).is_none());
        assert!(triangle_from_lengths([1.0, 1.0, 1.0]).is_some());
    }
}
