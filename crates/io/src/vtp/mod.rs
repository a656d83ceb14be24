//! VTK XML PolyData (`.vtp`): the surface and leaflet artifacts.
//!
//! The writer produces what VTK 9 itself writes in appended mode (one piece,
//! Float64 points, Int64 `connectivity`/`offsets`, UInt64 headers, optional
//! vtkZLibDataCompressor blocks); the reader accepts every layout VTK,
//! ParaView and 3D Slicer produce. Checked against VTK's own reader by
//! `tools/vtp_crosscheck.py`; fixtures written by VTK live in `tests/data/vtp/`.

mod read;
mod write;

use std::io::Write;
use std::path::Path;

use crate::write_atomic;
use coapt_base::{Error, Result};
use coapt_geom::{PolyData, TriMesh};

/// How [`write`] lays out the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriteOptions {
    /// zlib-compress the appended data (vtkZLibDataCompressor block format).
    pub compress: bool,
}

impl Default for WriteOptions {
    fn default() -> Self {
        Self { compress: true }
    }
}

/// Read and validate a `.vtp` file; errors name the file.
pub fn read(path: &Path) -> Result<PolyData> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    parse(&bytes).map_err(|e| e.in_file(path))
}

/// Parse and validate (with [`PolyData::sanity_check`]) the bytes of a
/// `.vtp` file. Errors are context-free [`Error::Value`]s.
pub fn parse(bytes: &[u8]) -> Result<PolyData, Error> {
    read::parse(bytes)
}

/// Write `pd` atomically. Invalid data (indices out of range, NaN points,
/// array lengths that do not match, an unknown `frame`) is refused, never
/// written. Without a `frame` in field data, `frame` = "LPS" is recorded.
pub fn write(path: &Path, pd: &PolyData, opts: &WriteOptions) -> Result<()> {
    pd.sanity_check().and_then(|_| pd.frame()).map_err(|e| {
        Error::write(
            path,
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("invalid dataset: {e}"),
            ),
        )
    })?;
    write_atomic(path, |w| encode(w, pd, opts))
}

/// Serialise `pd` (not validated: see [`write`]), adding `frame` = "LPS" to
/// field data when absent. Same input, same bytes, whatever the number of
/// threads.
pub fn encode(w: &mut impl Write, pd: &PolyData, opts: &WriteOptions) -> std::io::Result<()> {
    write::encode(w, pd, opts)
}

/// Read a triangle mesh (no polylines), with its frame from field data.
pub fn read_mesh(path: &Path) -> Result<TriMesh> {
    let pd = read(path)?;
    let mesh = TriMesh::from_polydata(pd).map_err(|e| e.in_file(path))?;
    mesh.sanity_check().map_err(|e| e.in_file(path))?;
    Ok(mesh)
}

/// Write a triangle mesh, compressed, its frame in field data `frame`.
pub fn write_mesh(path: &Path, mesh: &TriMesh) -> Result<()> {
    write(path, &mesh.to_polydata(), &WriteOptions::default())
}

#[cfg(test)]
mod tests;
