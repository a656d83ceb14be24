//! Reading the report's inputs into a [`ClosedValve`].

use std::path::Path;

use super::ClosedValve;
use coapt_base::{Error, Result};
use coapt_geom::{TriMesh, ValveFrame};

/// The closed leaflets (`closed.vtp`: positions, point data `displacement`,
/// `boundary`, `ref_uv`, cell data `leaflet`) checked against the placed
/// leaflets they came from (`leaflets.vtp`).
pub fn closed_valve(
    closed: &TriMesh,
    closed_path: &Path,
    placed: &TriMesh,
    placed_path: &Path,
    frame: ValveFrame,
) -> Result<ClosedValve> {
    let bad = |m: String| Error::bad_input(closed_path, m);
    if closed.vertices.len() != placed.vertices.len() || closed.triangles != placed.triangles {
        return Err(Error::bad_input(
            placed_path,
            format!(
                "does not match {}: {} vs {} points, triangles {}",
                closed_path.display(),
                placed.vertices.len(),
                closed.vertices.len(),
                if closed.triangles == placed.triangles {
                    "equal"
                } else {
                    "differ"
                }
            ),
        ));
    }
    // The placed leaflets carry the arrays (one reading for every stage);
    // the closed mesh, written from them by `coapt close`, must agree.
    let a = coapt_io::leaflet_mesh::arrays(placed).map_err(|e| Error::bad_input(placed_path, e))?;
    if let Some(i) = closed
        .vertices
        .iter()
        .position(|p| !p.coords.iter().all(|c| c.is_finite()))
    {
        return Err(bad(format!("point {i} has a non-finite position")));
    }
    if let Some(k) = closed
        .cell_data
        .get("leaflet")
        .and_then(|k| k.values.to_f64())
    {
        if k.iter().zip(&a.leaflet).any(|(k, l)| *k != (*l + 1) as f64) {
            return Err(bad(format!(
                "its cell data 'leaflet' differs from that of {}",
                placed_path.display()
            )));
        }
    }
    let (tri_leaflet, boundary, ref_uv, leaflets) = (a.leaflet, a.boundary, a.ref_uv, a.leaflets);
    Ok(ClosedValve {
        x: closed.vertices.clone(),
        x0: placed.vertices.clone(),
        tris: closed.triangles.clone(),
        tri_leaflet,
        boundary,
        ref_uv,
        frame,
        leaflets,
    })
}

/// Point data `low_pressure_position` of `closed.vtp` (positions of an
/// extra closure at a low pressure, written by the close stage when asked).
pub fn low_pressure_positions(
    closed: &TriMesh,
    path: &Path,
) -> Result<Option<Vec<coapt_geom::Point3>>> {
    let Some(a) = closed.point_data.get("low_pressure_position") else {
        return Ok(None);
    };
    let v = a
        .values
        .to_f64()
        .filter(|v| a.components == 3 && v.len() == 3 * closed.vertices.len())
        .ok_or_else(|| {
            Error::bad_input(
                path,
                "point data 'low_pressure_position' must hold 3 numbers per point",
            )
        })?;
    if v.iter().any(|c| !c.is_finite()) {
        return Err(Error::bad_input(
            path,
            "point data 'low_pressure_position' has non-finite numbers",
        ));
    }
    Ok(Some(
        v.chunks(3)
            .map(|c| coapt_geom::Point3::new(c[0], c[1], c[2]))
            .collect(),
    ))
}
