//! The native cusps filled into the root.
//!
//! In a diastolic scan the closed native cusps are thin dark sheets (a "Y"
//! seen from above) inside the contrast-filled root. The threshold leaves
//! them out, so the lumen's surface gets internal sheets and tunnels (Euler
//! characteristic −4 on the real CT). The valve needs the root *wall*: the
//! mask must hold everything inside it. A closing with a ball wider than
//! the sheets fills them; it acts only in the root (from the VAJ plane to
//! just above the commissures, near the root's axis), so nothing outside
//! the root is bridged.

use rayon::prelude::*;

use super::morphology::{SubBox, close_ball, fill_holes};
use super::vaj::Plane;
use coapt_geom::{Point3, Vector3};

/// Radius of the closing ball (mm): native cusps are 0.5–1 mm thick and
/// blur to 2–4 mm of dark band at 1–2 mm voxels.
pub const CLOSE_MM: f64 = 2.5;

/// The part of space where the cusps may lie.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct RootSlab {
    /// The VAJ plane; heights are measured along its normal.
    pub vaj: Plane,
    /// Heights above the plane up to which the closing acts (mm).
    pub top_mm: f64,
    /// A point of the root's axis and its direction.
    pub axis_point_mm: [f64; 3],
    pub axis: [f64; 3],
    /// Largest distance from the axis (mm).
    pub radius_mm: f64,
}

impl RootSlab {
    fn contains(&self, q: &Point3) -> bool {
        let h = self.vaj.height(q);
        if !(-1.0..=self.top_mm).contains(&h) {
            return false;
        }
        let a = Vector3::from(self.axis);
        let d = q - Point3::from(self.axis_point_mm);
        (d - a * d.dot(&a)).norm() <= self.radius_mm
    }
}

/// What the fill did, for `segment.json`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RootFill {
    pub slab: RootSlab,
    pub close_mm: f64,
    pub added_ml: f64,
}

/// Close `mask` inside `slab` and fill its holes; returns the voxels added.
pub fn fill_cusps(
    mask: &mut [bool],
    dims: [usize; 3],
    spacing: [f64; 3],
    world: impl Fn(usize) -> Point3 + Sync,
    slab: &RootSlab,
) -> usize {
    let pad = [0, 1, 2].map(|a| (CLOSE_MM / spacing[a]).ceil() as usize + 2);
    let sub = SubBox::around(mask, dims, pad);
    let sd = sub.dims();
    let local = sub.extract(mask, dims);
    let closed = close_ball(&local, sd, spacing, CLOSE_MM);
    let grown: Vec<bool> = (0..local.len())
        .into_par_iter()
        .map(|v| local[v] || (closed[v] && slab.contains(&world(sub.to_outer(v, dims)))))
        .collect();
    let filled = fill_holes(&grown, sd);
    let added = filled
        .iter()
        .zip(&local)
        .filter(|(f, l)| **f && !**l)
        .count();
    sub.scatter(&filled, mask, dims);
    added
}
