use std::path::{Path, PathBuf};

use super::*;
use crate::scratch::{Scratch, scratch};
use coapt_geom::{Attributes, DataArray, DataValues, Frame, Point3};

fn tmpdir(tag: &str) -> Scratch {
    scratch(&format!("vtp-{tag}"))
}

/// Points, two polylines, triangles, and arrays of every type coapt writes.
fn sample() -> PolyData {
    let points = vec![
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, -0.0, 1e-300),
        Point3::new(1.0 / 3.0, 1.0, f64::MAX),
        Point3::new(-2.5, std::f64::consts::PI, 7.0),
        Point3::new(0.1, 0.2, 0.3),
    ];
    let lines = vec![vec![0, 1, 2], vec![3, 4]];
    let triangles = vec![[0, 1, 2], [0, 2, 3], [1, 3, 4]];
    let mut point_data = Attributes::new();
    point_data.insert(DataArray::new(
        "disp",
        3,
        DataValues::F64((0..15).map(|i| i as f64 / 7.0).collect()),
    ));
    point_data.insert(DataArray::new(
        "t",
        1,
        DataValues::F32(vec![0.5, -1.25, 3.0e-8, 7.0, f32::MAX]),
    ));
    point_data.insert(DataArray::new(
        "label",
        1,
        DataValues::I32(vec![-3, 0, 1, i32::MAX, i32::MIN]),
    ));
    point_data.insert(DataArray::new(
        "boundary",
        1,
        DataValues::U8(vec![0, 1, 2, 255, 1]),
    ));
    let mut cell_data = Attributes::new();
    cell_data.insert(DataArray::new(
        "id",
        1,
        DataValues::I64(vec![10, 11, 20, 21, i64::MIN]),
    ));
    cell_data.insert(DataArray::scalars_f64("q", vec![0.1, 0.2, 0.3, 0.4, 0.5]));
    let mut field_data = Attributes::new();
    field_data.insert(DataArray::string("frame", "LPS"));
    field_data.insert(DataArray::new(
        "pressure & <units>",
        2,
        DataValues::F64(vec![80.0, 10.665, 1.0, 2.0]),
    ));
    field_data.insert(DataArray::new(
        "notes",
        1,
        DataValues::Str(vec!["first".into(), String::new(), "ünïcode ok".into()]),
    ));
    PolyData {
        points,
        lines,
        triangles,
        point_data,
        cell_data,
        field_data,
    }
}

fn encoded(pd: &PolyData, compress: bool) -> Vec<u8> {
    let mut out = Vec::new();
    encode(&mut out, pd, &WriteOptions { compress }).unwrap();
    out
}

fn assert_bit_identical(a: &PolyData, b: &PolyData) {
    assert_eq!(a, b);
    for (p, q) in a.points.iter().zip(&b.points) {
        for k in 0..3 {
            assert_eq!(p[k].to_bits(), q[k].to_bits());
        }
    }
}

#[test]
fn round_trip_exact_compressed_and_not() {
    let pd = sample();
    pd.sanity_check().unwrap();
    for compress in [false, true] {
        let bytes = encoded(&pd, compress);
        let back = parse(&bytes).unwrap();
        assert_bit_identical(&pd, &back);
        // Deterministic: same input, same bytes.
        assert_eq!(bytes, encoded(&pd, compress));
    }
    let d = tmpdir("rt");
    let p = d.join("s.vtp");
    write(&p, &pd, &WriteOptions::default()).unwrap();
    assert_bit_identical(&pd, &read(&p).unwrap());
}

#[test]
fn header_matches_vtk_conventions() {
    let text = String::from_utf8_lossy(&encoded(&sample(), true)).into_owned();
    assert!(text.starts_with("<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\">"));
    assert!(text.contains("<Array type=\"String\" Name=\"frame\" NumberOfTuples=\"1\" format=\"appended\" offset=\"0\"/>"));
    assert!(text.contains(
        "Name=\"pressure &amp; &lt;units&gt;\" NumberOfComponents=\"2\" NumberOfTuples=\"2\""
    ));
    assert!(text.contains("<AppendedData encoding=\"raw\">"));
    let plain = String::from_utf8_lossy(&encoded(&sample(), false)).into_owned();
    assert!(!plain.contains("compressor"));
    // "LPS\0" preceded by its UInt64 byte count, as VTK writes vtkStringArray.
    let data = plain.as_bytes();
    let marker = b"<AppendedData encoding=\"raw\">\n   _";
    let us = data
        .windows(marker.len())
        .position(|w| w == marker)
        .unwrap()
        + marker.len()
        - 1;
    assert_eq!(&data[us + 1..us + 13], b"\x04\0\0\0\0\0\0\0LPS\0");
}

#[test]
fn empty_cells_are_omitted_and_empty_dataset_round_trips() {
    let mut pd = sample();
    pd.lines.clear();
    pd.cell_data = Attributes::new();
    let text = String::from_utf8_lossy(&encoded(&pd, true)).into_owned();
    assert!(!text.contains("<Lines>"));
    assert_eq!(parse(&encoded(&pd, true)).unwrap(), pd);
    // An empty dataset without a frame comes back with the default one.
    let empty = PolyData::default();
    let mut with_frame = PolyData::default();
    with_frame
        .field_data
        .insert(DataArray::string("frame", "LPS"));
    for c in [false, true] {
        let bytes = encoded(&empty, c);
        let s = String::from_utf8_lossy(&bytes);
        assert!(!s.contains("<Polys>") && !s.contains("<Lines>"));
        assert_eq!(parse(&bytes).unwrap(), with_frame);
    }
}

/// A mesh large enough to span several compression blocks.
fn grid(n: usize) -> PolyData {
    let mut points = Vec::new();
    for j in 0..n {
        for i in 0..n {
            points.push(Point3::new(
                i as f64 * 0.1,
                j as f64 * 0.37,
                ((i * j) as f64).sin(),
            ));
        }
    }
    let mut triangles = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (j * n + i) as u32;
            let (b, c, d) = (a + 1, a + n as u32, a + n as u32 + 1);
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    let mut pd = PolyData {
        points,
        triangles,
        ..Default::default()
    };
    let nt = pd.triangles.len();
    pd.cell_data.insert(DataArray::new(
        "leaflet",
        1,
        DataValues::I32((0..nt as i32).map(|t| t % 3).collect()),
    ));
    pd.point_data.insert(DataArray::scalars_f64(
        "h",
        (0..n * n).map(|i| (i as f64).sqrt()).collect(),
    ));
    pd.field_data.insert(DataArray::string("frame", "RAS"));
    pd
}

#[test]
fn multi_block_round_trip_is_thread_count_independent() {
    let pd = grid(200); // 40k points: ~1 MB of coordinates, several blocks
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    for compress in [false, true] {
        let a = one.install(|| encoded(&pd, compress));
        let b = two.install(|| encoded(&pd, compress));
        assert_eq!(a, b);
        assert!(parse(&a).unwrap() == pd);
    }
}

#[test]
fn trimesh_round_trip_keeps_frame() {
    let d = tmpdir("mesh");
    for frame in [Frame::Ras, Frame::Lps] {
        let pd = grid(5);
        let mut mesh = TriMesh::from_polydata(pd).unwrap();
        mesh.frame = frame;
        mesh.field_data.insert(DataArray::string("units", "mm"));
        let p = d.join(format!("{frame}.vtp"));
        write_mesh(&p, &mesh).unwrap();
        let back = read_mesh(&p).unwrap();
        assert_eq!(back.frame, frame);
        assert_eq!(back, mesh);
    }
}

// ---- files written by VTK (tests/data/vtp/make_fixtures.py) ----

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/vtp")
        .join(name)
}

const FIXTURES: &[&str] = &[
    "ascii.vtp",
    "binary_u32.vtp",
    "binary_u64.vtp",
    "binary_zlib_u32.vtp",
    "binary_zlib_blocks.vtp",
    "appended_raw_u32.vtp",
    "appended_raw_u64.vtp",
    "appended_base64_u32.vtp",
    "appended_base64_zlib_u64.vtp",
    "appended_raw_zlib_u64.vtp",
    "appended_raw_zlib_blocks.vtp",
    "bigendian_raw.vtp",
    "bigendian_zlib_u64.vtp",
    "bigendian_binary.vtp",
];

fn expected_fixture() -> PolyData {
    let points = vec![
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(1.0, 1.0, 0.0),
        Point3::new(0.0, 1.0, 0.1),
        Point3::new(-1.0 / 3.0, 0.5, 1e-300),
        Point3::new(2.5, -7.25, 1e10),
    ];
    let mut pd = PolyData {
        points,
        lines: vec![vec![0, 1, 2]],
        triangles: vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]],
        ..Default::default()
    };
    let p = &mut pd.point_data;
    p.insert(DataArray::new(
        "temperature",
        1,
        DataValues::F32((0..6).map(|i| 0.5 * i as f32 + 0.25).collect()),
    ));
    p.insert(DataArray::new(
        "disp",
        3,
        DataValues::F64((0..18).map(|i| i as f64 / 7.0).collect()),
    ));
    p.insert(DataArray::new(
        "label",
        1,
        DataValues::I32(vec![-3, -2, -1, 0, 1, 2]),
    ));
    p.insert(DataArray::new(
        "flag",
        1,
        DataValues::U8(vec![0, 1, 2, 250, 255, 7]),
    ));
    p.insert(DataArray::new(
        "short",
        1,
        DataValues::I32(vec![-300, 0, 1, 2, 3, 300]),
    ));
    p.insert(DataArray::new(
        "big",
        1,
        DataValues::I64(vec![-(1 << 40), 0, 1, 2, 3, 1 << 40]),
    ));
    // The vertex cell's tuple (first) is dropped.
    pd.cell_data.insert(DataArray::new(
        "cellid",
        1,
        DataValues::I32(vec![101, 102, 103, 104]),
    ));
    pd.cell_data
        .insert(DataArray::scalars_f64("quality", vec![0.1, 0.2, 0.3, 0.4]));
    let f = &mut pd.field_data;
    f.insert(DataArray::string("frame", "LPS"));
    f.insert(DataArray::new(
        "notes",
        1,
        DataValues::Str(vec!["hello world".into(), "second".into(), "é µ".into()]),
    ));
    f.insert(DataArray::scalars_f64("scale", vec![2.5, -0.125]));
    pd
}

#[test]
fn reads_every_layout_vtk_writes() {
    let want = expected_fixture();
    for name in FIXTURES {
        let got = read(&fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(got, want, "{name}");
        assert_bit_identical(&got, &want);
    }
    // Float32 points (3D Slicer's default) widen exactly to f64.
    let got = read(&fixture("points_float32_zlib.vtp")).unwrap();
    let mut want32 = want.clone();
    for p in &mut want32.points {
        for k in 0..3 {
            p[k] = p[k] as f32 as f64;
        }
    }
    assert_eq!(got, want32);
}

#[test]
fn vtk_fixture_survives_our_round_trip() {
    let pd = read(&fixture("appended_raw_zlib_blocks.vtp")).unwrap();
    assert_eq!(parse(&encoded(&pd, true)).unwrap(), pd);
}

// ---- bad input ----

fn parse_err(bytes: &[u8]) -> String {
    match parse(bytes) {
        Ok(_) => panic!("accepted bad input"),
        Err(e) => e.to_string(),
    }
}

fn ascii_doc(points: &str, polys_conn: &str, polys_offs: &str, extra_piece: &str) -> String {
    let np = points.split_whitespace().count() / 3;
    let nc = polys_offs.split_whitespace().count();
    format!(
        r#"<?xml version="1.0"?>
<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian">
  <PolyData>
    <Piece NumberOfPoints="{np}" NumberOfPolys="{nc}" {extra_piece}>
      <Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">{points}</DataArray></Points>
      <Polys>
        <DataArray type="Int64" Name="connectivity" format="ascii">{polys_conn}</DataArray>
        <DataArray type="Int64" Name="offsets" format="ascii">{polys_offs}</DataArray>
      </Polys>
    </Piece>
  </PolyData>
</VTKFile>
"#
    )
}

const SQUARE: &str = "0 0 0 1 0 0 1 1 0 0 1 0";

#[test]
fn ascii_doc_helper_is_valid() {
    let pd = parse(ascii_doc(SQUARE, "0 1 2 0 2 3", "3 6", "").as_bytes()).unwrap();
    assert_eq!(pd.triangles, vec![[0, 1, 2], [0, 2, 3]]);
}

#[test]
fn refuses_malformed_xml() {
    let e = parse_err(b"<VTKFile type=\"PolyData\"><PolyData><Piece></PolyData>");
    assert!(e.contains("not well-formed XML"), "{e}");
    let e = parse_err(b"<VTKFile type=\"UnstructuredGrid\"></VTKFile>");
    assert!(e.contains("not PolyData"), "{e}");
    let e = parse_err(&[0xff, 0xfe, 0, 1]);
    assert!(e.contains("UTF-8"), "{e}");
}

#[test]
fn refuses_truncated_appended_data() {
    let pd = grid(60);
    for compress in [false, true] {
        let bytes = encoded(&pd, compress);
        for cut in [bytes.len() - 40, bytes.len() * 3 / 4, bytes.len() / 2] {
            let e = parse_err(&bytes[..cut]);
            assert!(e.contains("truncated") || e.contains("beyond"), "{e}");
        }
    }
    // A corrupted compressed block.
    let mut bytes = encoded(&pd, true);
    let n = bytes.len();
    for b in &mut bytes[n - 2000..n - 1000] {
        *b = b.wrapping_add(1);
    }
    let e = parse_err(&bytes);
    assert!(e.contains("compressed block") || e.contains("zlib"), "{e}");
}

#[test]
fn refuses_bad_indices_quads_strips_nan_tokens() {
    let e = parse_err(ascii_doc(SQUARE, "0 1 2 0 2 99", "3 6", "").as_bytes());
    assert!(
        e.contains("triangle 1 refers to point 99, but there are only 4 points"),
        "{e}"
    );
    let e = parse_err(ascii_doc(SQUARE, "0 1 2 0 1 2 3", "3 7", "").as_bytes());
    assert!(
        e.contains("polygon 1 has 4 points") && e.contains("Triangulate"),
        "{e}"
    );
    let e = parse_err(ascii_doc(SQUARE, "0 1 2", "3", "NumberOfStrips=\"1\"").as_bytes());
    assert!(
        e.contains("triangle strips") && e.contains("Triangulate"),
        "{e}"
    );
    let e = parse_err(ascii_doc("0 0 0 1 0 0 1 x 0", "0 1 2", "3", "").as_bytes());
    assert!(e.contains("\"x\" is not a number"), "{e}");
    let e = parse_err(ascii_doc("0 0 0 1 0 0 1 nan 0", "0 1 2", "3", "").as_bytes());
    assert!(e.contains("point 2 has a NaN"), "{e}");
    let e = parse_err(ascii_doc(SQUARE, "0 1 2 3 0", "3 5", "").as_bytes());
    assert!(e.contains("polygon 1 has 2 points"), "{e}");
    let e = parse_err(ascii_doc(SQUARE, "0 1 2", "3 5", "").as_bytes());
    assert!(e.contains("offset"), "{e}");
    let e = parse_err(ascii_doc(SQUARE, "0 1 -2", "3", "").as_bytes());
    assert!(e.contains("point -2"), "{e}");
    let e = parse_err(
        ascii_doc(SQUARE, "0 1 2", "3", "")
            .replace("NumberOfPoints=\"4\"", "NumberOfPoints=\"5\"")
            .as_bytes(),
    );
    assert!(e.contains("NumberOfPoints is 5"), "{e}");
    let e = parse_err(
        ascii_doc(SQUARE, "0 1 2", "3", "")
            .replace("Float64", "Float65")
            .as_bytes(),
    );
    assert!(e.contains("unsupported type \"Float65\""), "{e}");
    let two = ascii_doc(SQUARE, "0 1 2", "3", "")
        .replace("</Piece>", "</Piece><Piece NumberOfPoints=\"0\"/>");
    let e = parse_err(two.as_bytes());
    assert!(e.contains("2 pieces"), "{e}");
}

/// Corrupt bytes anywhere must give an error or a valid dataset, never a panic.
#[test]
fn mutated_files_never_panic() {
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let mut inputs = vec![encoded(&sample(), true), encoded(&sample(), false)];
    for name in [
        "ascii.vtp",
        "binary_zlib_blocks.vtp",
        "appended_base64_u32.vtp",
        "bigendian_zlib_u64.vtp",
    ] {
        inputs.push(std::fs::read(fixture(name)).unwrap());
    }
    for base in &inputs {
        for _ in 0..300 {
            let mut b = base.clone();
            match next() % 3 {
                0 => b.truncate((next() as usize) % b.len()),
                1 => {
                    let i = (next() as usize) % b.len();
                    b[i] = next() as u8;
                }
                _ => {
                    let i = (next() as usize) % b.len();
                    let digit = b"0123456789"[(next() % 10) as usize];
                    b.insert(i, digit);
                }
            }
            if let Ok(pd) = parse(&b) {
                pd.sanity_check().unwrap();
            }
        }
    }
}

#[test]
fn read_errors_name_the_file_and_leave_nothing_on_write_failure() {
    let d = tmpdir("err");
    let p = d.join("bad.vtp");
    std::fs::write(&p, ascii_doc(SQUARE, "0 1 2 0 2 99", "3 6", "")).unwrap();
    let e = read(&p).unwrap_err().to_string();
    assert!(e.contains("bad.vtp") && e.contains("point 99"), "{e}");
    let e = read(&d.join("missing.vtp")).unwrap_err().to_string();
    assert!(e.contains("missing.vtp"), "{e}");
    // Invalid data is not written at all.
    let mut pd = sample();
    pd.triangles[0] = [0, 1, 42];
    let out = d.join("out.vtp");
    assert!(write(&out, &pd, &WriteOptions::default()).is_err());
    let mut pd = sample();
    pd.field_data.insert(DataArray::string("frame", "XYZ"));
    let e = write(&out, &pd, &WriteOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("out.vtp") && e.contains("unknown frame"), "{e}");
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
}

/// RFC 4648 vectors, and every padding length at every offset, decode back.
#[test]
fn base64_decodes_known_vectors_and_every_length() {
    use base64::Engine as _;
    for (raw, enc) in [
        ("", ""),
        ("f", "Zg=="),
        ("fo", "Zm8="),
        ("foo", "Zm9v"),
        ("foob", "Zm9vYg=="),
        ("fooba", "Zm9vYmE="),
        ("foobar", "Zm9vYmFy"),
    ] {
        assert_eq!(read::decode_base64(enc.as_bytes()).unwrap(), raw.as_bytes());
    }
    assert_eq!(read::decode_base64(b"+/8=").unwrap(), [0xfb, 0xff]);
    let all: Vec<u8> = (0..=255u8).collect();
    for start in 0..3 {
        for len in 0..=7 {
            let d = &all[start..start + 250 - len];
            let e = base64::engine::general_purpose::STANDARD.encode(d);
            assert_eq!(read::decode_base64(e.as_bytes()).unwrap(), d);
        }
    }
}

/// VTK's separately padded runs, whitespace, lenient trailing bits, and
/// the errors.
#[test]
fn base64_concatenated_runs_and_errors() {
    assert_eq!(read::decode_base64(b" Zg==\n Zm8= ").unwrap(), b"ffo");
    assert_eq!(
        read::decode_base64(b"Zg==Zm9vYmFyZg==").unwrap(),
        b"ffoobarf"
    );
    assert_eq!(read::decode_base64(b"Zh==").unwrap(), b"f");
    let e = |t: &[u8]| read::decode_base64(t).unwrap_err();
    assert!(e(b"Zm9").contains("truncated"));
    assert!(e(b"Z=9v").contains("misplaced '='"));
    assert!(e(b"Zg=A").contains("misplaced '='"));
    assert!(e(b"====").contains("misplaced '='"));
    assert!(e(b"Zm9*").contains("invalid base64 character '*'"));
}
