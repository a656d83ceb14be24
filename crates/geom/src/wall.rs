//! The aortic wall as a ray-castable, point-projectable BVH (parry3d, whose
//! vectors are glam's; conversion stays in this module): where the valve
//! stage casts its suture paths and the leaflet stage projects placed nodes
//! back inside. The mechanics keeps its own view of the wall (closest
//! points and averaged normals, `mech::wall`).

use parry3d_f64::math::Vector as GVec;
use parry3d_f64::query::{PointQuery, Ray, RayCast};
use parry3d_f64::shape::{FeatureId, TriMesh as PTriMesh};

use crate::{Point3, TriMesh, Vector3};

pub struct Wall {
    bvh: PTriMesh,
    /// Unit normal of each input triangle (orientation as given).
    normals: Vec<Vector3>,
    /// `region` cell data when present (0 wall, 1 VAJ cap, 2 top cap).
    region: Option<Vec<i64>>,
    /// The wall proper without the caps, when regions say which is which:
    /// suture paths run at the annulus, right at the VAJ cap's rim, and a
    /// segmented cap on a tilted valve is a voxel staircase that a radial ray
    /// would hit inside the lumen.
    wall_only: Option<PTriMesh>,
}

fn g(p: &Point3) -> GVec {
    GVec::new(p.x, p.y, p.z)
}

fn n(v: GVec) -> Point3 {
    Point3::new(v.x, v.y, v.z)
}

impl Wall {
    pub fn new(mesh: &TriMesh) -> Result<Wall, String> {
        let verts = mesh.vertices.iter().map(g).collect();
        let bvh = PTriMesh::new(verts, mesh.triangles.clone())
            .map_err(|e| format!("surface cannot be indexed: {e}"))?;
        let region = mesh
            .cell_data
            .get("region")
            .and_then(|a| a.values.to_f64())
            .map(|v| v.into_iter().map(|x| x as i64).collect::<Vec<i64>>());
        let wall_only = match &region {
            Some(r) if r.len() == mesh.triangles.len() && r.iter().any(|&x| x != 0) => {
                let tris: Vec<[u32; 3]> = mesh
                    .triangles
                    .iter()
                    .zip(r)
                    .filter(|(_, x)| **x == 0)
                    .map(|(t, _)| *t)
                    .collect();
                if tris.is_empty() {
                    None
                } else {
                    let verts = mesh.vertices.iter().map(g).collect();
                    Some(
                        PTriMesh::new(verts, tris)
                            .map_err(|e| format!("surface wall cannot be indexed: {e}"))?,
                    )
                }
            }
            _ => None,
        };
        let normals = (0..mesh.triangles.len())
            .map(|t| {
                let p = mesh.corners(t);
                let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
                let l = n.norm();
                if l > 0.0 { n / l } else { n }
            })
            .collect();
        Ok(Wall {
            bvh,
            normals,
            region,
            wall_only,
        })
    }

    /// Closest surface point and whether it lies on the wall proper (not a cap).
    pub fn closest(&self, p: &Point3) -> (Point3, bool) {
        let (proj, feat) = self.bvh.project_local_point_and_get_feature(g(p));
        let on_wall = match (&self.region, feat) {
            (Some(r), FeatureId::Face(f)) => r.get(f as usize % r.len().max(1)).copied() == Some(0),
            _ => true,
        };
        (n(proj.point), on_wall)
    }

    /// Every crossing of the ray o + t·d (d unit), up to `max_t`, nearest first.
    pub fn hits(&self, o: &Point3, d: &Vector3, max_t: f64) -> Vec<f64> {
        crossings(&self.bvh, o, d, max_t)
    }

    /// The nearest crossing of the ray o + t·d (d unit) up to `max_t`: its
    /// distance, the crossed triangle's unit normal and whether that triangle
    /// is wall proper (not a cap). A ray along a mesh edge that slips
    /// between two triangles is nudged by a microradian.
    pub fn first_crossing(&self, o: &Point3, d: &Vector3, max_t: f64) -> Option<Crossing> {
        let side = d.cross(&Vector3::new(0.3, 0.5, 0.8)).normalize();
        for nudge in [0.0, 1e-6, -1e-6, 3e-6] {
            let dir = (d + side * nudge).normalize();
            let ray = Ray::new(g(o), GVec::new(dir.x, dir.y, dir.z));
            if let Some(hit) = self.bvh.cast_local_ray_and_get_normal(&ray, max_t, false) {
                let nt = self.normals.len().max(1);
                // The crossed triangle of the mesh (its own normal and
                // region, whichever side the ray came from).
                let t = hit.subshape as usize % nt;
                let on_wall = self
                    .region
                    .as_ref()
                    .is_none_or(|r| r.get(t).copied() == Some(0));
                let normal = self
                    .normals
                    .get(t)
                    .copied()
                    .unwrap_or_else(|| Vector3::new(hit.normal.x, hit.normal.y, hit.normal.z));
                return Some(Crossing {
                    t: hit.time_of_impact,
                    normal,
                    on_wall,
                });
            }
        }
        None
    }

    /// Whether `p` lies inside the closed surface: the parity of the
    /// crossings of three rays, by majority (a ray along an edge or
    /// through a vertex can count one crossing twice or none).
    pub fn contains(&self, p: &Point3) -> bool {
        let dirs = [
            Vector3::new(0.5773, 0.5774, 0.5774),
            Vector3::new(-0.6, 0.48, -0.64),
            Vector3::new(0.28, -0.96, 0.0),
        ];
        let inside = dirs
            .iter()
            .filter(|d| {
                let d = d.normalize();
                let mut n = 0usize;
                let mut start = 0.0;
                let dir = GVec::new(d.x, d.y, d.z);
                while n < 10_000 {
                    let ray = Ray::new(g(&(p + d * start)), dir);
                    match self.bvh.cast_local_ray(&ray, f64::MAX, false) {
                        Some(t) => {
                            n += 1;
                            start += t + 1e-7;
                        }
                        None => break,
                    }
                }
                n % 2 == 1
            })
            .count();
        inside >= 2
    }

    /// Where a ray from inside the lumen leaves it for good: crossings come
    /// in exit/entry pairs, and an exit followed within `CLEFT_MM` by a
    /// re-entry is a cleft in the lumen (a segmentation leaves the native
    /// cusps out: on a diastolic CT they cut thin slits up from the
    /// annulus), not the wall.
    pub fn lumen_exit(&self, o: &Point3, d: &Vector3, max_t: f64) -> Option<Crossing> {
        let mut start = 0.0;
        for _ in 0..8 {
            let exit = self.first_crossing(&(o + d * start), d, max_t - start)?;
            let t_exit = start + exit.t;
            match self.first_crossing(&(o + d * (t_exit + 1e-6)), d, CLEFT_MM) {
                Some(entry) => start = t_exit + 1e-6 + entry.t + 1e-6,
                None => return Some(Crossing { t: t_exit, ..exit }),
            }
        }
        None
    }

    /// Radial projection: the crossing of the ray nearest to `r_expect`,
    /// on the wall proper when the ray meets it. Below the wall's lower rim
    /// (the nadirs sit at the annulus, right where the VAJ cap cuts the
    /// lumen) a cap crossing still serves when it lies within 1 mm of the
    /// wall, where the cap meets it; a cap crossing deep inside the
    /// lumen (a segmented cap on a tilted valve is a voxel staircase that can
    /// bulge past the annulus level) is refused for the closest wall point.
    pub fn radial(&self, o: &Point3, d: &Vector3, r_expect: f64) -> Point3 {
        let max_t = 20.0 * r_expect.max(1.0);
        let nearest = |hits: &[f64]| {
            hits.iter()
                .copied()
                .min_by(|a, b| (a - r_expect).abs().total_cmp(&(b - r_expect).abs()))
        };
        let cast = |mesh: &PTriMesh| {
            let hits = crossings(mesh, o, d, max_t);
            if hits.is_empty() {
                // A ray along a mesh edge can slip through: nudge it.
                let side = d.cross(&Vector3::new(0.3, 0.5, 0.8)).normalize() * 1e-6;
                crossings(mesh, o, &(d + side).normalize(), max_t)
            } else {
                hits
            }
        };
        // Without region labels the whole surface counts as wall.
        let wall = self.wall_only.as_ref().unwrap_or(&self.bvh);
        if let Some(t) = nearest(&cast(wall)) {
            return o + d * t;
        }
        let on_rim = |t: &f64| {
            let p = o + d * *t;
            (n(wall.project_local_point(g(&p), true).point) - p).norm() <= CAP_HIT_NEAR_WALL_MM
        };
        let caps = self.wall_only.as_ref().map(|_| &self.bvh);
        match caps.and_then(|all| nearest(&cast(all))).filter(on_rim) {
            Some(t) => o + d * t,
            None => n(wall.project_local_point(g(&(o + d * r_expect)), true).point),
        }
    }
}

/// Largest gap (mm) in the lumen along a ray that counts as a cleft.
pub const CLEFT_MM: f64 = 4.0;

/// One ray crossing of the surface.
#[derive(Debug, Clone, Copy)]
pub struct Crossing {
    pub t: f64,
    pub normal: Vector3,
    pub on_wall: bool,
}

/// A cap crossing this close to the wall (mm) is where the cap meets the
/// wall, at the rim; farther in, it is a step of the cap inside the lumen.
const CAP_HIT_NEAR_WALL_MM: f64 = 1.0;

fn crossings(bvh: &PTriMesh, o: &Point3, d: &Vector3, max_t: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let mut start = 0.0;
    let dir = GVec::new(d.x, d.y, d.z);
    while out.len() < 6 {
        let ray = Ray::new(g(&(o + d * start)), dir);
        match bvh.cast_local_ray(&ray, max_t - start, false) {
            Some(t) => {
                out.push(start + t);
                start += t + 1e-6;
            }
            None => break,
        }
    }
    out
}
