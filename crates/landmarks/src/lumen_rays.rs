//! Rays through the lumen mask: where a ray from inside first leaves it.
//!
//! The mask is read with trilinear interpolation and the wall is its 0.5
//! level, the level the surface stage's marching cubes meshes, so a hit
//! here lies on the wall `valve` snaps to (within the surface's smoothing).

use coapt_geom::{Point3, Vector3, Volume};

/// Step along a ray (mm): a tenth of the finest voxel the segment stage
/// writes (0.5 mm) would be 0.05; the linear interpolation between the
/// two samples that straddle the 0.5 level makes 0.1 mm exact enough.
const STEP_MM: f64 = 0.1;

/// A binary mask sampled in world millimetres.
pub struct LumenProbe<'a> {
    mask: &'a Volume<u8>,
}

impl<'a> LumenProbe<'a> {
    pub fn new(mask: &'a Volume<u8>) -> Self {
        Self { mask }
    }

    /// Trilinear value of the mask (0 outside, 1 inside) at `p`; 0 beyond
    /// the grid.
    pub fn value(&self, p: &Point3) -> f64 {
        let q = self.mask.world_to_index(p);
        let d = self.mask.dims();
        let base = q.map(|x| x.floor());
        let f = [q[0] - base[0], q[1] - base[1], q[2] - base[2]];
        let mut v = 0.0;
        for corner in 0..8usize {
            let off = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            let mut w = 1.0;
            let mut idx = [0usize; 3];
            let mut inside = true;
            for a in 0..3 {
                let i = base[a] + off[a] as f64;
                w *= if off[a] == 1 { f[a] } else { 1.0 - f[a] };
                if !(i >= 0.0 && i < d[a] as f64) {
                    inside = false;
                    break;
                }
                idx[a] = i as usize;
            }
            if inside && w > 0.0 && self.mask[[idx[0], idx[1], idx[2]]] > 0 {
                v += w;
            }
        }
        v
    }

    /// Distance (mm) from `from` along the unit `dir` to where the mask
    /// first falls below 0.5, searched up to `reach` mm; `None` when `from`
    /// is outside the lumen or the ray never leaves it.
    pub fn exit(&self, from: &Point3, dir: &Vector3, reach: f64) -> Option<f64> {
        let mut prev = self.value(from);
        if prev < 0.5 {
            return None;
        }
        let n = (reach / STEP_MM).ceil() as usize;
        for s in 1..=n {
            let t = s as f64 * STEP_MM;
            let v = self.value(&(from + dir * t));
            if v < 0.5 {
                return Some(t - STEP_MM + STEP_MM * (prev - 0.5) / (prev - v));
            }
            prev = v;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use coapt_geom::Matrix4;

    /// A ball of radius 10 mm on a 0.5 mm grid: rays from its centre leave
    /// it at 10 mm within the half-voxel the 0.5 level allows.
    #[test]
    fn exit_of_a_ball_is_its_radius() {
        let n = 60;
        let mut aff = Matrix4::identity();
        for a in 0..3 {
            aff[(a, a)] = 0.5;
            aff[(a, 3)] = -15.0;
        }
        let mut v = Volume::filled([n, n, n], aff, 0u8).unwrap();
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let p = v.index_to_world([i as f64, j as f64, k as f64]);
                    if p.coords.norm() < 10.0 {
                        v[[i, j, k]] = 1;
                    }
                }
            }
        }
        let probe = LumenProbe::new(&v);
        for d in [
            Vector3::x(),
            -Vector3::y(),
            Vector3::new(1.0, 1.0, 1.0).normalize(),
        ] {
            let r = probe.exit(&Point3::origin(), &d, 30.0).unwrap();
            assert!((r - 10.0).abs() < 0.3, "{r}");
        }
        assert!(
            probe
                .exit(&Point3::new(20.0, 0.0, 0.0), &Vector3::x(), 5.0)
                .is_none()
        );
    }
}
