//! NRRD volumes (.nrrd with attached data, .nhdr with a detached data file),
//! as 3D Slicer and ITK write them.
//!
//! Reading accepts raw and gzip encodings, either byte order, every scalar
//! type, and the spaces left-posterior-superior (LPS), right-anterior-superior
//! (RAS) and left-anterior-superior (LAS); `space directions` and `space
//! origin` give the exact voxel→world affine, converted to LPS. The header is
//! validated in full (as the NIfTI one is) before anything is allocated.
//!
//! Writing produces an attached, gzip-encoded, little-endian NRRD in LPS.

mod header;
mod write;

pub use header::layout;
pub use write::{encode, write};
