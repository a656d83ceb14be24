//! Voxel→world transforms as NIfTI stores them (RAS): sform, qform
//! (quaternion + pixdim + qfac) and the bare pixdim scaling, both directions.

use nalgebra::{Matrix3, Matrix4, Rotation3, UnitQuaternion};

use super::header::{RawHeader, TransformSource};

/// Voxel spacings a CT can have (mm). A spacing of 1e-6 mm asked the
/// segmentation for 160 GB; 0.3–2 mm is what scanners write, so the bounds
/// are far outside that, only to stop nonsense before it costs anything.
pub const SPACING_MM: (f64, f64) = (0.01, 50.0);

/// The RAS affine the header defines, by NIfTI precedence: sform, then
/// qform, then pixdim scaling ("method 1"), refused when a voxel axis is
/// shorter or longer than [`SPACING_MM`].
pub fn affine_ras(
    raw: &RawHeader,
    unit_to_mm: f64,
) -> Result<(Matrix4<f64>, TransformSource), String> {
    let (a, src) = affine_any(raw, unit_to_mm)?;
    for c in 0..3 {
        let d = a.fixed_view::<3, 1>(0, c).norm();
        if !(SPACING_MM.0..=SPACING_MM.1).contains(&d) {
            return Err(format!(
                "voxel spacing along axis {} is {d:e} mm (from the {}); a CT's lies in {}–{} mm: fix the header's spacing or its units",
                c + 1,
                src.as_str(),
                SPACING_MM.0,
                SPACING_MM.1
            ));
        }
    }
    Ok((a, src))
}

fn affine_any(raw: &RawHeader, unit_to_mm: f64) -> Result<(Matrix4<f64>, TransformSource), String> {
    if raw.sform_code > 0 {
        return sform(raw, unit_to_mm).map(|a| (a, TransformSource::Sform));
    }
    if raw.qform_code > 0 {
        return qform(raw, unit_to_mm).map(|a| (a, TransformSource::Qform));
    }
    let s = spacing(raw, "pixdim scaling (no sform or qform)")?;
    let mut a = Matrix4::identity();
    for i in 0..3 {
        a[(i, i)] = s[i] * unit_to_mm;
    }
    Ok((a, TransformSource::Pixdim))
}

fn sform(raw: &RawHeader, unit_to_mm: f64) -> Result<Matrix4<f64>, String> {
    let mut a = Matrix4::identity();
    for (r, row) in raw.srow.iter().enumerate() {
        for (c, &v) in row.iter().enumerate() {
            if !v.is_finite() {
                return Err(format!(
                    "sform (srow_{}) has a non-finite entry ({v}); fix the header",
                    ["x", "y", "z"][r]
                ));
            }
            a[(r, c)] = scale_unit(v, unit_to_mm);
        }
    }
    if a.fixed_view::<3, 3>(0, 0).determinant() == 0.0 {
        return Err(
            "sform (srow_x/y/z) is singular: a zero or degenerate voxel axis; fix the header"
                .into(),
        );
    }
    Ok(a)
}

/// Exact when the unit is millimetres (the common case), so f32-stored
/// values round-trip bit for bit.
fn scale_unit(v: f64, unit_to_mm: f64) -> f64 {
    if unit_to_mm == 1.0 { v } else { v * unit_to_mm }
}

/// pixdim[1..3], refused when not a positive spacing.
fn spacing(raw: &RawHeader, used_by: &str) -> Result<[f64; 3], String> {
    let s = [raw.pixdim[1], raw.pixdim[2], raw.pixdim[3]];
    if let Some(i) = (0..3).find(|&i| !(s[i] > 0.0 && s[i].is_finite())) {
        return Err(format!(
            "pixdim[{}] (voxel spacing) is {}, but the {used_by} needs a positive spacing; \
             fix the header",
            i + 1,
            s[i]
        ));
    }
    Ok(s)
}

fn qform(raw: &RawHeader, unit_to_mm: f64) -> Result<Matrix4<f64>, String> {
    let s = spacing(raw, "qform (the transform in use: sform_code is 0)")?;
    let qfac = raw.pixdim[0];
    if qfac != 1.0 && qfac != -1.0 {
        return Err(format!(
            "pixdim[0] (qfac) is {qfac}; it must be 1 or -1 when the qform is the transform in \
             use (sform_code is 0), fix the header (set pixdim[0] to 1 or -1, or add an sform)"
        ));
    }
    let [b, c, d] = raw.quatern;
    if raw
        .quatern
        .iter()
        .chain(&raw.qoffset)
        .any(|v| !v.is_finite())
    {
        return Err(
            "qform (quatern_b/c/d or qoffset_x/y/z) has a non-finite entry; fix the header".into(),
        );
    }
    if b * b + c * c + d * d > 1.0 + 1e-4 {
        return Err(format!(
            "qform quaternion (quatern_b, c, d) = ({b}, {c}, {d}) has norm > 1, so it is not a \
             rotation; fix the header"
        ));
    }
    let r = quatern_to_rotation(b, c, d);
    let mut a = Matrix4::identity();
    for col in 0..3 {
        let f = s[col] * if col == 2 { qfac } else { 1.0 } * unit_to_mm;
        for row in 0..3 {
            a[(row, col)] = r[(row, col)] * f;
        }
        a[(col, 3)] = scale_unit(raw.qoffset[col], unit_to_mm);
    }
    Ok(a)
}

/// 3×3 rotation from a NIfTI quaternion (b, c, d), following nifti1_io:
/// `a` comes from the unit norm, and a (b, c, d) made slightly longer than 1
/// by f32 rounding is renormalised rather than refused.
pub fn quatern_to_rotation(b: f64, c: f64, d: f64) -> Matrix3<f64> {
    let n2 = b * b + c * c + d * d;
    let (a, b, c, d) = if 1.0 - n2 < 1e-7 {
        let s = 1.0 / n2.sqrt();
        (0.0, b * s, c * s, d * s)
    } else {
        ((1.0 - n2).sqrt(), b, c, d)
    };
    Matrix3::new(
        a * a + b * b - c * c - d * d,
        2.0 * (b * c - a * d),
        2.0 * (b * d + a * c),
        2.0 * (b * c + a * d),
        a * a + c * c - b * b - d * d,
        2.0 * (c * d - a * b),
        2.0 * (b * d - a * c),
        2.0 * (c * d + a * b),
        a * a + d * d - c * c - b * b,
    )
}

/// The qform fields that best represent a RAS affine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Qform {
    pub quatern: [f32; 3],
    pub offset: [f32; 3],
    pub spacing: [f32; 3],
    pub qfac: f32,
}

/// qform of an affine: spacing = column lengths; a negative determinant is
/// absorbed by qfac = -1 (third column flipped); a sheared matrix is replaced
/// by its nearest rotation (polar decomposition), as nifti1_io does.
pub fn qform_from_affine(ras: &Matrix4<f64>) -> Qform {
    let m = ras.fixed_view::<3, 3>(0, 0).into_owned();
    let spacing: [f64; 3] = std::array::from_fn(|c| m.column(c).norm());
    let mut r = Matrix3::from_fn(|i, j| m[(i, j)] / spacing[j]);
    let qfac = if r.determinant() < 0.0 {
        r.set_column(2, &(-r.column(2)));
        -1.0
    } else {
        1.0
    };
    let r = nearest_rotation(&r);
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    // NIfTI stores only (b, c, d) and takes a ≥ 0.
    let s = if q.w < 0.0 { -1.0 } else { 1.0 };
    let bcd = [q.i * s, q.j * s, q.k * s];
    Qform {
        quatern: round_quatern(bcd, &r),
        offset: [ras[(0, 3)] as f32, ras[(1, 3)] as f32, ras[(2, 3)] as f32],
        spacing: spacing.map(|x| x as f32),
        qfac,
    }
}

fn nearest_rotation(r: &Matrix3<f64>) -> Matrix3<f64> {
    let svd = r.svd(true, true);
    match (svd.u, svd.v_t) {
        (Some(u), Some(vt)) => {
            let p = u * vt;
            // det(r) > 0 here, so p is a proper rotation; guard anyway.
            if p.determinant() > 0.0 { p } else { *r }
        }
        _ => *r,
    }
}

/// Round (b, c, d) to f32 choosing, among the neighbouring f32 values, the
/// triple whose decoded rotation is closest to `target`. Plain rounding can
/// be far off near 180° rotations, where a = sqrt(1 − b² − c² − d²) is
/// ill-conditioned.
fn round_quatern(bcd: [f64; 3], target: &Matrix3<f64>) -> [f32; 3] {
    let cands = bcd.map(|x| {
        let f = x as f32;
        [f, f32_step(f, -1), f32_step(f, 1)]
    });
    let mut best = cands.map(|c| c[0]);
    let mut best_err = f64::INFINITY;
    for &b in &cands[0] {
        for &c in &cands[1] {
            for &d in &cands[2] {
                let e = (quatern_to_rotation(b as f64, c as f64, d as f64) - target)
                    .abs()
                    .max();
                if e < best_err {
                    best_err = e;
                    best = [b, c, d];
                }
            }
        }
    }
    best
}

/// The neighbouring f32 one ulp away (towards +∞ for `dir` > 0); written
/// out because `f32::next_up` is newer than the crate's minimum Rust.
fn f32_step(f: f32, dir: i32) -> f32 {
    if !f.is_finite() {
        return f;
    }
    if f == 0.0 {
        let tiny = f32::from_bits(1);
        return if dir > 0 { tiny } else { -tiny };
    }
    let bits = f.to_bits();
    // Away from zero increments the magnitude bits, towards zero decrements.
    let away = (f > 0.0) == (dir > 0);
    f32::from_bits(if away { bits + 1 } else { bits - 1 })
}
