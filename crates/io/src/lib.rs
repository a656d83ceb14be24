//! File formats, and nothing else: volumes (NIfTI, NRRD, MetaImage, DICOM series; one
//! entry point in [`volume_file`]), VTK XML PolyData, STL and PLY, 3D Slicer
//! markups, PNG (write only). Readers validate before they allocate and return
//! errors that name the file and the problem; writers are atomic.

pub mod atomic;
pub mod design_json;
pub mod dicom;
pub mod leaflet_mesh;
pub mod markups;
pub mod metaimage;
pub mod nifti;
pub mod nrrd;
pub mod ply;
pub mod png;
pub mod raw_voxels;
pub mod report_json;
pub mod scratch;
pub mod sha256;
pub mod stl;
pub mod toml_error;
pub mod valve_json;
pub mod volume_file;
pub mod vtp;

pub use atomic::{Transaction, write_atomic};
