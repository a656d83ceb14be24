//! Parsing VTK XML PolyData as VTK, ParaView and 3D Slicer write it: ascii,
//! inline base64 ("binary") and appended (raw or base64) data, optionally
//! zlib-compressed, little- or big-endian, with 32- or 64-bit headers.

use std::borrow::Cow;

use base64::engine::general_purpose::{GeneralPurpose, GeneralPurposeConfig};
use base64::{DecodeError, Engine as _, alphabet};
use rayon::prelude::*;
use roxmltree::{Document, Node};

use coapt_base::{Error, Result};
use coapt_geom::{Attributes, DataArray, DataValues, Point3, PolyData};

/// How binary data in this file is laid out (from the `VTKFile` attributes).
struct Layout<'a> {
    little_endian: bool,
    header64: bool,
    zlib: bool,
    /// Bytes after the `_` marker of `<AppendedData>`, if any.
    appended: Option<&'a [u8]>,
    appended_base64: bool,
    /// Every `offset` attribute in the document, sorted: a base64 appended
    /// array ends where the next one starts.
    offsets: Vec<usize>,
}

fn err(msg: impl Into<String>) -> Error {
    Error::value(msg)
}

pub fn parse(bytes: &[u8]) -> Result<PolyData> {
    let (xml, appended) = split_appended(bytes)?;
    let doc = Document::parse(&xml).map_err(|e| err(format!("not well-formed XML: {e}")))?;
    let root = doc.root_element();
    if root.tag_name().name() != "VTKFile" {
        return Err(err(format!(
            "root element is <{}>, not <VTKFile>: not a VTK XML file",
            root.tag_name().name()
        )));
    }
    match root.attribute("type") {
        Some("PolyData") => {}
        Some(t) => {
            return Err(err(format!(
                "this is a VTK {t} file, not PolyData; extract its surface \
                 (ParaView: Filters › Extract Surface) and save it as .vtp"
            )));
        }
        None => return Err(err("<VTKFile> has no type attribute")),
    }
    let layout = layout(root, appended, &doc)?;
    let poly = child(root, "PolyData").ok_or_else(|| err("<VTKFile> has no <PolyData> element"))?;
    let pieces: Vec<Node> = elements(poly, "Piece").collect();
    let piece = match pieces.as_slice() {
        [p] => *p,
        [] => return Err(err("<PolyData> has no <Piece>")),
        many => {
            return Err(err(format!(
                "the file has {} pieces; coapt reads single-piece files: merge them \
                 (ParaView: Filters › Merge Blocks, or VTK's vtkAppendPolyData) and save again",
                many.len()
            )));
        }
    };
    let pd = read_piece(piece, poly, &layout)?;
    pd.sanity_check()?;
    Ok(pd)
}

/// Split the file at `<AppendedData`: raw appended bytes are not UTF-8, so
/// only the XML before them (closed artificially) goes to the XML parser.
fn split_appended(bytes: &[u8]) -> Result<(Cow<'_, str>, Option<&[u8]>)> {
    let Some(start) = find(bytes, b"<AppendedData") else {
        let text =
            std::str::from_utf8(bytes).map_err(|e| err(format!("not a UTF-8 XML file: {e}")))?;
        return Ok((Cow::Borrowed(text), None));
    };
    let tag_end = start
        + bytes[start..]
            .iter()
            .position(|&b| b == b'>')
            .ok_or_else(|| err("<AppendedData> tag is not closed"))?;
    let head = std::str::from_utf8(&bytes[..start])
        .map_err(|e| err(format!("not a UTF-8 XML file: {e}")))?;
    let tag = std::str::from_utf8(&bytes[start..tag_end])
        .map_err(|_| err("<AppendedData> tag is not UTF-8"))?
        .trim_end_matches('/');
    let rest = &bytes[tag_end + 1..];
    let underscore = rest
        .iter()
        .position(|&b| !b.is_ascii_whitespace())
        .filter(|&i| rest[i] == b'_')
        .ok_or_else(|| err("<AppendedData> does not start with the '_' marker"))?;
    let xml = format!("{head}{tag}/></VTKFile>");
    Ok((Cow::Owned(xml), Some(&rest[underscore + 1..])))
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

fn layout<'a>(root: Node, appended: Option<&'a [u8]>, doc: &Document) -> Result<Layout<'a>> {
    let little_endian = match root.attribute("byte_order").unwrap_or("LittleEndian") {
        "LittleEndian" => true,
        "BigEndian" => false,
        o => {
            return Err(err(format!(
                "unknown byte_order '{o}' (expected LittleEndian or BigEndian)"
            )));
        }
    };
    let header64 = match root.attribute("header_type").unwrap_or("UInt32") {
        "UInt32" => false,
        "UInt64" => true,
        o => {
            return Err(err(format!(
                "unknown header_type '{o}' (expected UInt32 or UInt64)"
            )));
        }
    };
    let zlib = match root.attribute("compressor") {
        None | Some("") => false,
        Some("vtkZLibDataCompressor") => true,
        Some(o) => {
            return Err(err(format!(
                "data compressed with {o}; coapt reads zlib-compressed or uncompressed files: \
                 save again with zlib compression (ParaView: Save Data › Compressor Type: ZLib)"
            )));
        }
    };
    let mut offsets: Vec<usize> = doc
        .descendants()
        .filter_map(|n| n.attribute("offset"))
        .filter_map(|s| s.trim().parse().ok())
        .collect();
    offsets.sort_unstable();
    let (appended, appended_base64) = match appended {
        None => (None, false),
        Some(data) => {
            let el = child(root, "AppendedData")
                .ok_or_else(|| err("<AppendedData> is outside <VTKFile>"))?;
            match el.attribute("encoding").unwrap_or("raw") {
                "raw" => (Some(data), false),
                "base64" => {
                    // Base64 text is ASCII: it ends at the closing tag.
                    let end = data.iter().position(|&b| b == b'<').unwrap_or(data.len());
                    (Some(&data[..end]), true)
                }
                o => {
                    return Err(err(format!(
                        "unknown AppendedData encoding '{o}' (expected raw or base64)"
                    )));
                }
            }
        }
    };
    Ok(Layout {
        little_endian,
        header64,
        zlib,
        appended,
        appended_base64,
        offsets,
    })
}

fn child<'a, 'i>(n: Node<'a, 'i>, name: &str) -> Option<Node<'a, 'i>> {
    n.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
}

fn elements<'a, 'i: 'a>(n: Node<'a, 'i>, name: &'a str) -> impl Iterator<Item = Node<'a, 'i>> + 'a {
    n.children()
        .filter(move |c| c.is_element() && c.tag_name().name() == name)
}

fn count_attr(n: Node, name: &str) -> Result<usize> {
    match n.attribute(name) {
        None => Ok(0),
        Some(s) => s.trim().parse().map_err(|_| {
            err(format!(
                "<{}> {name}=\"{s}\" is not a count",
                n.tag_name().name()
            ))
        }),
    }
}

fn read_piece(piece: Node, poly: Node, layout: &Layout) -> Result<PolyData> {
    let n_points = count_attr(piece, "NumberOfPoints")?;
    let n_verts = count_attr(piece, "NumberOfVerts")?;
    let n_lines = count_attr(piece, "NumberOfLines")?;
    let n_strips = count_attr(piece, "NumberOfStrips")?;
    let n_polys = count_attr(piece, "NumberOfPolys")?;
    if n_strips > 0 {
        return Err(err(format!(
            "the file has {n_strips} triangle strips: coapt needs plain triangles; convert them \
             (ParaView: Filters › Triangulate, or VTK's vtkTriangleFilter) and save again"
        )));
    }
    let points = read_points(piece, n_points, layout)?;
    let lines = match child(piece, "Lines") {
        Some(el) => lines(el, n_lines, layout)?,
        None if n_lines == 0 => Vec::new(),
        None => {
            return Err(err(format!(
                "NumberOfLines is {n_lines} but there is no <Lines> element"
            )));
        }
    };
    let triangles = match child(piece, "Polys") {
        Some(el) => triangles(el, n_polys, layout)?,
        None if n_polys == 0 => Vec::new(),
        None => {
            return Err(err(format!(
                "NumberOfPolys is {n_polys} but there is no <Polys> element"
            )));
        }
    };
    let point_data = match child(piece, "PointData") {
        Some(el) => attributes(el, Some(n_points), "point data", layout)?,
        None => Attributes::new(),
    };
    let n_cells = n_verts
        .checked_add(n_lines)
        .and_then(|n| n.checked_add(n_polys))
        .ok_or_else(|| err("cell counts in <Piece> are impossibly large"))?;
    let mut cell_data = match child(piece, "CellData") {
        Some(el) => attributes(el, Some(n_cells), "cell data", layout)?,
        None => Attributes::new(),
    };
    if n_verts > 0 && !cell_data.is_empty() {
        // Vertex cells come first in VTK's cell order; coapt drops them.
        let keep: Vec<usize> = (n_verts..n_cells).collect();
        cell_data = cell_data.select(&keep);
    }
    let field_data = match child(poly, "FieldData") {
        Some(el) => attributes(el, None, "field data", layout)?,
        None => Attributes::new(),
    };
    Ok(PolyData {
        points,
        lines,
        triangles,
        point_data,
        cell_data,
        field_data,
    })
}

fn read_points(piece: Node, n_points: usize, layout: &Layout) -> Result<Vec<Point3>> {
    let Some(el) = child(piece, "Points") else {
        if n_points == 0 {
            return Ok(Vec::new());
        }
        return Err(err(format!(
            "NumberOfPoints is {n_points} but there is no <Points> element"
        )));
    };
    let arr = array_elements(el)
        .next()
        .ok_or_else(|| err("<Points> holds no DataArray"))?;
    let a = read_array(arr, layout, "points")?;
    if a.components != 3 {
        return Err(err(format!(
            "points have {} components, expected 3",
            a.components
        )));
    }
    let coords: Cow<[f64]> = match &a.values {
        DataValues::F64(v) => Cow::Borrowed(v),
        DataValues::Str(_) => return Err(err("points are stored as strings")),
        other => Cow::Owned(other.to_f64().expect("numeric")),
    };
    if Some(coords.len()) != n_points.checked_mul(3) {
        return Err(err(format!(
            "NumberOfPoints is {n_points} but the points array holds {} coordinates ({} points)",
            coords.len(),
            coords.len() / 3
        )));
    }
    Ok(coords
        .chunks_exact(3)
        .map(|c| Point3::new(c[0], c[1], c[2]))
        .collect())
}

fn connectivity(el: Node, n_cells: usize, layout: &Layout) -> Result<(Vec<u32>, Vec<usize>)> {
    let what = el.tag_name().name();
    let mut conn = None;
    let mut offs = None;
    for a in array_elements(el) {
        match a.attribute("Name") {
            Some("connectivity") => conn = Some(a),
            Some("offsets") => offs = Some(a),
            _ => {}
        }
    }
    let (Some(conn), Some(offs)) = (conn, offs) else {
        if n_cells == 0 {
            return Ok((Vec::new(), Vec::new()));
        }
        return Err(err(format!(
            "<{what}> lacks its connectivity or offsets array"
        )));
    };
    let conn = integers(read_array(conn, layout, what)?, what, "connectivity")?;
    let offs = integers(read_array(offs, layout, what)?, what, "offsets")?;
    if offs.len() != n_cells {
        return Err(err(format!(
            "<{what}> has {} offsets but the piece declares {n_cells} cells",
            offs.len()
        )));
    }
    let mut prev = 0usize;
    let mut ends = Vec::with_capacity(offs.len());
    for (i, &o) in offs.iter().enumerate() {
        let o = usize::try_from(o).ok().filter(|&o| o >= prev && o <= conn.len()).ok_or_else(|| {
            err(format!(
                "<{what}> offset {i} is {o}: offsets must increase and stay within the {} connectivity entries",
                conn.len()
            ))
        })?;
        ends.push(o);
        prev = o;
    }
    if prev != conn.len() {
        return Err(err(format!(
            "<{what}> offsets end at {prev} but there are {} connectivity entries",
            conn.len()
        )));
    }
    let conn = conn
        .iter()
        .map(|&i| {
            u32::try_from(i)
                .map_err(|_| err(format!("<{what}> refers to point {i}, which cannot exist")))
        })
        .collect::<Result<Vec<u32>>>()?;
    Ok((conn, ends))
}

fn lines(el: Node, n_lines: usize, layout: &Layout) -> Result<Vec<Vec<u32>>> {
    let (conn, ends) = connectivity(el, n_lines, layout)?;
    let mut start = 0;
    Ok(ends
        .iter()
        .map(|&e| {
            let line = conn[start..e].to_vec();
            start = e;
            line
        })
        .collect())
}

fn triangles(el: Node, n_polys: usize, layout: &Layout) -> Result<Vec<[u32; 3]>> {
    let (conn, ends) = connectivity(el, n_polys, layout)?;
    let mut start = 0;
    for (i, &e) in ends.iter().enumerate() {
        let k = e - start;
        if k < 3 {
            return Err(err(format!(
                "polygon {i} has {k} points: not a surface; remove degenerate cells \
                 (ParaView: Filters › Clean) and save again"
            )));
        }
        if k > 3 {
            return Err(err(format!(
                "polygon {i} has {k} points: coapt needs triangles; triangulate it \
                 (ParaView: Filters › Triangulate, or VTK's vtkTriangleFilter) and save again"
            )));
        }
        start = e;
    }
    Ok(conn.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

fn integers(a: DataArray, what: &str, name: &str) -> Result<Vec<i64>> {
    Ok(match a.values {
        DataValues::I64(v) => v,
        DataValues::I32(v) => v.into_iter().map(i64::from).collect(),
        DataValues::U8(v) => v.into_iter().map(i64::from).collect(),
        _ => {
            return Err(err(format!(
                "<{what}> {name} array is not an integer array"
            )));
        }
    })
}

fn array_elements<'a, 'i: 'a>(n: Node<'a, 'i>) -> impl Iterator<Item = Node<'a, 'i>> + 'a {
    n.children()
        .filter(|c| c.is_element() && matches!(c.tag_name().name(), "DataArray" | "Array"))
}

fn attributes(el: Node, tuples: Option<usize>, what: &str, layout: &Layout) -> Result<Attributes> {
    let mut out = Attributes::new();
    for (i, a) in array_elements(el).enumerate() {
        let name = a
            .attribute("Name")
            .map(str::to_owned)
            .unwrap_or_else(|| format!("array{i}"));
        let ctx = format!("{what} array '{name}'");
        let mut arr = read_array(a, layout, &ctx)?;
        arr.name = name;
        let expect =
            match tuples {
                Some(t) => Some(t),
                None => match a.attribute("NumberOfTuples") {
                    Some(s) => Some(s.trim().parse::<usize>().map_err(|_| {
                        err(format!("{ctx}: NumberOfTuples=\"{s}\" is not a count"))
                    })?),
                    None => None,
                },
            };
        if let Some(t) = expect {
            if Some(arr.values.len()) != t.checked_mul(arr.components) {
                return Err(err(format!(
                    "{ctx} holds {} values, expected {t} tuples × {} components",
                    arr.values.len(),
                    arr.components
                )));
            }
        }
        out.insert(arr);
    }
    Ok(out)
}

/// VTK scalar types, with their size in bytes.
#[derive(Clone, Copy, PartialEq)]
enum Ty {
    F32,
    F64,
    I8,
    I16,
    I32,
    I64,
    U8,
    U16,
    U32,
    U64,
    Str,
}

impl Ty {
    fn parse(s: &str) -> Option<Ty> {
        Some(match s {
            "Float32" => Ty::F32,
            "Float64" => Ty::F64,
            "Int8" | "Char" => Ty::I8,
            "Int16" => Ty::I16,
            "Int32" => Ty::I32,
            "Int64" => Ty::I64,
            "UInt8" => Ty::U8,
            "UInt16" => Ty::U16,
            "UInt32" => Ty::U32,
            "UInt64" => Ty::U64,
            "String" => Ty::Str,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 | Ty::Str => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::F32 | Ty::I32 | Ty::U32 => 4,
            Ty::F64 | Ty::I64 | Ty::U64 => 8,
        }
    }
}

/// Read one `<DataArray>`/`<Array>` element (name left for the caller).
fn read_array(a: Node, layout: &Layout, ctx: &str) -> Result<DataArray> {
    let ty_name = a
        .attribute("type")
        .ok_or_else(|| err(format!("{ctx}: no type attribute")))?;
    let ty = Ty::parse(ty_name).ok_or_else(|| {
        err(format!(
            "{ctx}: unsupported type \"{ty_name}\" (coapt reads Float32/64, (U)Int8/16/32/64 and String)"
        ))
    })?;
    let components = match a.attribute("NumberOfComponents") {
        None => 1,
        Some(s) => s
            .trim()
            .parse::<usize>()
            .ok()
            .filter(|&c| c > 0)
            .ok_or_else(|| {
                err(format!(
                    "{ctx}: NumberOfComponents=\"{s}\" is not a positive count"
                ))
            })?,
    };
    let format = a.attribute("format").unwrap_or("ascii");
    let values = match format {
        "ascii" => parse_ascii(&direct_text(a), ty).map_err(|e| err(format!("{ctx}: {e}")))?,
        "binary" => {
            let raw =
                decode_base64(direct_text(a).as_bytes()).map_err(|e| err(format!("{ctx}: {e}")))?;
            let payload = unpack(&raw, layout).map_err(|e| err(format!("{ctx}: {e}")))?;
            from_bytes(&payload, ty, layout.little_endian)
                .map_err(|e| err(format!("{ctx}: {e}")))?
        }
        "appended" => appended(a, ty, layout).map_err(|e| err(format!("{ctx}: {e}")))?,
        o => {
            return Err(err(format!(
                "{ctx}: unknown format \"{o}\" (expected ascii, binary or appended)"
            )));
        }
    };
    if values.len() % components != 0 {
        return Err(err(format!(
            "{ctx}: {} values is not a multiple of {components} components",
            values.len()
        )));
    }
    Ok(DataArray::new(String::new(), components, values))
}

/// Standard base64 with padding; like VTK's own reader, it ignores unused
/// low bits in the last symbol.
const BASE64: GeneralPurpose = GeneralPurpose::new(
    &alphabet::STANDARD,
    GeneralPurposeConfig::new().with_decode_allow_trailing_bits(true),
);

/// Decode VTK's base64, skipping whitespace. Padding may occur in the
/// middle: VTK encodes a compressed array's header and its data as two
/// separately padded runs, so each run (up to and including a padded
/// 4-character group) is decoded on its own.
pub(super) fn decode_base64(text: &[u8]) -> std::result::Result<Vec<u8>, String> {
    let text: Vec<u8> = text
        .iter()
        .copied()
        .filter(|c| !c.is_ascii_whitespace())
        .collect();
    if text.len() % 4 != 0 {
        return Err("base64 text ends in the middle of a 4-character group (truncated?)".into());
    }
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let mut start = 0;
    for end in (4..=text.len()).step_by(4) {
        if text[end - 1] == b'=' || end == text.len() {
            BASE64
                .decode_vec(&text[start..end], &mut out)
                .map_err(|e| match e {
                    DecodeError::InvalidByte(_, c) if c != b'=' => {
                        format!("invalid base64 character {:?}", c as char)
                    }
                    _ => "misplaced '=' padding in base64 text".to_string(),
                })?;
            start = end;
        }
    }
    Ok(out)
}

/// Text of the element itself, without nested `<InformationKey>` elements.
fn direct_text<'a>(a: Node<'a, '_>) -> Cow<'a, str> {
    let mut texts = a
        .children()
        .filter(|c| c.is_text())
        .filter_map(|c| c.text());
    match (texts.next(), texts.next()) {
        (None, _) => Cow::Borrowed(""),
        (Some(t), None) => Cow::Borrowed(t),
        (Some(t), Some(u)) => {
            let mut s = format!("{t} {u}");
            for t in texts {
                s.push(' ');
                s.push_str(t);
            }
            Cow::Owned(s)
        }
    }
}

fn appended(a: Node, ty: Ty, layout: &Layout) -> std::result::Result<DataValues, String> {
    let data = layout
        .appended
        .ok_or("format is \"appended\" but the file has no <AppendedData>")?;
    let s = a
        .attribute("offset")
        .ok_or("appended array without an offset attribute")?;
    let offset: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("offset=\"{s}\" is not a number"))?;
    if offset > data.len() {
        return Err(format!(
            "offset {offset} lies beyond the {} bytes of appended data (truncated file?)",
            data.len()
        ));
    }
    if layout.appended_base64 {
        let end = layout
            .offsets
            .iter()
            .find(|&&o| o > offset)
            .copied()
            .unwrap_or(data.len())
            .min(data.len());
        let raw = decode_base64(&data[offset..end])?;
        let payload = unpack(&raw, layout)?;
        from_bytes(&payload, ty, layout.little_endian)
    } else {
        let payload = unpack(&data[offset..], layout)?;
        from_bytes(&payload, ty, layout.little_endian)
    }
}

/// Header words (byte counts) in the file's width and byte order.
fn header_word(bytes: &[u8], i: usize, layout: &Layout) -> std::result::Result<usize, String> {
    let w = if layout.header64 { 8 } else { 4 };
    let b = bytes
        .get(i * w..(i + 1) * w)
        .ok_or("data ends inside its header (truncated file?)")?;
    let v = match (layout.header64, layout.little_endian) {
        (true, true) => u64::from_le_bytes(b.try_into().expect("8 bytes")),
        (true, false) => u64::from_be_bytes(b.try_into().expect("8 bytes")),
        (false, true) => u32::from_le_bytes(b.try_into().expect("4 bytes")) as u64,
        (false, false) => u32::from_be_bytes(b.try_into().expect("4 bytes")) as u64,
    };
    usize::try_from(v).map_err(|_| format!("header value {v} is too large"))
}

/// The payload of one array from its header onward: the counted bytes, or
/// the decompressed vtkZLibDataCompressor blocks.
fn unpack<'a>(bytes: &'a [u8], layout: &Layout) -> std::result::Result<Cow<'a, [u8]>, String> {
    let w: usize = if layout.header64 { 8 } else { 4 };
    if !layout.zlib {
        let n = header_word(bytes, 0, layout)?;
        return bytes
            .get(w..w.saturating_add(n))
            .map(Cow::Borrowed)
            .ok_or_else(|| {
                format!(
                    "header announces {n} bytes but only {} follow (truncated file?)",
                    bytes.len() - w
                )
            });
    }
    // Header: number of blocks, uncompressed block size, uncompressed size
    // of the last block (0 = full), then each block's compressed size.
    let nb = header_word(bytes, 0, layout)?;
    let bs = header_word(bytes, 1, layout)?;
    let last = header_word(bytes, 2, layout)?;
    if nb == 0 {
        return Ok(Cow::Owned(Vec::new()));
    }
    if bs == 0 || last > bs {
        return Err(format!(
            "corrupt compression header (block size {bs}, last block {last})"
        ));
    }
    let header_len = (3usize.checked_add(nb).ok_or("corrupt compression header")?)
        .checked_mul(w)
        .ok_or("corrupt compression header")?;
    if header_len > bytes.len() {
        return Err(format!(
            "compression header announces {nb} blocks but the data ends first (truncated file?)"
        ));
    }
    let mut inputs = Vec::with_capacity(nb);
    let mut pos = header_len;
    for b in 0..nb {
        let c = header_word(bytes, 3 + b, layout)?;
        let end = pos
            .checked_add(c)
            .filter(|&e| e <= bytes.len())
            .ok_or_else(|| {
                format!("compressed block {b} runs past the end of the data (truncated file?)")
            })?;
        inputs.push(&bytes[pos..end]);
        pos = end;
    }
    let last_size = if last == 0 { bs } else { last };
    let total = (nb - 1)
        .checked_mul(bs)
        .and_then(|t| t.checked_add(last_size))
        .ok_or("corrupt compression header")?;
    // zlib cannot expand more than ~1032:1; refuse before allocating.
    if total / 1100 > pos {
        return Err(format!(
            "compression header announces {total} bytes, impossible for {pos} compressed bytes"
        ));
    }
    let mut out = vec![0u8; total];
    out.par_chunks_mut(bs)
        .zip(inputs.par_iter())
        .enumerate()
        .try_for_each(|(b, (dst, src))| {
            inflate(src, dst).map_err(|e| format!("compressed block {b}: {e}"))
        })?;
    Ok(Cow::Owned(out))
}

fn inflate(src: &[u8], dst: &mut [u8]) -> std::result::Result<(), String> {
    let mut z = flate2::Decompress::new(true);
    let status = z
        .decompress(src, dst, flate2::FlushDecompress::Finish)
        .map_err(|e| format!("corrupt zlib data ({e})"))?;
    if status != flate2::Status::StreamEnd && z.total_out() as usize == dst.len() {
        // Full, yet the stream goes on ("expected 17616 bytes, got 17616").
        return Err(format!(
            "the block inflates to more than the {} bytes its header announces (corrupt)",
            dst.len()
        ));
    }
    if status != flate2::Status::StreamEnd || z.total_out() as usize != dst.len() {
        return Err(format!(
            "expected {} bytes after decompression, got {} (truncated or corrupt)",
            dst.len(),
            z.total_out()
        ));
    }
    Ok(())
}

macro_rules! decode {
    ($bytes:expr, $le:expr, $t:ty, $n:expr) => {
        $bytes.chunks_exact($n).map(|c| {
            let a: [u8; $n] = c.try_into().expect("chunk size");
            if $le {
                <$t>::from_le_bytes(a)
            } else {
                <$t>::from_be_bytes(a)
            }
        })
    };
}

fn from_bytes(bytes: &[u8], ty: Ty, le: bool) -> std::result::Result<DataValues, String> {
    if bytes.len() % ty.size() != 0 {
        return Err(format!(
            "{} bytes is not a whole number of {}-byte values",
            bytes.len(),
            ty.size()
        ));
    }
    Ok(match ty {
        Ty::F64 => DataValues::F64(decode!(bytes, le, f64, 8).collect()),
        Ty::F32 => DataValues::F32(decode!(bytes, le, f32, 4).collect()),
        Ty::I64 => DataValues::I64(decode!(bytes, le, i64, 8).collect()),
        Ty::U64 => DataValues::I64(
            decode!(bytes, le, u64, 8)
                .map(|v| {
                    i64::try_from(v).map_err(|_| format!("UInt64 value {v} does not fit in Int64"))
                })
                .collect::<std::result::Result<_, _>>()?,
        ),
        Ty::U32 => DataValues::I64(decode!(bytes, le, u32, 4).map(i64::from).collect()),
        Ty::I32 => DataValues::I32(decode!(bytes, le, i32, 4).collect()),
        Ty::I16 => DataValues::I32(decode!(bytes, le, i16, 2).map(i32::from).collect()),
        Ty::U16 => DataValues::I32(decode!(bytes, le, u16, 2).map(i32::from).collect()),
        Ty::I8 => DataValues::I32(bytes.iter().map(|&b| b as i8 as i32).collect()),
        Ty::U8 => DataValues::U8(bytes.to_vec()),
        Ty::Str => DataValues::Str(split_strings(bytes)),
    })
}

/// vtkStringArray data: each string followed by a NUL byte.
fn split_strings(bytes: &[u8]) -> Vec<String> {
    let body = bytes.strip_suffix(&[0]).unwrap_or(bytes);
    if bytes.is_empty() {
        return Vec::new();
    }
    body.split(|&b| b == 0)
        .map(|s| String::from_utf8_lossy(s).into_owned())
        .collect()
}

fn parse_ascii(text: &str, ty: Ty) -> std::result::Result<DataValues, String> {
    let tokens = text.split_ascii_whitespace();
    let bad = |t: &str, i: usize| format!("value {i} \"{t}\" is not a number (ascii data)");
    fn ints<T: TryFrom<i64>>(
        tokens: std::str::SplitAsciiWhitespace,
        bad: impl Fn(&str, usize) -> String,
    ) -> std::result::Result<Vec<T>, String> {
        tokens
            .enumerate()
            .map(|(i, t)| {
                t.parse::<i64>()
                    .ok()
                    .and_then(|v| T::try_from(v).ok())
                    .ok_or_else(|| bad(t, i))
            })
            .collect()
    }
    Ok(match ty {
        Ty::F64 => DataValues::F64(
            tokens
                .enumerate()
                .map(|(i, t)| t.parse::<f64>().map_err(|_| bad(t, i)))
                .collect::<std::result::Result<_, _>>()?,
        ),
        Ty::F32 => DataValues::F32(
            tokens
                .enumerate()
                .map(|(i, t)| t.parse::<f32>().map_err(|_| bad(t, i)))
                .collect::<std::result::Result<_, _>>()?,
        ),
        Ty::I64 | Ty::U32 | Ty::U64 => DataValues::I64(ints(tokens, bad)?),
        Ty::I8 => DataValues::I32(
            ints::<i8>(tokens, bad)?
                .into_iter()
                .map(i32::from)
                .collect(),
        ),
        Ty::I16 => DataValues::I32(
            ints::<i16>(tokens, bad)?
                .into_iter()
                .map(i32::from)
                .collect(),
        ),
        Ty::U16 => DataValues::I32(
            ints::<u16>(tokens, bad)?
                .into_iter()
                .map(i32::from)
                .collect(),
        ),
        Ty::I32 => DataValues::I32(ints(tokens, bad)?),
        Ty::U8 => DataValues::U8(ints(tokens, bad)?),
        // Strings in ascii are written as character codes, each string
        // NUL-terminated; VTK prints bytes above 127 as negative (signed) chars.
        Ty::Str => {
            let codes: Vec<i64> = ints(tokens, bad)?;
            let bytes = codes
                .iter()
                .map(|&c| u8::try_from(c).or_else(|_| i8::try_from(c).map(|b| b as u8)))
                .collect::<std::result::Result<Vec<u8>, _>>()
                .map_err(|_| "character code out of range in ascii string data".to_string())?;
            DataValues::Str(split_strings(&bytes))
        }
    })
}

#[cfg(test)]
mod inflate_tests {
    use super::inflate;

    fn zlib(bytes: &[u8]) -> Vec<u8> {
        let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        std::io::Write::write_all(&mut e, bytes).unwrap();
        e.finish().unwrap()
    }

    /// A block that inflates to more than its header says is named as such,
    /// not "expected 16 bytes, got 16".
    #[test]
    fn a_block_longer_or_shorter_than_announced_says_which() {
        let z = zlib(&[7u8; 32]);
        let mut exact = [0u8; 32];
        assert!(inflate(&z, &mut exact).is_ok());
        let e = inflate(&z, &mut [0u8; 16]).unwrap_err();
        assert!(e.contains("more than the 16 bytes"), "{e}");
        let e = inflate(&z[..z.len() / 2], &mut [0u8; 32]).unwrap_err();
        assert!(e.contains("expected 32 bytes"), "{e}");
    }
}
