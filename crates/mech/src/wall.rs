//! The aortic wall as the mechanics sees it: the surface the suture line
//! is sewn to (its tangent planes turn the sutured triangles, `suture.rs`)
//! and the one the leaflets may not pass (`contact/wall_barrier.rs`).

use super::element::V3;
use coapt_geom::bvh::Bvh;
use coapt_geom::closest_point::closest_point;

/// Radius (mm) of the wall patch whose normals a mesh wall's normal at a
/// point averages: a segmented wall is bumpy at the triangle scale.
pub const NORMAL_RADIUS_MM: f64 = 1.0;

#[derive(Clone)]
pub enum Wall {
    /// Inside of the cylinder of `radius` about the line through `origin`
    /// along `dir` (unit): benchmarks and tests.
    Cylinder { origin: V3, dir: V3, radius: f64 },
    /// Wall triangles and their tree (aorta.vtp's wall).
    Mesh {
        x: Vec<V3>,
        tris: Vec<[u32; 3]>,
        bvh: Bvh,
    },
}

impl Wall {
    pub fn mesh(x: Vec<V3>, tris: Vec<[u32; 3]>) -> Wall {
        let bvh = Bvh::build(&x, &tris);
        Wall::Mesh { x, tris, bvh }
    }

    /// The vector from the line through `origin` along `dir` (unit) to `p`,
    /// perpendicular to it.
    pub fn radial(origin: &V3, dir: &V3, p: &V3) -> V3 {
        let d = p - origin;
        d - dir * d.dot(dir)
    }

    /// A unit normal of the wall near `p` (either orientation): the
    /// cylinder's radial direction, or the area-weighted normals of the
    /// mesh triangles within [`NORMAL_RADIUS_MM`] of `p` (four times wider
    /// each time none is found, eight times at most).
    pub fn normal(&self, p: &V3) -> Option<V3> {
        match self {
            Wall::Cylinder { origin, dir, .. } => {
                let r = Wall::radial(origin, dir, p);
                (r.norm() > 0.0).then(|| r.normalize())
            }
            Wall::Mesh { x, tris, bvh } => {
                let mut r = NORMAL_RADIUS_MM;
                for _ in 0..8 {
                    let mut acc = V3::zeros();
                    bvh.query_sphere(p, r, |t| {
                        let [a, b, c] = tris[t as usize].map(|i| x[i as usize]);
                        let d = (closest_point(p, &a, &b, &c).point - p).norm();
                        if d <= r {
                            acc += (b - a).cross(&(c - a)) * (1.0 - d / r);
                        }
                    });
                    if acc.norm() > 0.0 {
                        return Some(acc.normalize());
                    }
                    r *= 4.0;
                }
                None
            }
        }
    }
}
