//! `valve.json`, written by the valve stage: what later stages read back.

use std::path::Path;

use serde_json::Value as Json;

use crate::geom::ValveFrame;
use crate::{Error, Result};

/// The valve frame from `valve.json` (key `valve_frame`).
pub fn read_frame(path: &Path) -> Result<ValveFrame> {
    let v: Json = serde_json::from_slice(&std::fs::read(path).map_err(|e| Error::read(path, e))?)
        .map_err(|e| Error::bad_input(path, format!("not JSON: {e}")))?;
    let f: ValveFrame = serde_json::from_value(v["valve_frame"].clone()).map_err(|e| {
        Error::bad_input(
            path,
            format!("no valid valve_frame (origin_mm, axis, e1, commissures_mm): {e}"),
        )
    })?;
    let unit = |n: f64| (n - 1.0).abs() < 1e-6;
    if !unit(f.axis.norm()) || !unit(f.e1.norm()) || f.axis.dot(&f.e1).abs() > 1e-6 {
        return Err(Error::bad_input(
            path,
            "valve_frame.axis and e1 must be orthogonal unit vectors",
        ));
    }
    if ![f.origin_mm.coords, f.axis]
        .iter()
        .all(|v| v.iter().all(|c| c.is_finite()))
    {
        return Err(Error::bad_input(path, "valve_frame has non-finite numbers"));
    }
    Ok(f)
}
