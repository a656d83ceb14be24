//! Exact triangle–triangle intersection (Guigue & Devillers, "Fast and
//! robust triangle-triangle overlap test using orientation predicates",
//! JGT 8(1), 2003), with every sign decision taken by Shewchuk's exact
//! `orient3d` / `orient2d` (crate `robust`), so touching, coplanar and
//! nearly-separated configurations are decided exactly for the given f64
//! coordinates. Triangles are closed sets: sharing a single point counts.
//!
//! Degenerate triangles (vertices exactly collinear or coincident) and
//! triangles with non-finite coordinates are never reported as intersecting.

use rayon::prelude::*;
use robust::{Coord, Coord3D, orient2d, orient3d};

use super::Vector3 as V3;
use super::bvh::{Aabb, Bvh};

fn c3(v: &V3) -> Coord3D<f64> {
    Coord3D {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

/// Sign of (d − a)·((b − a) × (c − a)), exactly: +1 when d lies on the side
/// of plane abc that the right-hand normal points to.
pub fn orient(a: &V3, b: &V3, c: &V3, d: &V3) -> i8 {
    // robust's orient3d is positive when d lies *below* (a, b, c).
    let o = orient3d(c3(a), c3(b), c3(c), c3(d));
    if o < 0.0 {
        1
    } else if o > 0.0 {
        -1
    } else {
        0
    }
}

fn sign2(o: f64) -> i8 {
    if o > 0.0 {
        1
    } else if o < 0.0 {
        -1
    } else {
        0
    }
}

/// 2-D projection dropping axis `k`.
fn proj(v: &V3, k: usize) -> Coord<f64> {
    match k {
        0 => Coord { x: v.y, y: v.z },
        1 => Coord { x: v.z, y: v.x },
        _ => Coord { x: v.x, y: v.y },
    }
}

fn o2(a: &V3, b: &V3, c: &V3, k: usize) -> i8 {
    sign2(orient2d(proj(a, k), proj(b, k), proj(c, k)))
}

/// Exact: the vertices are collinear (or coincident), or not finite.
pub fn is_degenerate(a: &V3, b: &V3, c: &V3) -> bool {
    if ![a, b, c].iter().all(|v| v.iter().all(|c| c.is_finite())) {
        return true;
    }
    (0..3).all(|k| o2(a, b, c, k) == 0)
}

/// The projection axis for a coplanar configuration: the axis whose
/// projection of (a, b, c) has the largest (non-zero) signed area.
fn drop_axis(a: &V3, b: &V3, c: &V3) -> usize {
    let n = (b - a).cross(&(c - a));
    let mut k = if n.x.abs() >= n.y.abs() && n.x.abs() >= n.z.abs() {
        0
    } else if n.y.abs() >= n.z.abs() {
        1
    } else {
        2
    };
    // Guard the floating choice with the exact predicate.
    if o2(a, b, c, k) == 0 {
        k = (0..3).find(|&k| o2(a, b, c, k) != 0).unwrap_or(2);
    }
    k
}

/// Closed 2-D segment intersection in projection `k` (points coplanar).
fn seg_seg_2d(a: &V3, b: &V3, c: &V3, d: &V3, k: usize) -> bool {
    let (d1, d2) = (o2(a, b, c, k), o2(a, b, d, k));
    let (d3, d4) = (o2(c, d, a, k), o2(c, d, b, k));
    if d1 * d2 < 0 && d3 * d4 < 0 {
        return true;
    }
    (d1 == 0 && on_seg(a, b, c, k))
        || (d2 == 0 && on_seg(a, b, d, k))
        || (d3 == 0 && on_seg(c, d, a, k))
        || (d4 == 0 && on_seg(c, d, b, k))
}

/// `p` (collinear with a, b in projection k) lies within the segment's box.
fn on_seg(a: &V3, b: &V3, p: &V3, k: usize) -> bool {
    let (a, b, p) = (proj(a, k), proj(b, k), proj(p, k));
    a.x.min(b.x) <= p.x && p.x <= a.x.max(b.x) && a.y.min(b.y) <= p.y && p.y <= a.y.max(b.y)
}

/// Closed point-in-triangle in projection `k` (non-degenerate projection).
fn point_in_tri_2d(p: &V3, t: [&V3; 3], k: usize) -> bool {
    let s = [
        o2(t[0], t[1], p, k),
        o2(t[1], t[2], p, k),
        o2(t[2], t[0], p, k),
    ];
    !(s.contains(&1) && s.contains(&-1))
}

/// Coplanar triangles (closed): an edge pair crosses or a vertex lies in
/// the other triangle.
fn coplanar_tri_tri(t1: [&V3; 3], t2: [&V3; 3]) -> bool {
    let k = drop_axis(t1[0], t1[1], t1[2]);
    for i in 0..3 {
        for j in 0..3 {
            if seg_seg_2d(t1[i], t1[(i + 1) % 3], t2[j], t2[(j + 1) % 3], k) {
                return true;
            }
        }
    }
    point_in_tri_2d(t1[0], t2, k) || point_in_tri_2d(t2[0], t1, k)
}

/// Guigue–Devillers final test for canonically permuted triangles.
fn check_min_max(p1: &V3, q1: &V3, r1: &V3, p2: &V3, q2: &V3, r2: &V3) -> bool {
    orient(q1, p2, p1, q2) <= 0 && orient(p1, p2, r1, r2) <= 0
}

/// Permutes T2 into canonical form (p2 alone on its side of plane T1).
#[allow(clippy::too_many_arguments)]
fn tri_tri_3d(
    p1: &V3,
    q1: &V3,
    r1: &V3,
    p2: &V3,
    q2: &V3,
    r2: &V3,
    dp2: i8,
    dq2: i8,
    dr2: i8,
) -> bool {
    use std::cmp::Ordering::*;
    match (dp2.cmp(&0), dq2.cmp(&0), dr2.cmp(&0)) {
        (Greater, Greater, _) => check_min_max(p1, r1, q1, r2, p2, q2),
        (Greater, _, Greater) => check_min_max(p1, r1, q1, q2, r2, p2),
        (Greater, _, _) => check_min_max(p1, q1, r1, p2, q2, r2),
        (Less, Less, _) => check_min_max(p1, q1, r1, r2, p2, q2),
        (Less, _, Less) => check_min_max(p1, q1, r1, q2, r2, p2),
        (Less, _, _) => check_min_max(p1, r1, q1, p2, q2, r2),
        (Equal, Less, Equal | Greater) => check_min_max(p1, r1, q1, q2, r2, p2),
        (Equal, Less, Less) => check_min_max(p1, q1, r1, p2, q2, r2),
        (Equal, Greater, Greater) => check_min_max(p1, r1, q1, p2, q2, r2),
        (Equal, Greater, _) => check_min_max(p1, q1, r1, q2, r2, p2),
        (Equal, Equal, Greater) => check_min_max(p1, q1, r1, r2, p2, q2),
        (Equal, Equal, Less) => check_min_max(p1, r1, q1, r2, p2, q2),
        (Equal, Equal, Equal) => coplanar_tri_tri([p1, q1, r1], [p2, q2, r2]),
    }
}

/// Whether the closed triangles (p1, q1, r1) and (p2, q2, r2) intersect.
/// Exact for the given coordinates; false when either is degenerate.
pub fn tri_tri_intersect(t1: [&V3; 3], t2: [&V3; 3]) -> bool {
    if is_degenerate(t1[0], t1[1], t1[2]) || is_degenerate(t2[0], t2[1], t2[2]) {
        return false;
    }
    let [p1, q1, r1] = t1;
    let [p2, q2, r2] = t2;
    let (dp1, dq1, dr1) = (
        orient(p2, q2, r2, p1),
        orient(p2, q2, r2, q1),
        orient(p2, q2, r2, r1),
    );
    if dp1 * dq1 > 0 && dp1 * dr1 > 0 {
        return false;
    }
    let (dp2, dq2, dr2) = (
        orient(p1, q1, r1, p2),
        orient(p1, q1, r1, q2),
        orient(p1, q1, r1, r2),
    );
    if dp2 * dq2 > 0 && dp2 * dr2 > 0 {
        return false;
    }
    // Permute T1 into canonical form (p1 alone on its side of plane T2).
    use std::cmp::Ordering::*;
    match (dp1.cmp(&0), dq1.cmp(&0), dr1.cmp(&0)) {
        (Greater, Greater, _) => tri_tri_3d(r1, p1, q1, p2, r2, q2, dp2, dr2, dq2),
        (Greater, _, Greater) => tri_tri_3d(q1, r1, p1, p2, r2, q2, dp2, dr2, dq2),
        (Greater, _, _) => tri_tri_3d(p1, q1, r1, p2, q2, r2, dp2, dq2, dr2),
        (Less, Less, _) => tri_tri_3d(r1, p1, q1, p2, q2, r2, dp2, dq2, dr2),
        (Less, _, Less) => tri_tri_3d(q1, r1, p1, p2, q2, r2, dp2, dq2, dr2),
        (Less, _, _) => tri_tri_3d(p1, q1, r1, p2, r2, q2, dp2, dr2, dq2),
        (Equal, Less, Equal | Greater) => tri_tri_3d(q1, r1, p1, p2, r2, q2, dp2, dr2, dq2),
        (Equal, Less, Less) => tri_tri_3d(p1, q1, r1, p2, q2, r2, dp2, dq2, dr2),
        (Equal, Greater, Greater) => tri_tri_3d(p1, q1, r1, p2, r2, q2, dp2, dr2, dq2),
        (Equal, Greater, _) => tri_tri_3d(q1, r1, p1, p2, q2, r2, dp2, dq2, dr2),
        (Equal, Equal, Greater) => tri_tri_3d(r1, p1, q1, p2, q2, r2, dp2, dq2, dr2),
        (Equal, Equal, Less) => tri_tri_3d(r1, p1, q1, p2, r2, q2, dp2, dr2, dq2),
        (Equal, Equal, Equal) => coplanar_tri_tri(t1, t2),
    }
}

/// Triangle pairs (i < j, sorted) whose closed triangles intersect, found
/// through `bvh` (a tree over `tris` refitted to `x`). Pairs of different
/// bodies always; pairs within a body only when `within_body`. Pairs that
/// share a vertex index are skipped (they touch by construction).
pub fn intersecting_pairs_with(
    x: &[V3],
    tris: &[[u32; 3]],
    tri_body: &[u16],
    bvh: &Bvh,
    within_body: bool,
) -> Vec<(u32, u32)> {
    assert_eq!(tri_body.len(), tris.len());
    let per: Vec<Vec<(u32, u32)>> = (0..tris.len())
        .into_par_iter()
        .map(|i| {
            let ti = tris[i];
            let vi = ti.map(|k| &x[k as usize]);
            let mut out = vec![];
            if is_degenerate(vi[0], vi[1], vi[2]) {
                return out;
            }
            let bx = Aabb::of_triangle(vi[0], vi[1], vi[2]);
            bvh.query_aabb(&bx, |j| {
                if j as usize <= i {
                    return;
                }
                if !within_body && tri_body[j as usize] == tri_body[i] {
                    return;
                }
                let tj = tris[j as usize];
                if tj.iter().any(|v| ti.contains(v)) {
                    return;
                }
                if tri_tri_intersect(vi, tj.map(|k| &x[k as usize])) {
                    out.push((i as u32, j));
                }
            });
            out.sort_unstable();
            out
        })
        .collect();
    per.concat()
}

/// [`intersecting_pairs_with`] between different bodies only.
pub fn intersecting_pairs(
    x: &[V3],
    tris: &[[u32; 3]],
    tri_body: &[u16],
    bvh: &Bvh,
) -> Vec<(u32, u32)> {
    intersecting_pairs_with(x, tris, tri_body, bvh, false)
}

#[cfg(test)]
mod tests {
    use super::*;
    use coapt_base::rng::SplitMix64;

    /// Independent reference: closed segment [a, b] against closed triangle.
    fn seg_tri(a: &V3, b: &V3, t: [&V3; 3]) -> bool {
        let (oa, ob) = (orient(t[0], t[1], t[2], a), orient(t[0], t[1], t[2], b));
        if oa * ob > 0 {
            return false;
        }
        if oa == 0 && ob == 0 {
            let k = drop_axis(t[0], t[1], t[2]);
            return point_in_tri_2d(a, t, k)
                || point_in_tri_2d(b, t, k)
                || (0..3).any(|i| seg_seg_2d(a, b, t[i], t[(i + 1) % 3], k));
        }
        let s = [
            orient(a, b, t[0], t[1]),
            orient(a, b, t[1], t[2]),
            orient(a, b, t[2], t[0]),
        ];
        !(s.contains(&1) && s.contains(&-1))
    }

    fn reference(t1: [&V3; 3], t2: [&V3; 3]) -> bool {
        (0..3).any(|i| seg_tri(t1[i], t1[(i + 1) % 3], t2))
            || (0..3).any(|i| seg_tri(t2[i], t2[(i + 1) % 3], t1))
    }

    #[test]
    fn orient_convention() {
        let o = V3::zeros();
        assert_eq!(orient(&o, &V3::x(), &V3::y(), &V3::z()), 1);
        assert_eq!(orient(&o, &V3::y(), &V3::x(), &V3::z()), -1);
        assert_eq!(orient(&o, &V3::x(), &V3::y(), &V3::new(3.0, 7.0, 0.0)), 0);
    }

    fn check(t1: [V3; 3], t2: [V3; 3]) -> bool {
        let a = [&t1[0], &t1[1], &t1[2]];
        let b = [&t2[0], &t2[1], &t2[2]];
        let r = tri_tri_intersect(a, b);
        // Symmetric and invariant under vertex order.
        assert_eq!(r, tri_tri_intersect(b, a));
        assert_eq!(r, tri_tri_intersect([a[1], a[2], a[0]], [b[2], b[1], b[0]]));
        assert_eq!(r, tri_tri_intersect([a[0], a[2], a[1]], [b[1], b[0], b[2]]));
        r
    }

    #[test]
    fn random_pairs_match_segment_triangle_reference() {
        let mut r = SplitMix64::new(17);
        let mut hits = [0usize; 2];
        // Real coordinates, and small integer grids (many exact
        // coplanar / touching / shared-edge configurations).
        for round in 0..60_000 {
            let grid = round % 2 == 1;
            let mut v = || {
                if grid {
                    V3::new(
                        (r.next_u64() % 3) as f64,
                        (r.next_u64() % 3) as f64,
                        (r.next_u64() % 2) as f64,
                    )
                } else {
                    V3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0))
                }
            };
            let t1 = [v(), v(), v()];
            let t2 = [v(), v(), v()];
            let d = is_degenerate(&t1[0], &t1[1], &t1[2]) || is_degenerate(&t2[0], &t2[1], &t2[2]);
            let got = check(t1, t2);
            if d {
                assert!(!got);
                continue;
            }
            let want = reference([&t1[0], &t1[1], &t1[2]], [&t2[0], &t2[1], &t2[2]]);
            assert_eq!(got, want, "{t1:?} {t2:?}");
            hits[got as usize] += 1;
        }
        eprintln!("tri-tri: {} intersecting, {} separate", hits[1], hits[0]);
        assert!(hits.iter().all(|&h| h > 5000));
    }

    #[test]
    fn hand_cases() {
        let v = |x: f64, y: f64, z: f64| V3::new(x, y, z);
        let base = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        // Touching at a single vertex (vertex of T2 on T1's vertex).
        assert!(check(
            base,
            [v(0.0, 0.0, 0.0), v(-1.0, 0.0, 1.0), v(0.0, -1.0, 1.0)]
        ));
        // Vertex of T2 touching the interior of T1 from above.
        assert!(check(
            base,
            [v(0.2, 0.2, 0.0), v(0.2, 0.2, 1.0), v(0.5, 0.1, 1.0)]
        ));
        // ... and lifted by 1e-12: separate.
        assert!(!check(
            base,
            [v(0.2, 0.2, 1e-12), v(0.2, 0.2, 1.0), v(0.5, 0.1, 1.0)]
        ));
        // Separated by 1e-12 in the plane (coplanar, a gap along the hypotenuse).
        let e = 1e-12;
        assert!(!check(
            base,
            [v(0.5 + e, 0.5 + e, 0.0), v(1.0, 1.0, 0.0), v(2.0, 0.0, 0.0)]
        ));
        assert!(check(
            base,
            [v(0.5, 0.5, 0.0), v(1.0, 1.0, 0.0), v(2.0, 0.0, 0.0)]
        ));
        // Coplanar overlapping, and one inside the other.
        assert!(check(
            base,
            [v(0.5, -0.5, 0.0), v(0.5, 0.5, 0.0), v(-0.5, 0.2, 0.0)]
        ));
        assert!(check(
            base,
            [v(0.1, 0.1, 0.0), v(0.2, 0.1, 0.0), v(0.1, 0.2, 0.0)]
        ));
        // Coplanar, disjoint.
        assert!(!check(
            base,
            [v(2.0, 2.0, 0.0), v(3.0, 2.0, 0.0), v(2.0, 3.0, 0.0)]
        ));
        // Piercing through the interior.
        assert!(check(
            base,
            [v(0.2, 0.2, -1.0), v(0.3, 0.2, 1.0), v(0.2, 0.3, 1.0)]
        ));
        // Parallel planes 1e-12 apart.
        let up = base.map(|p| p + V3::new(0.0, 0.0, 1e-12));
        assert!(!check(base, up));
        // Shared edge, folded.
        assert!(check(
            base,
            [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.5, 0.0, 1.0)]
        ));
        // Edge-edge crossing (skew edges touching at one point).
        assert!(check(
            base,
            [v(0.5, 0.5, 0.0), v(0.5, 0.5, 1.0), v(1.5, 1.5, 0.5)]
        ));
        // Degenerate: never.
        let line = [v(0.0, 0.0, 0.0), v(1.0, 1.0, 0.0), v(2.0, 2.0, 0.0)];
        assert!(!check(base, line));
        let nan = [v(f64::NAN, 0.0, 0.0), v(1.0, 1.0, 0.0), v(2.0, 0.0, 0.0)];
        assert!(!check(base, nan));
    }

    #[test]
    fn bvh_pairs_match_all_pairs() {
        let mut r = SplitMix64::new(2);
        let mut x = vec![];
        let mut tris = vec![];
        let mut body = vec![];
        for i in 0..600u32 {
            let c = V3::new(r.range(-3.0, 3.0), r.range(-3.0, 3.0), r.range(-3.0, 3.0));
            for _ in 0..3 {
                x.push(c + V3::new(r.range(-0.5, 0.5), r.range(-0.5, 0.5), r.range(-0.5, 0.5)));
            }
            tris.push([3 * i, 3 * i + 1, 3 * i + 2]);
            body.push((i % 3) as u16);
        }
        // Two triangles sharing vertex indices (skipped).
        tris.push([0, 1, 4]);
        body.push(2);
        let bvh = Bvh::build(&x, &tris);
        for within in [false, true] {
            let got = intersecting_pairs_with(&x, &tris, &body, &bvh, within);
            let mut want = vec![];
            for i in 0..tris.len() {
                for j in i + 1..tris.len() {
                    if (!within && body[i] == body[j])
                        || tris[j].iter().any(|v| tris[i].contains(v))
                    {
                        continue;
                    }
                    let f = |t: [u32; 3]| t.map(|k| &x[k as usize]);
                    if tri_tri_intersect(f(tris[i]), f(tris[j])) {
                        want.push((i as u32, j as u32));
                    }
                }
            }
            assert!(!want.is_empty());
            assert_eq!(got, want);
        }
        assert_eq!(
            intersecting_pairs(&x, &tris, &body, &bvh),
            intersecting_pairs_with(&x, &tris, &body, &bvh, false)
        );
    }
}
