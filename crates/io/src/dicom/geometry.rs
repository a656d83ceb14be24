//! A stack of slices as one grid: the slices ordered along the normal of
//! their common plane (never by file name or InstanceNumber), the slice
//! step from the positions (never SliceThickness), and refusals for stacks
//! that are not one regular grid: gantry tilt, missing slices, uneven steps.

use nalgebra::{Matrix4, Vector3};

use super::scan::Slice;

/// Directions of two slices agree to this (cosines).
const ORIENTATION_TOL: f64 = 1e-4;
/// Positions in the slice plane may wander this much (mm) from slice to
/// slice before the stack counts as sheared (gantry tilt); scanners round
/// positions to a few µm.
const SHEAR_TOL_MM: f64 = 0.01;
/// A step may differ from the typical step by this fraction.
const STEP_TOL: f64 = 0.01;

/// The slices in grid order (k along the plane normal) and the voxel→LPS
/// affine; or why the stack is not one regular grid.
pub fn grid(slices: &[Slice]) -> Result<(Vec<usize>, Matrix4<f64>), String> {
    if slices.len() < 2 {
        return Err(format!(
            "has {} image{}; a volume needs at least 2 slices (the slice spacing comes from \
             their positions)",
            slices.len(),
            if slices.len() == 1 { "" } else { "s" }
        ));
    }
    let first = &slices[0];
    for s in slices {
        if s.rows != first.rows || s.columns != first.columns {
            return Err(format!(
                "images differ in size ({}×{} in {}, {}×{} in {}); one series must be one grid",
                first.columns,
                first.rows,
                first.place(),
                s.columns,
                s.rows,
                s.place()
            ));
        }
        if (0..6).any(|i| (s.orientation[i] - first.orientation[i]).abs() > ORIENTATION_TOL) {
            return Err(format!(
                "images differ in orientation ({} and {}); one series must be one grid",
                first.place(),
                s.place()
            ));
        }
        if (0..2).any(|i| (s.pixel_spacing[i] - first.pixel_spacing[i]).abs() > 1e-6) {
            return Err(format!(
                "images differ in Pixel Spacing ({} and {})",
                first.place(),
                s.place()
            ));
        }
    }
    let o = first.orientation;
    let row = Vector3::new(o[0], o[1], o[2]);
    let col = Vector3::new(o[3], o[4], o[5]);
    if (row.norm() - 1.0).abs() > 1e-3
        || (col.norm() - 1.0).abs() > 1e-3
        || row.dot(&col).abs() > 1e-3
    {
        return Err(format!(
            "Image Orientation (Patient) {o:?} is not two perpendicular unit vectors"
        ));
    }
    let normal = row.cross(&col).normalize();
    let pos = |s: &Slice| Vector3::new(s.position[0], s.position[1], s.position[2]);
    let mut idx: Vec<usize> = (0..slices.len()).collect();
    idx.sort_by(|&a, &b| {
        normal
            .dot(&pos(&slices[a]))
            .total_cmp(&normal.dot(&pos(&slices[b])))
    });
    let order: Vec<&Slice> = idx.iter().map(|&i| &slices[i]).collect();
    let d: Vec<f64> = order.iter().map(|s| normal.dot(&pos(s))).collect();
    let steps: Vec<f64> = d.windows(2).map(|w| w[1] - w[0]).collect();
    if let Some(k) = steps.iter().position(|&s| s.abs() < 1e-3) {
        return Err(format!(
            "two images lie at the same position ({} and {}): duplicates, or several phases \
             or echoes in one series",
            order[k].place(),
            order[k + 1].place()
        ));
    }
    let mut sorted = steps.clone();
    sorted.sort_by(f64::total_cmp);
    // The lower median: a few gaps do not move it.
    let typical = sorted[(sorted.len() - 1) / 2];
    for (k, &s) in steps.iter().enumerate() {
        if (s - typical).abs() > STEP_TOL * typical {
            let gap = s / typical;
            let what = if gap > 1.5 && (gap - gap.round()).abs() < 0.1 {
                format!(
                    "{} slice{} missing",
                    gap.round() as i64 - 1,
                    if gap.round() as i64 == 2 {
                        " is"
                    } else {
                        "s are"
                    }
                )
            } else {
                "the slice spacing is not uniform".to_string()
            };
            return Err(format!(
                "{what}: {s:.3} mm between {} and {} where the other steps are {typical:.3} mm; \
                 export the complete series, or resample it to a regular grid first",
                order[k].place(),
                order[k + 1].place()
            ));
        }
    }
    for (k, w) in order.windows(2).enumerate() {
        let delta = pos(w[1]) - pos(w[0]);
        let inplane = delta - normal * normal.dot(&delta);
        if inplane.norm() > SHEAR_TOL_MM {
            let tilt = inplane.norm().atan2(steps[k]).to_degrees();
            return Err(format!(
                "the slices are sheared by {tilt:.2}° (gantry tilt, or a stack that is not \
                 perpendicular to its slices): coapt needs a regular grid; resample it first \
                 (dcm2niix corrects gantry tilt)"
            ));
        }
    }
    let n = order.len();
    let step = (pos(order[n - 1]) - pos(order[0])) / (n - 1) as f64;
    let mut a = Matrix4::identity();
    // Column index i runs along a row; row index j down the columns.
    a.fixed_view_mut::<3, 1>(0, 0)
        .copy_from(&(row * first.pixel_spacing[1]));
    a.fixed_view_mut::<3, 1>(0, 1)
        .copy_from(&(col * first.pixel_spacing[0]));
    a.fixed_view_mut::<3, 1>(0, 2).copy_from(&step);
    a.fixed_view_mut::<3, 1>(0, 3).copy_from(&pos(order[0]));
    Ok((idx, a))
}
