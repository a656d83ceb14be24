//! Binary STL, for tools that want a bare triangle soup (3D printing, CAD).
//!
//! STL has no frame or units: coordinates are always written in LPS
//! millimetres (a RAS mesh is converted) and the header says so, in words and
//! in 3D Slicer's `SPACE=LPS` convention.

use std::io::{self, Write};
use std::path::Path;

use crate::write_atomic;
use coapt_base::{Error, Result};
use coapt_geom::{Frame, TriMesh};

const HEADER: &str = "coapt triangle mesh, LPS mm, SPACE=LPS";

/// Write `mesh` as binary STL (f32 coordinates, unit normals from the
/// triangles' geometry, zero for a degenerate triangle).
pub fn write(path: &Path, mesh: &TriMesh) -> Result<()> {
    check(mesh).map_err(|e| Error::write(path, e))?;
    write_atomic(path, |w| encode(w, mesh))
}

/// Indices in range, finite coordinates, a count that fits STL's u32.
pub(crate) fn check(mesh: &TriMesh) -> io::Result<()> {
    let invalid = |m: String| io::Error::new(io::ErrorKind::InvalidInput, m);
    let n = mesh.vertices.len();
    if let Some(t) = mesh
        .triangles
        .iter()
        .position(|t| t.iter().any(|&i| i as usize >= n))
    {
        return Err(invalid(format!(
            "triangle {t} refers to a vertex beyond the {n} vertices"
        )));
    }
    if let Some(v) = mesh
        .vertices
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        return Err(invalid(format!(
            "vertex {v} has a NaN or infinite coordinate"
        )));
    }
    if u32::try_from(mesh.triangles.len()).is_err() {
        return Err(invalid(format!(
            "{} triangles: too many for STL",
            mesh.triangles.len()
        )));
    }
    Ok(())
}

fn encode(w: &mut impl Write, mesh: &TriMesh) -> io::Result<()> {
    let mut header = [b' '; 80];
    header[..HEADER.len()].copy_from_slice(HEADER.as_bytes());
    w.write_all(&header)?;
    w.write_all(&(mesh.triangles.len() as u32).to_le_bytes())?;
    let lps = |i: u32| {
        let p = mesh.vertices[i as usize];
        nalgebra::Vector3::from(mesh.frame.convert(Frame::Lps, [p.x, p.y, p.z]))
    };
    // Buffer many records per write: one 50-byte write per triangle is slow.
    let mut buf = Vec::with_capacity(50 * 8192);
    for chunk in mesh.triangles.chunks(8192) {
        buf.clear();
        for &[a, b, c] in chunk {
            let (pa, pb, pc) = (lps(a), lps(b), lps(c));
            let n = (pb - pa)
                .cross(&(pc - pa))
                .try_normalize(0.0)
                .unwrap_or_default();
            for v in [n, pa, pb, pc] {
                for k in 0..3 {
                    buf.extend_from_slice(&(v[k] as f32).to_le_bytes());
                }
            }
            buf.extend_from_slice(&[0, 0]);
        }
        w.write_all(&buf)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scratch::scratch;
    use coapt_geom::trimesh::octahedron;

    fn f32_at(b: &[u8], at: usize) -> f32 {
        f32::from_le_bytes(b[at..at + 4].try_into().unwrap())
    }

    #[test]
    fn layout_normals_and_frame() {
        let mut m = octahedron();
        m.vertices[0].y = 0.25; // make the RAS → LPS flip visible
        let d = scratch("stl");
        for frame in [Frame::Lps, Frame::Ras] {
            m.frame = frame;
            let p = d.join(format!("o-{frame}.stl"));
            write(&p, &m).unwrap();
            let b = std::fs::read(&p).unwrap();
            assert_eq!(b.len(), 84 + 50 * 8);
            let header = String::from_utf8_lossy(&b[..80]);
            assert!(
                header.contains("coapt")
                    && header.contains("LPS mm")
                    && !header.starts_with("solid")
            );
            assert_eq!(u32::from_le_bytes(b[80..84].try_into().unwrap()), 8);
            let sign = if frame == Frame::Ras { -1.0 } else { 1.0 };
            // Triangle 0, first corner: vertex 0 = (1, 0.25, 0) in the mesh frame.
            assert_eq!(
                [f32_at(&b, 96), f32_at(&b, 100), f32_at(&b, 104)],
                [sign, 0.25 * sign, 0.0]
            );
            for t in 0..8 {
                let r = 84 + 50 * t;
                let n = nalgebra::Vector3::new(f32_at(&b, r), f32_at(&b, r + 4), f32_at(&b, r + 8));
                let c = (1..4).fold(nalgebra::Vector3::zeros(), |s, k| {
                    s + nalgebra::Vector3::new(
                        f32_at(&b, r + 12 * k),
                        f32_at(&b, r + 12 * k + 4),
                        f32_at(&b, r + 12 * k + 8),
                    )
                });
                assert!((n.norm() - 1.0).abs() < 1e-6);
                assert!(n.dot(&c) > 0.0, "normal of triangle {t} points inward");
            }
        }
    }

    #[test]
    fn refuses_bad_mesh() {
        let mut m = octahedron();
        m.triangles[3] = [0, 1, 6];
        let d = scratch("stl");
        let p = d.join("bad.stl");
        assert!(write(&p, &m).is_err());
        assert!(!p.exists());
    }
}
