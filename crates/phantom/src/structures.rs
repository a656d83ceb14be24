//! Inside tests of the phantom's neighbouring structures (LV, PA, LA, DA,
//! spine), for checking that a segmentation of the aorta never leaks into
//! them. Reuses the scene's analytic shapes; the phantom's own outputs are
//! untouched.

use super::PhantomParams;
use super::anatomy::Anatomy;
use super::shapes::Sdf;
use coapt_base::Result;
use coapt_geom::{Point3, Volume};

/// A structure next to the aortic root.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Structure {
    /// Left-ventricular cavity (the ellipsoid the LVOT opens into).
    Lv,
    /// Pulmonary trunk and branches (lumen).
    Pa,
    /// Left atrium (lumen).
    La,
    /// Descending aorta (lumen).
    Da,
    /// Vertebral column and posterior arch.
    Spine,
}

impl Structure {
    pub const ALL: [Structure; 5] = [
        Structure::Lv,
        Structure::Pa,
        Structure::La,
        Structure::Da,
        Structure::Spine,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Structure::Lv => "LV",
            Structure::Pa => "PA",
            Structure::La => "LA",
            Structure::Da => "DA",
            Structure::Spine => "spine",
        }
    }
}

/// The anatomy of a phantom, rebuilt from its parameters (same seed, tilt
/// and field of view give the same shapes as `generate`).
pub struct Structures {
    an: Anatomy,
}

/// Radius of the posterior arch and the gap to the canal, as in the scene.
const ARCH_RADIUS_MM: f64 = 12.0;
const CANAL_RADIUS_MM: f64 = 8.0;

impl Structures {
    pub fn new(params: &PhantomParams) -> Result<Self> {
        let (dims, spacing) = params.grid_shape();
        let fov = [0, 1, 2].map(|a| dims[a] as f64 * spacing[a]);
        let (an, _) = Anatomy::new(params.seed, params.tilt_rad, fov, params.extras())?;
        Ok(Structures { an })
    }

    /// Is `p` (LPS mm) inside structure `s`?
    pub fn contains(&self, s: Structure, p: &Point3) -> bool {
        let an = &self.an;
        match s {
            Structure::Lv => an.lv.eval(p).0 < 0.0,
            Structure::Pa => an.pa.iter().any(|t| t.eval(p).0 < 0.0),
            Structure::La => an.la.eval(p).0 < 0.0,
            Structure::Da => an.da.eval(p).0 < 0.0,
            Structure::Spine => {
                let [vx, vy] = an.spine_centre;
                let rv = an.vertebra_radius_mm;
                let canal_y = vy + rv + CANAL_RADIUS_MM + 1.0;
                (p.x - vx).hypot(p.y - vy) < rv || (p.x - vx).hypot(p.y - canal_y) < ARCH_RADIUS_MM
            }
        }
    }

    /// Rasterise structure `s` at the voxel centres of `grid` (uint8 0/1).
    pub fn rasterise<T: Clone>(&self, s: Structure, grid: &Volume<T>) -> Volume<u8> {
        let [ni, nj, nk] = grid.dims();
        let mut out = Vec::with_capacity(ni * nj * nk);
        for k in 0..nk {
            for j in 0..nj {
                for i in 0..ni {
                    let p = grid.index_to_world([i as f64, j as f64, k as f64]);
                    out.push(self.contains(s, &p) as u8);
                }
            }
        }
        Volume::from_fortran_vec([ni, nj, nk], *grid.affine(), out).expect("same grid")
    }
}
