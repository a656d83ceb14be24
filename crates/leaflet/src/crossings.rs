//! The crossing section of leaflets.json: the placed leaflets' crossings
//! by the rule of [`coapt_geom::crossings`], grouped by where they are.

use coapt_geom::crossings::{RULE, leaflet_pairs, wall_pairs};
use coapt_geom::{Point3, TriMesh};
use serde_json::{Value as Json, json};
use std::collections::BTreeMap;

/// Crossing counts for leaflets.json, grouped by leaflet pair (or leaflet
/// and wall) and nearest commissure; `warning` is set when any exist.
/// `commissures[k]` is where suture path k starts (leaflets k and k − 1
/// meet there).
pub fn summary(
    leaflets: &TriMesh,
    leaflet: &[u16],
    sutured: &[bool],
    surface: &TriMesh,
    commissures: &[Point3],
) -> Json {
    let x = &leaflets.vertices;
    let tris = &leaflets.triangles;
    let (ll, sewn) = leaflet_pairs(x, tris, leaflet, sutured);
    let lw = wall_pairs(x, tris, sutured, &surface.vertices, &surface.triangles);
    let centroid = |t: &[u32; 3], v: &[Point3]| {
        Point3::from(
            (v[t[0] as usize].coords + v[t[1] as usize].coords + v[t[2] as usize].coords) / 3.0,
        )
    };
    let nearest = |p: &Point3| {
        commissures
            .iter()
            .enumerate()
            .map(|(k, c)| (k + 1, (p - c).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((0, f64::NAN))
    };
    // (sewn, a, b, commissure) → (pairs, max distance to the commissure);
    // b = 0 is the wall.
    let mut groups: BTreeMap<(bool, u16, u16, usize), (usize, f64)> = BTreeMap::new();
    let mut add = |key: (bool, u16, u16), p: Point3| {
        let (c, d) = nearest(&p);
        let e = groups.entry((key.0, key.1, key.2, c)).or_insert((0, 0.0));
        e.0 += 1;
        e.1 = e.1.max(d);
    };
    for (is_sewn, list) in [(false, &ll), (true, &sewn)] {
        for &(i, j) in list {
            let (ti, tj) = (&tris[i as usize], &tris[j as usize]);
            let p = Point3::from((centroid(ti, x).coords + centroid(tj, x).coords) / 2.0);
            let (a, b) = (leaflet[i as usize], leaflet[j as usize]);
            add((is_sewn, a.min(b), a.max(b)), p);
        }
    }
    for &(i, _) in &lw {
        add(
            (false, leaflet[i as usize], 0),
            centroid(&tris[i as usize], x),
        );
    }
    let mut wall_tris: Vec<u32> = lw.iter().map(|p| p.0).collect();
    wall_tris.dedup();
    let places: Vec<Json> = groups
        .iter()
        .map(|(&(is_sewn, a, b, c), &(n, d))| {
            json!({
                "kind": if is_sewn { "sewn" } else { "crossing" },
                "between": if b == 0 { json!([a, "wall"]) } else { json!([a, b]) },
                "pairs": n,
                "nearest_commissure": c,
                "max_distance_to_commissure_mm": d,
            })
        })
        .collect();
    let mut out = json!({
        "rule": RULE,
        "leaflet_leaflet_pairs": ll.len(),
        "sewn_contacts": sewn.len(),
        "leaflet_wall_pairs": lw.len(),
        "leaflet_triangles_crossing_wall": wall_tris.len(),
        "where": places,
    });
    if !ll.is_empty() || !lw.is_empty() {
        out["warning"] = json!(format!(
            "placed leaflets cross: {} leaflet-leaflet and {} leaflet-wall triangle pairs \
             (leaflets.json crossings.where says where); contact in `close` starts from an \
             interpenetrating state there",
            ll.len(),
            lw.len()
        ));
    }
    out
}
