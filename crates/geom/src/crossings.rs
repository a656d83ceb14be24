//! Exact crossing checks for placed leaflets: leaflet against leaflet and
//! leaflet against the lumen wall, every decision by exact orientation
//! predicates (`geom::tri_tri`).
//!
//! What counts (the rule, also written into leaflets.json):
//! * Leaflet–leaflet: any two triangles of different leaflets whose closed
//!   triangles meet, unless both lie in their leaflet's suture strip (have
//!   a sutured vertex). Neighbouring leaflets are sewn to the same
//!   commissure post: their suture paths end at the same point and run
//!   within ~0.01 mm of each other down the post, so their strips touch
//!   there by construction. Those contacts are counted apart as "sewn".
//! * Leaflet–wall: the suture strip is exempt — its sutured nodes lie on
//!   the wall by construction, so those triangles touch it. Every other
//!   leaflet triangle must not meet any surface triangle.

use super::bvh::{Aabb, Bvh};
use super::tri_tri::{is_degenerate, tri_tri_intersect};
use super::{Point3, Vector3 as V3};

pub const RULE: &str = "exact triangle-triangle tests; the suture strip is the row of \
triangles with a sutured vertex. leaflet-leaflet: any contact between different leaflets \
except strip against strip (neighbours are sewn to the same commissure post; counted as \
sewn_contacts); leaflet-wall: any contact of a triangle outside the suture strip";

/// Leaflet triangle pairs (i < j) of different leaflets that cross, and
/// the strip-against-strip contacts (not crossings).
pub fn leaflet_pairs(
    x: &[Point3],
    tris: &[[u32; 3]],
    leaflet: &[u16],
    sutured: &[bool],
) -> (Vec<(u32, u32)>, Vec<(u32, u32)>) {
    let v: Vec<V3> = x.iter().map(|p| p.coords).collect();
    leaflet_pairs_at(&v, tris, leaflet, sutured)
}

/// [`leaflet_pairs`] on coordinate vectors (the mechanics' positions): the
/// one rule the placed leaflets (leaflets.json), the true-contact barrier's
/// admissible states and the closed state (closure.json) are judged by.
pub fn leaflet_pairs_at(
    v: &[V3],
    tris: &[[u32; 3]],
    leaflet: &[u16],
    sutured: &[bool],
) -> (Vec<(u32, u32)>, Vec<(u32, u32)>) {
    let strip = |t: &[u32; 3]| t.iter().any(|&k| sutured[k as usize]);
    let bvh = Bvh::build(v, tris);
    let mut out = Vec::new();
    let mut sewn = Vec::new();
    for (i, ti) in tris.iter().enumerate() {
        let a = ti.map(|k| &v[k as usize]);
        if is_degenerate(a[0], a[1], a[2]) {
            continue;
        }
        bvh.query_aabb(&Aabb::of_triangle(a[0], a[1], a[2]), |j| {
            let j = j as usize;
            if j <= i || leaflet[j] == leaflet[i] {
                return;
            }
            let b = tris[j].map(|k| &v[k as usize]);
            if tri_tri_intersect(a, b) {
                if strip(ti) && strip(&tris[j]) {
                    sewn.push((i as u32, j as u32));
                } else {
                    out.push((i as u32, j as u32));
                }
            }
        });
    }
    out.sort_unstable();
    sewn.sort_unstable();
    (out, sewn)
}

/// Leaflet triangles (index) crossing a surface triangle (index), suture
/// strip exempt (see the module comment).
pub fn wall_pairs(
    x: &[Point3],
    tris: &[[u32; 3]],
    sutured: &[bool],
    wall_x: &[Point3],
    wall_tris: &[[u32; 3]],
) -> Vec<(u32, u32)> {
    let wv: Vec<V3> = wall_x.iter().map(|p| p.coords).collect();
    let bvh = Bvh::build(&wv, wall_tris);
    let mut out = Vec::new();
    for (i, ti) in tris.iter().enumerate() {
        if ti.iter().any(|&k| sutured[k as usize]) {
            continue;
        }
        let a = ti.map(|k| x[k as usize].coords);
        let a = [&a[0], &a[1], &a[2]];
        if is_degenerate(a[0], a[1], a[2]) {
            continue;
        }
        let mut hits = Vec::new();
        bvh.query_aabb(&Aabb::of_triangle(a[0], a[1], a[2]), |j| {
            let b = wall_tris[j as usize].map(|k| &wv[k as usize]);
            if tri_tri_intersect(a, b) {
                hits.push(j);
            }
        });
        hits.sort_unstable();
        out.extend(hits.into_iter().map(|j| (i as u32, j)));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64, z: f64) -> Point3 {
        Point3::new(x, y, z)
    }

    #[test]
    fn two_leaflets_through_each_other_are_detected() {
        // Two unit squares (two triangles each) crossing at right angles.
        let x = vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(1.0, 1.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(0.5, 0.5, -0.5),
            p(0.5, 0.5, 0.5),
            p(0.5, -0.5, 0.5),
            p(0.5, -0.5, -0.5),
        ];
        let tris = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
        let (pairs, sewn) = leaflet_pairs(&x, &tris, &[1, 1, 2, 2], &[false; 8]);
        assert!(sewn.is_empty());
        assert!(!pairs.is_empty());
        assert!(pairs.iter().all(|&(i, j)| i < 2 && j >= 2));
        // The same bodies apart along z do not cross.
        let far: Vec<Point3> = x
            .iter()
            .enumerate()
            .map(|(k, q)| {
                if k >= 4 {
                    q + V3::new(0.0, 0.0, 2.0)
                } else {
                    *q
                }
            })
            .collect();
        assert!(
            leaflet_pairs(&far, &tris, &[1, 1, 2, 2], &[false; 8])
                .0
                .is_empty()
        );
        // Sutured vertices on one side only: still a crossing.
        let one = [true, true, false, false, false, false, false, false];
        assert!(!leaflet_pairs(&x, &tris, &[1, 1, 2, 2], &one).0.is_empty());
    }

    #[test]
    fn strips_sewn_to_one_post_touch_but_a_strip_across_a_belly_crosses() {
        // Two leaflets sewn along the same post (the z axis from 0 to 1),
        // opening to either side: strip against strip, not a crossing.
        let x = vec![
            p(0.0, 0.0, 0.0),
            p(0.0, 0.0, 1.0),
            p(1.0, 0.0, 0.5),
            p(0.0, 0.0, 0.0),
            p(0.0, 0.0, 1.0),
            p(-1.0, 0.2, 0.5),
        ];
        let tris = vec![[0, 1, 2], [3, 4, 5]];
        let sut = [true, true, false, true, true, false];
        assert_eq!(
            leaflet_pairs(&x, &tris, &[1, 2], &sut),
            (vec![], vec![(0, 1)])
        );
        // The second leaflet's strip folded across the first one's belly
        // (the first triangle is no strip triangle now).
        let mut y = x.clone();
        y[5] = p(1.0, 0.5, -0.5);
        y[3] = p(0.5, -0.5, 0.5);
        y[4] = p(0.5, 0.5, 0.8);
        let unsewn = [false, false, false, true, true, false];
        let (got, sewn) = leaflet_pairs(&y, &tris, &[1, 2], &unsewn);
        assert_eq!((got, sewn), (vec![(0, 1)], vec![]));
    }

    #[test]
    fn wall_check_exempts_the_suture_strip_only() {
        // Wall: the plane z = 0 (two triangles). Leaflet: a strip standing on it.
        let wall = vec![
            p(-5.0, -5.0, 0.0),
            p(5.0, -5.0, 0.0),
            p(5.0, 5.0, 0.0),
            p(-5.0, 5.0, 0.0),
        ];
        let wt = vec![[0, 1, 2], [0, 2, 3]];
        let x = vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(0.0, 0.0, 1.0),
            p(1.0, 0.0, 1.0),
            p(0.0, 0.0, 2.0),
            p(1.0, 0.0, 2.0),
        ];
        let tris = vec![[0, 1, 2], [1, 3, 2], [2, 3, 4], [3, 5, 4]];
        let sut = [true, true, false, false, false, false];
        assert!(wall_pairs(&x, &tris, &sut, &wall, &wt).is_empty());
        // Fold the top row back through the wall: a free triangle crosses.
        let mut y = x.clone();
        y[5] = p(1.0, 0.0, -1.0);
        let got = wall_pairs(&y, &tris, &sut, &wall, &wt);
        assert!(!got.is_empty() && got.iter().all(|&(i, _)| i == 3));
        // Without the exemption the sutured triangle counts too.
        let got = wall_pairs(&x, &tris, &[false; 6], &wall, &wt);
        assert!(got.iter().any(|&(i, _)| i == 0));
    }
}
