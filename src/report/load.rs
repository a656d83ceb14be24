//! Reading the report's inputs into a [`ClosedValve`].

use std::path::Path;

use super::ClosedValve;
use crate::geom::{TriMesh, ValveFrame};
use crate::{Error, Result};

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
    if closed.triangles.is_empty() {
        return Err(bad("has no triangles".into()));
    }
    if closed
        .vertices
        .iter()
        .any(|p| !p.coords.iter().all(|c| c.is_finite()))
    {
        return Err(bad("has non-finite positions".into()));
    }
    let boundary: Vec<u8> = placed
        .point_data
        .get("boundary")
        .or_else(|| closed.point_data.get("boundary"))
        .and_then(|a| a.values.to_f64())
        .ok_or_else(|| bad("no point data 'boundary' (0 interior, 1 sutured, 2 free edge)".into()))?
        .iter()
        .map(|&b| b as u8)
        .collect();
    if boundary.iter().any(|&b| b > 2) {
        return Err(bad("point data 'boundary' must be 0, 1 or 2".into()));
    }
    let leaflet: Vec<f64> = closed
        .cell_data
        .get("leaflet")
        .and_then(|a| a.values.to_f64())
        .ok_or_else(|| bad("no cell data 'leaflet' (1, 2, 3)".into()))?;
    if leaflet
        .iter()
        .any(|&k| !(1.0..=8.0).contains(&k) || k.fract() != 0.0)
    {
        return Err(bad("cell data 'leaflet' must number leaflets 1..8".into()));
    }
    let tri_leaflet: Vec<u8> = leaflet.iter().map(|&k| k as u8 - 1).collect();
    let leaflets = *tri_leaflet.iter().max().expect("non-empty") as usize + 1;
    let ref_uv = placed
        .point_data
        .get("ref_uv")
        .filter(|a| a.components == 2)
        .and_then(|a| a.values.to_f64())
        .map(|v| v.chunks(2).map(|c| [c[0], c[1]]).collect());
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
) -> Result<Option<Vec<crate::geom::Point3>>> {
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
            .map(|c| crate::geom::Point3::new(c[0], c[1], c[2]))
            .collect(),
    ))
}
