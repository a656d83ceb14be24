//! What the interactive view shows: the closed leaflets with each node's
//! leaflet and contact class, and the part of the aortic wall around them,
//! all in the valve frame (e1 towards C1, e2 = axis × e1, axis up; mm).

use crate::ClosedValve;
use crate::figures::palette::{node_classes, node_leaflets};
use coapt_geom::{Point3, TriMesh, ValveFrame};

/// The wall is kept from this far below the lowest leaflet point to this
/// far above the highest leaflet point or commissure: the root the valve
/// sits in, without the arch or the ventricle the segmentation may reach.
pub const WALL_MARGIN_MM: f64 = 5.0;
/// … and out to this multiple of the commissures' largest distance from
/// the axis: the sinuses bulge past the commissures, side branches and
/// neighbouring structures lie further out.
pub const WALL_RADIUS_FACTOR: f64 = 1.6;

/// One triangle mesh, every vertex used by a triangle.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// Valve-frame positions, mm.
    pub positions: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

/// How the wall was cut down to the root (valve frame, mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crop {
    pub height_min: f64,
    pub height_max: f64,
    pub radius_max: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    pub leaflets: Part,
    /// Per leaflet vertex: its leaflet (0..7) × 4 + its contact class
    /// (0 none, 1 one other leaflet, 2 both others), as in the static views.
    pub codes: Vec<u8>,
    pub leaflet_count: usize,
    pub wall: Option<(Part, Crop)>,
}

/// The scene of `v` coloured by the per-node contact bitmask `contact`,
/// with `wall` (aorta.vtp) cropped to the root. `None` when no leaflet
/// triangle has valid indices and finite valve-frame corners.
pub fn build(v: &ClosedValve, contact: &[u8], wall: Option<&TriMesh>) -> Option<Scene> {
    let f = &v.frame;
    let local: Vec<Option<[f64; 3]>> = v.x.iter().map(|p| to_frame(f, p)).collect();
    let (leaflets, kept) = compact(&local, &v.tris, |_| true);
    if leaflets.triangles.is_empty() {
        return None;
    }
    let leaflet = node_leaflets(v.x.len(), &v.tris, &v.tri_leaflet);
    let classes = node_classes(contact, &leaflet);
    let codes = kept
        .iter()
        .map(|&i| {
            let l = leaflet[i as usize].unwrap_or(0).min(7) as u8;
            l * 4 + classes[i as usize] as u8
        })
        .collect();
    let leaflet_count = v.leaflet_count().clamp(1, 8);
    let wall = wall.and_then(|w| crop_wall(f, &leaflets, w));
    Some(Scene {
        leaflets,
        codes,
        leaflet_count,
        wall,
    })
}

fn to_frame(f: &ValveFrame, p: &Point3) -> Option<[f64; 3]> {
    let l = f.to_local(p);
    let q = [l.x, l.y, l.z];
    q.iter().all(|c| c.is_finite()).then_some(q)
}

/// The triangles of `tris` with valid, finite corners that `keep` accepts,
/// over only the vertices they use (in first-use order, so the same input
/// gives the same numbering); with the old index of each new vertex.
fn compact(
    local: &[Option<[f64; 3]>],
    tris: &[[u32; 3]],
    keep: impl Fn(&[[f64; 3]; 3]) -> bool,
) -> (Part, Vec<u32>) {
    let mut new_of = vec![u32::MAX; local.len()];
    let mut old = Vec::new();
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for t in tris {
        let corners = t.map(|i| local.get(i as usize).copied().flatten());
        let [Some(a), Some(b), Some(c)] = corners else {
            continue;
        };
        if !keep(&[a, b, c]) {
            continue;
        }
        triangles.push(t.map(|i| {
            let slot = &mut new_of[i as usize];
            if *slot == u32::MAX {
                *slot = old.len() as u32;
                old.push(i);
                positions.push(local[i as usize].expect("checked finite"));
            }
            *slot
        }));
    }
    (
        Part {
            positions,
            triangles,
        },
        old,
    )
}

/// The wall triangles (region 0 when the surface labels its caps) with all
/// three corners inside the root's slab and cylinder; `None` when none are.
fn crop_wall(f: &ValveFrame, leaflets: &Part, w: &TriMesh) -> Option<(Part, Crop)> {
    let heights = leaflets.positions.iter().map(|p| p[2]);
    let lo = heights.clone().fold(f64::INFINITY, f64::min);
    let comm: Vec<[f64; 3]> = f
        .commissures_mm
        .iter()
        .filter_map(|c| to_frame(f, c))
        .collect();
    let hi = heights
        .chain(comm.iter().map(|c| c[2]))
        .fold(f64::NEG_INFINITY, f64::max);
    let reach = comm
        .iter()
        .map(|c| c[0].hypot(c[1]))
        .chain(leaflets.positions.iter().map(|p| p[0].hypot(p[1])))
        .fold(0.0, f64::max);
    let crop = Crop {
        height_min: lo - WALL_MARGIN_MM,
        height_max: hi + WALL_MARGIN_MM,
        radius_max: WALL_RADIUS_FACTOR * reach,
    };
    let tris = w.wall_triangles();
    let local: Vec<Option<[f64; 3]>> = w.vertices.iter().map(|p| to_frame(f, p)).collect();
    let inside = |p: &[f64; 3]| {
        (crop.height_min..=crop.height_max).contains(&p[2]) && p[0].hypot(p[1]) <= crop.radius_max
    };
    let (part, _) = compact(&local, &tris, |c| c.iter().all(inside));
    (!part.triangles.is_empty()).then_some((part, crop))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::figures::test_valve::synthetic_valve;
    use coapt_geom::Vector3;

    /// A cylinder about the valve axis from −10 to +30 mm, radius 14 mm,
    /// with a cap (region 1) at the bottom.
    pub(crate) fn tube(v: &ClosedValve) -> TriMesh {
        let f = &v.frame;
        let (n, rings) = (24, 21);
        let mut m = TriMesh::default();
        for k in 0..rings {
            for j in 0..n {
                let a = j as f64 * std::f64::consts::TAU / n as f64;
                m.vertices.push(f.from_local(&Vector3::new(
                    14.0 * a.cos(),
                    14.0 * a.sin(),
                    -10.0 + 2.0 * k as f64,
                )));
            }
        }
        let id = |k: usize, j: usize| (k * n + j % n) as u32;
        for k in 0..rings - 1 {
            for j in 0..n {
                m.triangles.push([id(k, j), id(k, j + 1), id(k + 1, j)]);
                m.triangles
                    .push([id(k, j + 1), id(k + 1, j + 1), id(k + 1, j)]);
            }
        }
        let walls = m.triangles.len();
        m.vertices.push(f.origin_mm - f.axis * 10.0);
        let c = (m.vertices.len() - 1) as u32;
        for j in 0..n {
            m.triangles.push([c, id(0, j + 1), id(0, j)]);
        }
        let mut region = vec![0.0; walls];
        region.resize(m.triangles.len(), 1.0);
        m.cell_data
            .insert(coapt_geom::DataArray::scalars_f64("region", region));
        m
    }

    #[test]
    fn leaflets_keep_every_valid_triangle_in_the_valve_frame() {
        let (v, contact) = synthetic_valve(8);
        let s = build(&v, &contact, None).unwrap();
        assert_eq!(s.leaflets.triangles.len(), v.tris.len());
        assert_eq!(s.codes.len(), s.leaflets.positions.len());
        for (k, t) in s.leaflets.triangles.iter().enumerate() {
            for (c, &i) in t.iter().enumerate() {
                let p = s.leaflets.positions[i as usize];
                let q = v.frame.to_local(&v.x[v.tris[k][c] as usize]);
                assert_eq!(p, [q.x, q.y, q.z]);
                assert_eq!(s.codes[i as usize] / 4, v.tri_leaflet[k]);
            }
        }
        // Each contact class occurs: the synthetic valve has all three.
        for class in 0..3 {
            assert!(s.codes.iter().any(|c| c % 4 == class), "class {class}");
        }
        assert!(s.codes.iter().all(|c| c % 4 < 3));
    }

    #[test]
    fn bad_triangles_and_unused_nodes_are_dropped() {
        let (mut v, contact) = synthetic_valve(6);
        let n = v.tris.len();
        v.tris.push([0, 1, 99_999]);
        v.x.push(Point3::new(1e9, 0.0, 0.0));
        let k = v.tris[3][0] as usize;
        v.x[k] = Point3::new(f64::NAN, 0.0, 0.0);
        let s = build(&v, &contact, None).unwrap();
        let uses_k = v.tris[..n]
            .iter()
            .filter(|t| t.contains(&(k as u32)))
            .count();
        assert_eq!(s.leaflets.triangles.len(), n - uses_k);
        assert!(s.leaflets.positions.iter().all(|p| p[0].abs() < 1e3));
        v.x.iter_mut().for_each(|p| p.y = f64::INFINITY);
        assert!(build(&v, &contact, None).is_none());
    }

    #[test]
    fn the_wall_is_cropped_to_the_root_and_loses_its_caps() {
        let (v, contact) = synthetic_valve(8);
        let w = tube(&v);
        let s = build(&v, &contact, Some(&w)).unwrap();
        let (wall, crop) = s.wall.unwrap();
        assert!(
            crop.height_min > -10.0 && crop.height_max < 30.0,
            "{crop:?}"
        );
        assert!(!wall.triangles.is_empty());
        for p in &wall.positions {
            assert!((crop.height_min..=crop.height_max).contains(&p[2]));
            assert!((p[0].hypot(p[1]) - 14.0).abs() < 1e-9, "a cap vertex {p:?}");
        }
        // Fewer rings than the tube: the slab cut it.
        assert!(wall.triangles.len() < 20 * 24 * 2);
        // A wall far from the valve leaves nothing to show.
        let mut far = w.clone();
        far.vertices.iter_mut().for_each(|p| p.z += 500.0);
        assert!(build(&v, &contact, Some(&far)).unwrap().wall.is_none());
    }
}
