//! `valve.json`, written by the valve stage: what later stages read back.

use std::path::Path;

use serde_json::Value as Json;

use coapt_base::{Error, Result};
use coapt_geom::ValveFrame;

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
    // Each commissure stands above the annulus on the root's wall: a frame
    // whose commissures lie below the annulus, on the axis or metres away
    // describes no root (leaflets would be placed by it all the same).
    for (k, c) in f.commissures_mm.iter().enumerate() {
        let d = c - f.origin_mm;
        let h = d.dot(&f.axis);
        let r = (d - f.axis * h).norm();
        let (hr, rr) = (COMMISSURE_HEIGHT_MM, COMMISSURE_RADIUS_MM);
        if !(h >= hr.0 && h <= hr.1 && r >= rr.0 && r <= rr.1) {
            return Err(Error::bad_input(
                path,
                format!(
                    "valve_frame: commissure C{} stands {} mm above the annulus, {} mm from the axis; a root's commissures stand {}–{} mm above it, {}–{} mm from it",
                    k + 1,
                    coapt_base::units::short((h * 100.0).round() / 100.0),
                    coapt_base::units::short((r * 100.0).round() / 100.0),
                    hr.0,
                    hr.1,
                    rr.0,
                    rr.1
                ),
            ));
        }
    }
    Ok(f)
}

/// Commissure height above the annulus plane a `valve.json` may give (mm):
/// adult roots measure 10–25 mm, a child's or a tilted annulus less.
pub const COMMISSURE_HEIGHT_MM: (f64, f64) = (1.0, 60.0);

/// Commissure distance from the valve axis (mm): root radii are 8–20 mm.
pub const COMMISSURE_RADIUS_MM: (f64, f64) = (2.0, 50.0);

/// Height of the sinotubular junction's plane above the annulus plane,
/// along the valve axis, mm; `Ok(Err(why))` when `valve.json` does not say
/// (an older or hand-written file, or no STJ section was found).
///
/// The valve stage writes `sections.stj.height_mm` along the commissure
/// axis from the commissure cylinder's centre (`commissure_cylinder.
/// centre_mm`), and the frame's axis is that axis with its origin at the
/// annulus centre, so the STJ lies `height_mm − (origin − centre)·axis`
/// above the annulus. The file's `h_comm_mm` (mean commissure height above
/// the annulus by the same rule) must agree with the frame's commissures,
/// else the file was not written that way and nothing is guessed.
pub fn read_stj_height(path: &Path, f: &ValveFrame) -> Result<std::result::Result<f64, String>> {
    let v: Json = serde_json::from_slice(&std::fs::read(path).map_err(|e| Error::read(path, e))?)
        .map_err(|e| Error::bad_input(path, format!("not JSON: {e}")))?;
    Ok(stj_height(&v, f))
}

pub fn stj_height(v: &Json, f: &ValveFrame) -> std::result::Result<f64, String> {
    let stj = &v["sections"]["stj"];
    if stj.is_null() {
        return Err(if v["sections"].is_object() {
            "valve.json has no STJ section (no closed section of the wall above the commissures)"
                .into()
        } else {
            "valve.json has no sections.stj (an older or hand-written file)".into()
        });
    }
    let h = stj["height_mm"]
        .as_f64()
        .ok_or("valve.json sections.stj has no height_mm")?;
    let c = v["commissure_cylinder"]["centre_mm"]
        .as_array()
        .and_then(|a| {
            let x: Vec<f64> = a.iter().filter_map(Json::as_f64).collect();
            (x.len() == 3).then(|| coapt_geom::Point3::new(x[0], x[1], x[2]))
        })
        .ok_or("valve.json has no commissure_cylinder.centre_mm to place the STJ height")?;
    let h_ann = (f.origin_mm - c).dot(&f.axis);
    let comm = f
        .commissures_mm
        .iter()
        .map(|p| (p - f.origin_mm).dot(&f.axis))
        .sum::<f64>()
        / 3.0;
    match v["h_comm_mm"].as_f64() {
        Some(hc) if (hc - comm).abs() <= 1e-6 * (1.0 + hc.abs()) => {}
        _ => {
            return Err(
                "valve.json's h_comm_mm does not match its valve_frame: the STJ height cannot be placed"
                    .into(),
            );
        }
    }
    let s = h - h_ann;
    if s.is_finite() {
        Ok(s)
    } else {
        Err("valve.json's STJ height is not a finite number".into())
    }
}
