//! Shared geometric types: volumes with their voxel→world affine, triangle
//! meshes with named data arrays, landmarks and the valve frame.
//!
//! World coordinates are LPS millimetres throughout (as DICOM, ITK and
//! 3D Slicer); file readers convert other frames on the way in.

pub mod attributes;
pub mod basis;
pub mod bvh;
pub mod closest_point;
pub mod crossings;
pub mod frame;
pub mod free_edge_reach;
pub mod landmarks;
pub mod nadir_sectors;
pub mod polydata;
pub mod resample;
pub mod segment_distance;
pub mod tri_tri;
pub mod trimesh;
pub mod valve_frame;
pub mod volume;
pub mod wall;

pub use attributes::{Attributes, DataArray, DataValues};
pub use frame::Frame;
pub use landmarks::Landmarks;
pub use polydata::PolyData;
pub use trimesh::TriMesh;
pub use valve_frame::ValveFrame;
pub use volume::Volume;

pub type Point3 = nalgebra::Point3<f64>;

/// Test points: `r` off the z axis at `deg` degrees, at height `z`.
#[cfg(test)]
pub(crate) fn ring(r: f64, deg: f64, z: f64) -> Point3 {
    let a = deg.to_radians();
    Point3::new(r * a.cos(), r * a.sin(), z)
}
pub type Vector3 = nalgebra::Vector3<f64>;
pub type Matrix3 = nalgebra::Matrix3<f64>;
pub type Matrix4 = nalgebra::Matrix4<f64>;
