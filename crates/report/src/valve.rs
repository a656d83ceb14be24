//! The closed valve as the report sees it.

use coapt_geom::{Point3, ValveFrame};

/// Closed leaflets: one mesh holding every leaflet, with its placed
/// (pre-closure) positions and the valve frame.
#[derive(Debug, Clone)]
pub struct ClosedValve {
    /// Closed positions, LPS mm.
    pub x: Vec<Point3>,
    /// Placed (sutured, unloaded) positions, LPS mm; same indexing as `x`.
    pub x0: Vec<Point3>,
    pub tris: Vec<[u32; 3]>,
    /// Leaflet of each triangle, 0-based (cell data `leaflet` minus 1).
    pub tri_leaflet: Vec<u8>,
    /// Per node: 0 interior, 1 sutured, 2 free edge.
    pub boundary: Vec<u8>,
    /// Per node: coordinates on the flat template (mm), when the mesh has them.
    pub ref_uv: Option<Vec<[f64; 2]>>,
    pub frame: ValveFrame,
    /// Number of leaflets (max of `tri_leaflet` + 1).
    pub leaflets: usize,
}

impl ClosedValve {
    /// Leaflets the triangles name, never fewer than `leaflets` says (a
    /// hand-built valve may set one without the other).
    pub fn leaflet_count(&self) -> usize {
        self.tri_leaflet
            .iter()
            .map(|&l| l as usize + 1)
            .max()
            .unwrap_or(0)
            .max(self.leaflets)
    }
}
