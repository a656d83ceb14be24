//! Binary PLY (little-endian), for mesh tools that read it (MeshLab,
//! Blender, CloudCompare). Coordinates are written in LPS millimetres (a RAS
//! mesh is converted), with a `comment frame LPS` line saying so.

use std::io::{self, Write};
use std::path::Path;

use crate::write_atomic;
use coapt_base::{Error, Result};
use coapt_geom::{DataArray, DataValues, Frame, TriMesh};

/// Write `mesh` as binary little-endian PLY: `double x y z`, then every
/// one-component numeric point-data array as an extra vertex property;
/// faces as `list uchar int vertex_indices`.
pub fn write(path: &Path, mesh: &TriMesh) -> Result<()> {
    super::stl::check(mesh).map_err(|e| Error::write(path, e))?;
    if i32::try_from(mesh.vertices.len()).is_err() {
        let e = io::Error::new(
            io::ErrorKind::InvalidInput,
            "too many vertices for PLY's int indices",
        );
        return Err(Error::write(path, e));
    }
    if let Some(a) = mesh
        .point_data
        .iter()
        .find(|a| a.tuples() != mesh.vertices.len())
    {
        let msg = format!(
            "point data '{}' has {} tuples for {} vertices",
            a.name,
            a.tuples(),
            mesh.vertices.len()
        );
        return Err(Error::write(
            path,
            io::Error::new(io::ErrorKind::InvalidInput, msg),
        ));
    }
    write_atomic(path, |w| encode(w, mesh))
}

/// A point-data array written as a vertex property.
struct Property<'a> {
    name: String,
    values: &'a DataValues,
}

impl Property<'_> {
    /// PLY has no 64-bit integers: Int64 goes out as double (exact to 2^53).
    fn ply_type(&self) -> &'static str {
        match self.values {
            DataValues::F32(_) => "float",
            DataValues::I32(_) => "int",
            DataValues::U8(_) => "uchar",
            _ => "double",
        }
    }

    fn push(&self, i: usize, out: &mut Vec<u8>) {
        match self.values {
            DataValues::F64(v) => out.extend_from_slice(&v[i].to_le_bytes()),
            DataValues::F32(v) => out.extend_from_slice(&v[i].to_le_bytes()),
            DataValues::I64(v) => out.extend_from_slice(&(v[i] as f64).to_le_bytes()),
            DataValues::I32(v) => out.extend_from_slice(&v[i].to_le_bytes()),
            DataValues::U8(v) => out.push(v[i]),
            DataValues::Str(_) => unreachable!("strings are not selected"),
        }
    }
}

/// Scalar numeric arrays, named as PLY tokens; names that would clash with
/// the coordinates or an earlier property are skipped rather than guessed.
fn properties(mesh: &TriMesh) -> Vec<Property<'_>> {
    let mut used: Vec<String> = vec!["x".into(), "y".into(), "z".into()];
    let mut out = Vec::new();
    let scalar = |a: &&DataArray| a.components == 1 && !matches!(a.values, DataValues::Str(_));
    for a in mesh.point_data.iter().filter(scalar) {
        let name: String = a
            .name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        if name.is_empty() || used.contains(&name) {
            continue;
        }
        used.push(name.clone());
        out.push(Property {
            name,
            values: &a.values,
        });
    }
    out
}

fn encode(w: &mut impl Write, mesh: &TriMesh) -> io::Result<()> {
    let props = properties(mesh);
    let mut header = String::from(
        "ply\nformat binary_little_endian 1.0\ncomment coapt triangle mesh, units mm\n",
    );
    header.push_str("comment frame LPS\n");
    header.push_str(&format!("element vertex {}\n", mesh.vertices.len()));
    header.push_str("property double x\nproperty double y\nproperty double z\n");
    for p in &props {
        header.push_str(&format!("property {} {}\n", p.ply_type(), p.name));
    }
    header.push_str(&format!("element face {}\n", mesh.triangles.len()));
    header.push_str("property list uchar int vertex_indices\nend_header\n");
    w.write_all(header.as_bytes())?;

    let mut buf = Vec::with_capacity(1 << 20);
    for (i, p) in mesh.vertices.iter().enumerate() {
        for c in mesh.frame.convert(Frame::Lps, [p.x, p.y, p.z]) {
            buf.extend_from_slice(&c.to_le_bytes());
        }
        for prop in &props {
            prop.push(i, &mut buf);
        }
        if buf.len() > (1 << 20) - 256 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    for t in &mesh.triangles {
        buf.push(3);
        for &i in t {
            buf.extend_from_slice(&(i as i32).to_le_bytes());
        }
        if buf.len() > (1 << 20) - 16 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    w.write_all(&buf)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scratch::scratch;
    use coapt_geom::Point3;

    fn mesh() -> TriMesh {
        let v = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.5]];
        let mut m = TriMesh::new(
            v.iter().map(|p| Point3::from(*p)).collect(),
            vec![[0, 1, 2], [0, 2, 3]],
        );
        m.point_data.insert(DataArray::scalars_f64(
            "thickness mm",
            vec![0.4, 0.5, 0.6, 0.7],
        ));
        m.point_data.insert(DataArray::new(
            "boundary",
            1,
            DataValues::U8(vec![1, 0, 2, 1]),
        ));
        m.point_data.insert(DataArray::new(
            "id",
            1,
            DataValues::I64(vec![-1, 5, 7, 1 << 40]),
        ));
        m.point_data.insert(DataArray::new(
            "f",
            1,
            DataValues::F32(vec![0.5, 1.5, 2.5, 3.5]),
        ));
        m.point_data
            .insert(DataArray::new("i", 1, DataValues::I32(vec![-7, 0, 7, 9])));
        m.point_data
            .insert(DataArray::new("ref_uv", 2, DataValues::F64(vec![0.0; 8])));
        m.point_data
            .insert(DataArray::scalars_f64("x", vec![9.0; 4]));
        m
    }

    #[test]
    fn header_and_records() {
        let mut m = mesh();
        m.frame = Frame::Ras;
        let d = scratch("ply");
        let p = d.join("m.ply");
        write(&p, &m).unwrap();
        let b = std::fs::read(&p).unwrap();
        let end = b.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        let header = std::str::from_utf8(&b[..end]).unwrap();
        let want = "ply\nformat binary_little_endian 1.0\ncomment coapt triangle mesh, units mm\n\
                    comment frame LPS\nelement vertex 4\nproperty double x\nproperty double y\n\
                    property double z\nproperty double thickness_mm\nproperty uchar boundary\n\
                    property double id\nproperty float f\nproperty int i\nelement face 2\n\
                    property list uchar int vertex_indices\nend_header\n";
        assert_eq!(header, want);
        // Vertex record: 3 doubles, double, uchar, double, float, int = 49 bytes.
        let rec = 49;
        assert_eq!(b.len(), end + 4 * rec + 2 * 13);
        let f64_at = |at: usize| f64::from_le_bytes(b[at..at + 8].try_into().unwrap());
        // Vertex 1 = (1, 0, 0) RAS → (-1, -0, 0) LPS.
        assert_eq!(f64_at(end + rec), -1.0);
        assert_eq!(f64_at(end + rec + 24), 0.5);
        assert_eq!(b[end + rec + 32], 0);
        assert_eq!(f64_at(end + 3 * rec + 33), (1u64 << 40) as f64);
        let faces = end + 4 * rec;
        assert_eq!(b[faces], 3);
        assert_eq!(
            i32::from_le_bytes(b[faces + 14..faces + 18].try_into().unwrap()),
            0
        );
        assert_eq!(
            i32::from_le_bytes(b[faces + 22..faces + 26].try_into().unwrap()),
            3
        );
    }

    #[test]
    fn refuses_bad_mesh() {
        let mut m = mesh();
        m.vertices[2].z = f64::NAN;
        let d = scratch("ply");
        let p = d.join("bad.ply");
        assert!(write(&p, &m).is_err());
        assert!(!p.exists());
    }
}
