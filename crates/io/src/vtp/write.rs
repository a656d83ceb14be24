//! Writing VTK XML PolyData: one piece, all data in a raw appended block,
//! optionally zlib-compressed in vtkZLibDataCompressor's block format.

use std::fmt::Write as _;
use std::io::{self, Write};

use rayon::prelude::*;

use super::WriteOptions;
use coapt_geom::{DataArray, DataValues, Point3, PolyData};

/// Uncompressed size of one compressed block. VTK's default is 32 KiB;
/// larger blocks compress a little better and any reader handles them.
const BLOCK: usize = 1 << 18;
/// zlib level: VTK's default is 5; 1 costs ~5% in size and is several times faster.
const LEVEL: u32 = 1;

/// The bytes of one array, borrowed from the dataset where possible so that
/// large arrays are converted to little-endian one block at a time.
enum Payload<'a> {
    F64(&'a [f64]),
    F32(&'a [f32]),
    I64(&'a [i64]),
    I32(&'a [i32]),
    U8(&'a [u8]),
    /// Coordinates, written as Float64 x y z.
    Points(&'a [Point3]),
    /// Triangle corners, written as Int64.
    Triangles(&'a [[u32; 3]]),
    /// Offsets 3, 6, 9, … of `n` triangles, written as Int64.
    TriangleEnds(usize),
    /// Small or irregular data (polylines, strings), already little-endian.
    Bytes(Vec<u8>),
}

macro_rules! le_into {
    ($iter:expr, $out:expr) => {
        for x in $iter {
            $out.extend_from_slice(&x.to_le_bytes());
        }
    };
}

impl Payload<'_> {
    fn elem_size(&self) -> usize {
        match self {
            Payload::F32(_) | Payload::I32(_) => 4,
            Payload::U8(_) | Payload::Bytes(_) => 1,
            _ => 8,
        }
    }

    fn elems(&self) -> usize {
        match self {
            Payload::F64(v) => v.len(),
            Payload::F32(v) => v.len(),
            Payload::I64(v) => v.len(),
            Payload::I32(v) => v.len(),
            Payload::U8(v) => v.len(),
            Payload::Points(v) => 3 * v.len(),
            Payload::Triangles(v) => 3 * v.len(),
            Payload::TriangleEnds(n) => *n,
            Payload::Bytes(v) => v.len(),
        }
    }

    fn byte_len(&self) -> usize {
        self.elems() * self.elem_size()
    }

    /// Append elements `start..start + n` as little-endian bytes.
    fn fill(&self, start: usize, n: usize, out: &mut Vec<u8>) {
        out.reserve(n * self.elem_size());
        match self {
            Payload::F64(v) => le_into!(&v[start..start + n], out),
            Payload::F32(v) => le_into!(&v[start..start + n], out),
            Payload::I64(v) => le_into!(&v[start..start + n], out),
            Payload::I32(v) => le_into!(&v[start..start + n], out),
            Payload::U8(v) => out.extend_from_slice(&v[start..start + n]),
            Payload::Bytes(v) => out.extend_from_slice(&v[start..start + n]),
            Payload::Points(v) => {
                let flat = v[start / 3..].iter().flat_map(|p| [p.x, p.y, p.z]);
                le_into!(flat.skip(start % 3).take(n), out)
            }
            Payload::Triangles(v) => {
                let flat = v[start / 3..].iter().flat_map(|t| t.map(i64::from));
                le_into!(flat.skip(start % 3).take(n), out)
            }
            Payload::TriangleEnds(_) => {
                le_into!((start..start + n).map(|i| 3 * (i as i64 + 1)), out)
            }
        }
    }

    /// Element ranges of the compression blocks.
    fn blocks(&self) -> Vec<(usize, usize)> {
        let per = BLOCK / self.elem_size();
        let n = self.elems();
        (0..n.div_ceil(per))
            .map(|b| (b * per, per.min(n - b * per)))
            .collect()
    }
}

/// One array as it appears in the XML, with its appended payload.
struct Entry<'a> {
    xml_attrs: String,
    /// `Array` for strings (vtkStringArray), `DataArray` otherwise, as VTK does.
    tag: &'static str,
    payload: Payload<'a>,
    /// Compressed blocks (when compressing), computed before the XML is
    /// written because the offsets depend on their sizes.
    compressed: Option<Vec<Vec<u8>>>,
}

impl Entry<'_> {
    fn appended_len(&self) -> usize {
        match &self.compressed {
            None => 8 + self.payload.byte_len(),
            Some(blocks) => 8 * (3 + blocks.len()) + blocks.iter().map(Vec::len).sum::<usize>(),
        }
    }

    fn compress(&mut self) {
        let blocks = self.payload.blocks();
        let payload = &self.payload;
        // Each block is compressed on its own, so the bytes do not depend on
        // how rayon schedules them.
        self.compressed = Some(
            blocks
                .par_iter()
                .map(|&(start, n)| {
                    let mut raw = Vec::with_capacity(BLOCK);
                    payload.fill(start, n, &mut raw);
                    let mut z = flate2::write::ZlibEncoder::new(
                        Vec::with_capacity(raw.len() / 2 + 64),
                        flate2::Compression::new(LEVEL),
                    );
                    z.write_all(&raw).expect("writing to a Vec cannot fail");
                    z.finish().expect("writing to a Vec cannot fail")
                })
                .collect(),
        );
    }

    fn write_appended(&self, w: &mut impl Write) -> io::Result<()> {
        let total = self.payload.byte_len();
        match &self.compressed {
            Some(blocks) => {
                let last = total % BLOCK;
                let mut header = Vec::with_capacity(8 * (3 + blocks.len()));
                for v in [blocks.len(), BLOCK, last]
                    .into_iter()
                    .chain(blocks.iter().map(Vec::len))
                {
                    header.extend_from_slice(&(v as u64).to_le_bytes());
                }
                w.write_all(&header)?;
                for b in blocks {
                    w.write_all(b)?;
                }
            }
            None => {
                w.write_all(&(total as u64).to_le_bytes())?;
                let mut buf = Vec::with_capacity(BLOCK);
                for (start, n) in self.payload.blocks() {
                    buf.clear();
                    self.payload.fill(start, n, &mut buf);
                    w.write_all(&buf)?;
                }
            }
        }
        Ok(())
    }
}

fn invalid(msg: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, msg)
}

fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\n' => out.push_str("&#10;"),
            '\t' => out.push_str("&#9;"),
            '\r' => out.push_str("&#13;"),
            c => out.push(c),
        }
    }
    out
}

fn data_entry<'a>(a: &'a DataArray, field: bool) -> io::Result<Entry<'a>> {
    if a.components == 0 {
        return Err(invalid(format!("data array '{}' has 0 components", a.name)));
    }
    let payload = match &a.values {
        DataValues::F64(v) => Payload::F64(v),
        DataValues::F32(v) => Payload::F32(v),
        DataValues::I64(v) => Payload::I64(v),
        DataValues::I32(v) => Payload::I32(v),
        DataValues::U8(v) => Payload::U8(v),
        DataValues::Str(v) => {
            let mut bytes = Vec::new();
            for s in v {
                if s.contains('\0') {
                    return Err(invalid(format!(
                        "string array '{}' holds a NUL character",
                        a.name
                    )));
                }
                bytes.extend_from_slice(s.as_bytes());
                bytes.push(0);
            }
            Payload::Bytes(bytes)
        }
    };
    let mut attrs = format!(
        "type=\"{}\" Name=\"{}\"",
        a.values.vtk_type(),
        escape(&a.name)
    );
    if a.components != 1 {
        write!(attrs, " NumberOfComponents=\"{}\"", a.components).expect("String");
    }
    if field {
        write!(attrs, " NumberOfTuples=\"{}\"", a.tuples()).expect("String");
    }
    let tag = if matches!(a.values, DataValues::Str(_)) {
        "Array"
    } else {
        "DataArray"
    };
    Ok(Entry {
        xml_attrs: attrs,
        tag,
        payload,
        compressed: None,
    })
}

fn plain_entry<'a>(ty: &str, name: &str, components: usize, payload: Payload<'a>) -> Entry<'a> {
    let mut xml_attrs = format!("type=\"{ty}\" Name=\"{name}\"");
    if components != 1 {
        write!(xml_attrs, " NumberOfComponents=\"{components}\"").expect("String");
    }
    Entry {
        xml_attrs,
        tag: "DataArray",
        payload,
        compressed: None,
    }
}

fn le_i64(values: impl Iterator<Item = i64>) -> Vec<u8> {
    values.flat_map(i64::to_le_bytes).collect()
}

/// XML sections in document order, each with its entries.
struct Section<'a> {
    open: String,
    close: &'static str,
    indent: &'static str,
    entries: Vec<Entry<'a>>,
}

fn attribute_section<'a>(
    open: &str,
    close: &'static str,
    arrays: impl Iterator<Item = &'a DataArray>,
    field: bool,
) -> io::Result<Section<'a>> {
    Ok(Section {
        open: open.to_owned(),
        close,
        indent: if field { "      " } else { "        " },
        entries: arrays
            .map(|a| data_entry(a, field))
            .collect::<io::Result<_>>()?,
    })
}

pub fn encode(w: &mut impl Write, pd: &PolyData, opts: &WriteOptions) -> io::Result<()> {
    let mut sections: Vec<Section> = Vec::new();
    // Every coapt .vtp records its frame (field data `frame`,
    // docs/artifacts.md); absent means LPS.
    let default_frame = DataArray::string("frame", "LPS");
    let frame = pd
        .field_data
        .get("frame")
        .is_none()
        .then_some(&default_frame);
    sections.push(attribute_section(
        "    <FieldData>",
        "    </FieldData>",
        frame.into_iter().chain(pd.field_data.iter()),
        true,
    )?);
    let piece_open = format!(
        "    <Piece NumberOfPoints=\"{}\" NumberOfVerts=\"0\" NumberOfLines=\"{}\" NumberOfStrips=\"0\" NumberOfPolys=\"{}\">",
        pd.points.len(),
        pd.lines.len(),
        pd.triangles.len()
    );
    let piece = sections.len();
    if !pd.point_data.is_empty() {
        sections.push(attribute_section(
            "      <PointData>",
            "      </PointData>",
            pd.point_data.iter(),
            false,
        )?);
    }
    if !pd.cell_data.is_empty() {
        sections.push(attribute_section(
            "      <CellData>",
            "      </CellData>",
            pd.cell_data.iter(),
            false,
        )?);
    }
    sections.push(Section {
        open: "      <Points>".into(),
        close: "      </Points>",
        indent: "        ",
        entries: vec![plain_entry(
            "Float64",
            "Points",
            3,
            Payload::Points(&pd.points),
        )],
    });
    if !pd.lines.is_empty() {
        let conn = le_i64(pd.lines.iter().flatten().map(|&i| i64::from(i)));
        let ends = le_i64(pd.lines.iter().scan(0i64, |end, l| {
            *end += l.len() as i64;
            Some(*end)
        }));
        sections.push(Section {
            open: "      <Lines>".into(),
            close: "      </Lines>",
            indent: "        ",
            entries: vec![
                plain_entry("Int64", "connectivity", 1, Payload::Bytes(conn)),
                plain_entry("Int64", "offsets", 1, Payload::Bytes(ends)),
            ],
        });
    }
    if !pd.triangles.is_empty() {
        sections.push(Section {
            open: "      <Polys>".into(),
            close: "      </Polys>",
            indent: "        ",
            entries: vec![
                plain_entry(
                    "Int64",
                    "connectivity",
                    1,
                    Payload::Triangles(&pd.triangles),
                ),
                plain_entry(
                    "Int64",
                    "offsets",
                    1,
                    Payload::TriangleEnds(pd.triangles.len()),
                ),
            ],
        });
    }
    if opts.compress {
        for e in sections.iter_mut().flat_map(|s| s.entries.iter_mut()) {
            e.compress();
        }
    }

    let mut xml = String::from("<?xml version=\"1.0\"?>\n");
    xml.push_str("<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\"");
    if opts.compress {
        xml.push_str(" compressor=\"vtkZLibDataCompressor\"");
    }
    xml.push_str(">\n  <PolyData>\n");
    let mut offset = 0usize;
    for (i, s) in sections.iter().enumerate() {
        if i == piece {
            xml.push_str(&piece_open);
            xml.push('\n');
        }
        xml.push_str(&s.open);
        xml.push('\n');
        for e in &s.entries {
            writeln!(
                xml,
                "{}<{} {} format=\"appended\" offset=\"{offset}\"/>",
                s.indent, e.tag, e.xml_attrs
            )
            .expect("String");
            offset += e.appended_len();
        }
        xml.push_str(s.close);
        xml.push('\n');
    }
    xml.push_str("    </Piece>\n  </PolyData>\n  <AppendedData encoding=\"raw\">\n   _");
    w.write_all(xml.as_bytes())?;
    for e in sections.iter().flat_map(|s| s.entries.iter()) {
        e.write_appended(w)?;
    }
    w.write_all(b"\n  </AppendedData>\n</VTKFile>\n")
}
