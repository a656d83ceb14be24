//! A 3-D image on a grid with an exact voxel→world affine.

use ndarray::{Array3, ShapeBuilder};

use super::{Matrix3, Matrix4, Point3, Vector3};
use coapt_base::{Error, Result};

/// A scalar volume indexed `[i, j, k]`, with a 4×4 affine from voxel indices
/// to world LPS millimetres.
///
/// Invariants (checked by [`Volume::new`] and [`Volume::sanity_check`]):
/// * the data is stored contiguously in Fortran order (i fastest, then j,
///   then k), as NIfTI and ITK store it, so `as_slice()[i + ni*(j + nj*k)]`
///   is voxel `[i, j, k]` and an axial slice is one contiguous block;
/// * the affine is finite, invertible and has last row (0, 0, 0, 1). It may be
///   oblique (rotated, even sheared) and have a negative determinant; nothing
///   assumes axis-aligned, isotropic or right-handed grids.
#[derive(Debug, Clone, PartialEq)]
pub struct Volume<T> {
    data: Array3<T>,
    affine: Matrix4,
    inverse: Matrix4,
}

impl<T: Clone> Volume<T> {
    /// Wrap `data` (any memory layout; re-laid out in Fortran order if needed).
    pub fn new(data: Array3<T>, affine: Matrix4) -> Result<Self> {
        let inverse = check_affine(&affine)?;
        let data = if data.t().is_standard_layout() {
            data
        } else {
            let mut f = Array3::from_shape_vec(data.raw_dim().f(), data.iter().cloned().collect())
                .expect("shape matches element count");
            // from_shape_vec with .f() expects Fortran-ordered input; refill logically.
            f.zip_mut_with(&data, |a, b| *a = b.clone());
            f
        };
        Ok(Self {
            data,
            affine,
            inverse,
        })
    }

    /// A volume of `dims` filled with `value`.
    pub fn filled(dims: [usize; 3], affine: Matrix4, value: T) -> Result<Self> {
        let data = Array3::from_elem((dims[0], dims[1], dims[2]).f(), value);
        Self::new(data, affine)
    }

    /// Build from voxel data already in Fortran order (i fastest).
    pub fn from_fortran_vec(dims: [usize; 3], affine: Matrix4, values: Vec<T>) -> Result<Self> {
        let n = dims[0] * dims[1] * dims[2];
        if values.len() != n {
            return Err(Error::value(format!(
                "volume of {}×{}×{} needs {n} values, got {}",
                dims[0],
                dims[1],
                dims[2],
                values.len()
            )));
        }
        let data = Array3::from_shape_vec((dims[0], dims[1], dims[2]).f(), values)
            .map_err(|e| Error::value(format!("volume shape: {e}")))?;
        Self::new(data, affine)
    }

    /// Same grid, values mapped voxel by voxel.
    pub fn map<U: Clone>(&self, f: impl Fn(&T) -> U) -> Volume<U> {
        let values: Vec<U> = self.as_slice().iter().map(f).collect();
        Volume {
            data: Array3::from_shape_vec(self.data.raw_dim().f(), values).expect("same shape"),
            affine: self.affine,
            inverse: self.inverse,
        }
    }

    /// The sub-volume `lo..hi` (per axis, `hi` exclusive), with the affine
    /// shifted exactly so every voxel keeps its world position.
    pub fn crop(&self, lo: [usize; 3], hi: [usize; 3]) -> Result<Self> {
        let d = self.dims();
        for a in 0..3 {
            if lo[a] >= hi[a] || hi[a] > d[a] {
                return Err(Error::value(format!(
                    "crop {lo:?}..{hi:?} is empty or outside a {}×{}×{} volume",
                    d[0], d[1], d[2]
                )));
            }
        }
        let view = self
            .data
            .slice(ndarray::s![lo[0]..hi[0], lo[1]..hi[1], lo[2]..hi[2]]);
        let mut data = Array3::from_elem(
            (hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]).f(),
            self.as_slice()[0].clone(),
        );
        data.assign(&view);
        let mut affine = self.affine;
        let shift =
            self.affine * nalgebra::Vector4::new(lo[0] as f64, lo[1] as f64, lo[2] as f64, 1.0);
        affine[(0, 3)] = shift[0];
        affine[(1, 3)] = shift[1];
        affine[(2, 3)] = shift[2];
        Self::new(data, affine)
    }
}

impl<T> Volume<T> {
    pub fn dims(&self) -> [usize; 3] {
        let s = self.data.shape();
        [s[0], s[1], s[2]]
    }

    pub fn len(&self) -> usize {
        self.data.len()
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    pub fn data(&self) -> &Array3<T> {
        &self.data
    }

    pub fn data_mut(&mut self) -> &mut Array3<T> {
        &mut self.data
    }

    pub fn into_data(self) -> Array3<T> {
        self.data
    }

    /// Voxel values in Fortran order (i fastest).
    pub fn as_slice(&self) -> &[T] {
        self.data
            .as_slice_memory_order()
            .expect("Volume data is contiguous by invariant")
    }

    pub fn as_slice_mut(&mut self) -> &mut [T] {
        self.data
            .as_slice_memory_order_mut()
            .expect("Volume data is contiguous by invariant")
    }

    /// Position of `[i, j, k]` in [`Volume::as_slice`].
    #[inline]
    pub fn linear_index(&self, i: usize, j: usize, k: usize) -> usize {
        let d = self.dims();
        i + d[0] * (j + d[1] * k)
    }

    pub fn affine(&self) -> &Matrix4 {
        &self.affine
    }

    /// World → continuous voxel index.
    pub fn inverse_affine(&self) -> &Matrix4 {
        &self.inverse
    }

    /// Replace the affine (same data).
    pub fn set_affine(&mut self, affine: Matrix4) -> Result<()> {
        self.inverse = check_affine(&affine)?;
        self.affine = affine;
        Ok(())
    }

    /// World positions of the eight corner voxel centres (the field of
    /// view's extreme samples, in any orientation).
    pub fn corner_centres(&self) -> [Point3; 8] {
        let d = self.dims();
        std::array::from_fn(|c| {
            self.index_to_world([0, 1, 2].map(|a| {
                if c >> a & 1 == 1 {
                    d[a].saturating_sub(1) as f64
                } else {
                    0.0
                }
            }))
        })
    }

    /// World position of a (possibly fractional) voxel index.
    #[inline]
    pub fn index_to_world(&self, ijk: [f64; 3]) -> Point3 {
        let a = &self.affine;
        Point3::new(
            a[(0, 0)] * ijk[0] + a[(0, 1)] * ijk[1] + a[(0, 2)] * ijk[2] + a[(0, 3)],
            a[(1, 0)] * ijk[0] + a[(1, 1)] * ijk[1] + a[(1, 2)] * ijk[2] + a[(1, 3)],
            a[(2, 0)] * ijk[0] + a[(2, 1)] * ijk[1] + a[(2, 2)] * ijk[2] + a[(2, 3)],
        )
    }

    /// Continuous voxel index of a world point.
    #[inline]
    pub fn world_to_index(&self, p: &Point3) -> [f64; 3] {
        let a = &self.inverse;
        [
            a[(0, 0)] * p.x + a[(0, 1)] * p.y + a[(0, 2)] * p.z + a[(0, 3)],
            a[(1, 0)] * p.x + a[(1, 1)] * p.y + a[(1, 2)] * p.z + a[(1, 3)],
            a[(2, 0)] * p.x + a[(2, 1)] * p.y + a[(2, 2)] * p.z + a[(2, 3)],
        ]
    }

    /// World step (mm) along each index axis: the affine's columns.
    pub fn axis(&self, a: usize) -> Vector3 {
        Vector3::new(
            self.affine[(0, a)],
            self.affine[(1, a)],
            self.affine[(2, a)],
        )
    }

    /// Voxel spacing in mm (lengths of the affine's columns).
    pub fn spacing(&self) -> [f64; 3] {
        [
            self.axis(0).norm(),
            self.axis(1).norm(),
            self.axis(2).norm(),
        ]
    }

    /// Unit direction of each index axis, as columns.
    pub fn direction(&self) -> Matrix3 {
        let s = self.spacing();
        Matrix3::from_columns(&[
            self.axis(0) / s[0],
            self.axis(1) / s[1],
            self.axis(2) / s[2],
        ])
    }

    /// World position of voxel [0, 0, 0].
    pub fn origin(&self) -> Point3 {
        Point3::new(
            self.affine[(0, 3)],
            self.affine[(1, 3)],
            self.affine[(2, 3)],
        )
    }

    /// Volume of one voxel in mm³.
    pub fn voxel_volume(&self) -> f64 {
        self.affine.fixed_view::<3, 3>(0, 0).determinant().abs()
    }

    /// True when index axes (i, j, k) form a right-handed system in LPS.
    pub fn is_right_handed(&self) -> bool {
        self.affine.fixed_view::<3, 3>(0, 0).determinant() > 0.0
    }

    /// Same dimensions and the same affine (to `tol` mm per entry).
    pub fn same_grid<U>(&self, other: &Volume<U>, tol: f64) -> bool {
        self.dims() == other.dims()
            && self
                .affine
                .iter()
                .zip(other.affine.iter())
                .all(|(a, b)| (a - b).abs() <= tol)
    }

    /// Verify the invariants listed on the type.
    pub fn sanity_check(&self) -> Result<()> {
        if self.data.as_slice_memory_order().is_none() || !self.data.t().is_standard_layout() {
            return Err(Error::value(
                "volume data is not contiguous in Fortran order",
            ));
        }
        let inv = check_affine(&self.affine)?;
        let id = self.affine * inv;
        if (id - Matrix4::identity()).abs().max() > 1e-9 {
            return Err(Error::value("cached inverse affine is stale"));
        }
        Ok(())
    }
}

impl<T> std::ops::Index<[usize; 3]> for Volume<T> {
    type Output = T;
    #[inline]
    fn index(&self, idx: [usize; 3]) -> &T {
        &self.data[idx]
    }
}

impl<T> std::ops::IndexMut<[usize; 3]> for Volume<T> {
    #[inline]
    fn index_mut(&mut self, idx: [usize; 3]) -> &mut T {
        &mut self.data[idx]
    }
}

/// Validate an affine and return its inverse.
pub fn check_affine(a: &Matrix4) -> Result<Matrix4> {
    if a.iter().any(|v| !v.is_finite()) {
        return Err(Error::value("voxel→world affine has non-finite entries"));
    }
    if a[(3, 0)] != 0.0 || a[(3, 1)] != 0.0 || a[(3, 2)] != 0.0 || a[(3, 3)] != 1.0 {
        return Err(Error::value(
            "voxel→world affine's last row is not (0, 0, 0, 1)",
        ));
    }
    let m = a.fixed_view::<3, 3>(0, 0).into_owned();
    let scale = m.column(0).norm() * m.column(1).norm() * m.column(2).norm();
    if scale == 0.0 || m.determinant().abs() <= 1e-12 * scale {
        return Err(Error::value(
            "voxel→world affine is singular (a zero or degenerate voxel axis)",
        ));
    }
    a.try_inverse()
        .ok_or_else(|| Error::value("voxel→world affine is not invertible"))
}

/// Affine from spacing, a direction matrix (columns = index axes) and the world
/// position of voxel [0, 0, 0].
pub fn affine_from_parts(spacing: [f64; 3], direction: &Matrix3, origin: Point3) -> Matrix4 {
    let mut a = Matrix4::identity();
    for c in 0..3 {
        for r in 0..3 {
            a[(r, c)] = direction[(r, c)] * spacing[c];
        }
        a[(c, 3)] = origin[c];
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    fn oblique() -> Matrix4 {
        let rot = nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1).into_inner();
        let mut dir = rot;
        dir.set_column(2, &(-rot.column(2))); // negative determinant
        affine_from_parts([0.44, 0.5, 0.6], &dir, Point3::new(-12.0, 40.0, -300.0))
    }

    #[test]
    fn index_world_round_trip_oblique_left_handed() {
        let v = Volume::filled([5, 6, 7], oblique(), 0u8).unwrap();
        assert!(!v.is_right_handed());
        let s = v.spacing();
        assert!((s[0] - 0.44).abs() < 1e-12 && (s[2] - 0.6).abs() < 1e-12);
        assert!((v.voxel_volume() - 0.44 * 0.5 * 0.6).abs() < 1e-12);
        let ijk = [1.25, 4.5, 6.0];
        let p = v.index_to_world(ijk);
        let back = v.world_to_index(&p);
        for a in 0..3 {
            assert!((back[a] - ijk[a]).abs() < 1e-10);
        }
        v.sanity_check().unwrap();
    }

    #[test]
    fn fortran_layout_and_index() {
        let dims = [3, 4, 5];
        let vals: Vec<u32> = (0..60).collect();
        let v = Volume::from_fortran_vec(dims, Matrix4::identity(), vals).unwrap();
        assert_eq!(v[[2, 1, 3]], (2 + 3 * (1 + 4 * 3)) as u32);
        assert_eq!(v.linear_index(2, 1, 3), 2 + 3 * (1 + 4 * 3));
        // A C-ordered array is re-laid out, values kept by index.
        let c = Array3::from_shape_fn((3, 4, 5), |(i, j, k)| (i * 100 + j * 10 + k) as u32);
        let v = Volume::new(c, Matrix4::identity()).unwrap();
        v.sanity_check().unwrap();
        assert_eq!(v[[2, 3, 4]], 234);
        assert_eq!(v.as_slice()[1], 100);
    }

    #[test]
    fn crop_keeps_world_positions() {
        let v =
            Volume::from_fortran_vec([6, 7, 8], oblique(), (0..336).collect::<Vec<u32>>()).unwrap();
        let c = v.crop([1, 2, 3], [5, 6, 8]).unwrap();
        assert_eq!(c.dims(), [4, 4, 5]);
        assert_eq!(c[[0, 0, 0]], v[[1, 2, 3]]);
        assert_eq!(c[[3, 2, 4]], v[[4, 4, 7]]);
        let p = c.index_to_world([3.0, 2.0, 4.0]);
        let q = v.index_to_world([4.0, 4.0, 7.0]);
        assert!((p - q).norm() < 1e-12);
        assert!(v.crop([0, 0, 0], [7, 1, 1]).is_err());
    }

    #[test]
    fn refuses_singular_or_nan_affine() {
        let mut a = Matrix4::identity();
        a[(1, 1)] = 0.0;
        assert!(Volume::filled([2, 2, 2], a, 0u8).is_err());
        let mut a = Matrix4::identity();
        a[(0, 3)] = f64::NAN;
        assert!(Volume::filled([2, 2, 2], a, 0u8).is_err());
    }
}
