use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use nalgebra::{Matrix3, Matrix4, Rotation3, Unit, UnitQuaternion, Vector3};

use super::write::{header_bytes, le_bytes, write_gzip};
use super::*;
use crate::scratch::{Scratch, scratch};
use coapt_base::Error;
use coapt_base::rng::SplitMix64;
use coapt_geom::Point3;
use coapt_geom::volume::affine_from_parts;

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// A fresh, empty directory for one test.
fn tmpdir(tag: &str) -> Scratch {
    scratch(&format!("nifti-{tag}"))
}

fn random_rotation(rng: &mut SplitMix64) -> Matrix3<f64> {
    let q = nalgebra::Quaternion::new(rng.normal(), rng.normal(), rng.normal(), rng.normal());
    UnitQuaternion::from_quaternion(q)
        .to_rotation_matrix()
        .into_inner()
}

/// Random oblique affine: rotation, spacing 0.3–2 mm, origin within ±250 mm;
/// one column negated when `left_handed`.
fn random_affine(rng: &mut SplitMix64, left_handed: bool) -> Matrix4<f64> {
    let mut dir = random_rotation(rng);
    if left_handed {
        let c = (rng.next_u64() % 3) as usize;
        dir.set_column(c, &(-dir.column(c)));
    }
    let spacing = [
        rng.range(0.3, 2.0),
        rng.range(0.3, 2.0),
        rng.range(0.3, 2.0),
    ];
    let origin = Point3::new(
        rng.range(-250.0, 250.0),
        rng.range(-250.0, 250.0),
        rng.range(-250.0, 250.0),
    );
    affine_from_parts(spacing, &dir, origin)
}

fn f32_rounded(a: &Matrix4<f64>) -> Matrix4<f64> {
    a.map(|v| v as f32 as f64)
}

fn max_diff(a: &Matrix4<f64>, b: &Matrix4<f64>) -> f64 {
    (a - b).abs().max()
}

fn encode_bytes<T: NiftiWrite>(vol: &Volume<T>, gzip: bool) -> Vec<u8> {
    let mut v = Vec::new();
    encode(&mut v, vol, gzip).unwrap();
    v
}

fn gunzip(b: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    flate2::read::MultiGzDecoder::new(b)
        .read_to_end(&mut out)
        .unwrap();
    out
}

fn gzip(b: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(b).unwrap();
    e.finish().unwrap()
}

fn put_file(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn set_i16(b: &mut [u8], off: usize, v: i16) {
    b[off..off + 2].copy_from_slice(&v.to_le_bytes());
}
fn set_f32(b: &mut [u8], off: usize, v: f32) {
    b[off..off + 4].copy_from_slice(&v.to_le_bytes());
}

/// A random volume of type T with values from `gen`.
fn random_volume<T: Clone>(
    rng: &mut SplitMix64,
    dims: [usize; 3],
    left: bool,
    mut g: impl FnMut(&mut SplitMix64) -> T,
) -> Volume<T> {
    let n = dims.iter().product();
    let vals: Vec<T> = (0..n).map(|_| g(rng)).collect();
    Volume::from_fortran_vec(dims, random_affine(rng, left), vals).unwrap()
}

fn gen_u8(r: &mut SplitMix64) -> u8 {
    r.next_u64() as u8
}
fn gen_i16(r: &mut SplitMix64) -> i16 {
    r.next_u64() as i16
}
fn gen_f32(r: &mut SplitMix64) -> f32 {
    (r.normal() * 1000.0) as f32
}

/// Write with `write`, read back with `read`, check data and affine exactly,
/// then check the qform alone gives the same grid. Returns the qform error.
fn check_round_trip<T: NiftiRead + NiftiWrite + PartialEq + std::fmt::Debug>(
    dir: &Path,
    vol: &Volume<T>,
    gz: bool,
    read: impl Fn(&Path) -> coapt_base::Result<Volume<T>>,
) -> f64 {
    let name = format!(
        "v{}.nii{}",
        COUNTER.fetch_add(1, Ordering::Relaxed),
        if gz { ".gz" } else { "" }
    );
    let p = dir.join(name);
    write(&p, vol).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    assert_eq!(
        bytes[..2] == [0x1f, 0x8b],
        gz,
        "gzip iff the name ends in .gz"
    );
    let back = read(&p).unwrap();
    assert_eq!(back.dims(), vol.dims());
    assert_eq!(back.as_slice(), vol.as_slice(), "voxel data differs");
    assert_eq!(
        *back.affine(),
        f32_rounded(vol.affine()),
        "affine is not the f32-rounded input"
    );
    let h = read_header(&p).unwrap();
    assert_eq!(h.transform_source, TransformSource::Sform);

    // The qform alone must describe the same grid.
    let mut raw = if gz { gunzip(&bytes) } else { bytes };
    set_i16(&mut raw, 254, 0);
    let q = put_file(dir, "qonly.nii", &raw);
    assert_eq!(
        read_header(&q).unwrap().transform_source,
        TransformSource::Qform
    );
    let qb = read(&q).unwrap();
    assert_eq!(qb.as_slice(), vol.as_slice());
    let err = max_diff(qb.affine(), back.affine());
    assert!(err < 1e-5, "qform affine differs from sform by {err} mm");
    err
}

#[test]
fn round_trip_oblique_all_types_plain_and_gz() {
    let dir = tmpdir("rt");
    let mut rng = SplitMix64::new(42);
    let mut worst: f64 = 0.0;
    for case in 0..24 {
        let left = case % 2 == 1;
        let gz = (case / 2) % 2 == 1;
        let dims = [7, 5, 3];
        let e = match case % 3 {
            0 => check_round_trip(
                dir.as_path(),
                &random_volume(&mut rng, dims, left, gen_u8),
                gz,
                read_u8,
            ),
            1 => check_round_trip(
                dir.as_path(),
                &random_volume(&mut rng, dims, left, gen_i16),
                gz,
                read_i16,
            ),
            _ => check_round_trip(
                dir.as_path(),
                &random_volume(&mut rng, dims, left, gen_f32),
                gz,
                read_f32,
            ),
        };
        worst = worst.max(e);
    }
    assert!(worst < 1e-5, "{worst}");
}

#[test]
fn qform_is_accurate_near_half_turns() {
    // a = cos(θ/2) → 0: the worst case for NIfTI's a = sqrt(1 - b² - c² - d²).
    let dir = tmpdir("halfturn");
    let mut rng = SplitMix64::new(7);
    for i in 0..40 {
        let axis = Unit::new_normalize(Vector3::new(rng.normal(), rng.normal(), rng.normal()));
        let angle = std::f64::consts::PI - [0.0, 1e-7, 1e-5, 1e-3][i % 4];
        let mut rot = Rotation3::from_axis_angle(&axis, angle).into_inner();
        if i % 5 == 0 {
            rot.set_column(2, &(-rot.column(2)));
        }
        let a = affine_from_parts([0.44, 1.7, 2.0], &rot, Point3::new(10.0, -20.0, 30.0));
        let vol = Volume::filled([3, 4, 5], a, 7i16).unwrap();
        check_round_trip(dir.as_path(), &vol, i % 2 == 0, read_i16);
    }
}

#[test]
fn many_random_volumes_round_trip() {
    let dir = tmpdir("prop");
    let mut rng = SplitMix64::new(2024);
    for case in 0..150 {
        let dims = [
            1 + (rng.next_u64() % 9) as usize,
            1 + (rng.next_u64() % 9) as usize,
            1 + (rng.next_u64() % 9) as usize,
        ];
        let left = rng.uniform() < 0.5;
        let gz = rng.uniform() < 0.5;
        match case % 5 {
            0 => {
                check_round_trip(
                    dir.as_path(),
                    &random_volume(&mut rng, dims, left, gen_u8),
                    gz,
                    read_u8,
                );
            }
            1 => {
                check_round_trip(
                    dir.as_path(),
                    &random_volume(&mut rng, dims, left, gen_i16),
                    gz,
                    read_i16,
                );
            }
            2 => {
                check_round_trip(
                    dir.as_path(),
                    &random_volume(&mut rng, dims, left, gen_f32),
                    gz,
                    read_f32,
                );
            }
            3 => {
                let v = random_volume(&mut rng, dims, left, |r| r.next_u64() as i32);
                check_round_trip(dir.as_path(), &v, gz, |p| {
                    read_with::<i32>(p, &ReadOptions::default())
                });
            }
            _ => {
                let v = random_volume(&mut rng, dims, left, |r| r.normal());
                check_round_trip(dir.as_path(), &v, gz, |p| {
                    read_with::<f64>(p, &ReadOptions::default())
                });
            }
        }
    }
}

#[test]
fn header_fields_as_written() {
    let dir = tmpdir("hdr");
    let mut rng = SplitMix64::new(1);
    let vol = random_volume(&mut rng, [7, 5, 3], true, gen_i16);
    let p = dir.join("h.nii");
    write(&p, &vol).unwrap();
    let h = read_header(&p).unwrap();
    assert_eq!(h.version, 1);
    assert_eq!(h.endian, Endian::Little);
    assert_eq!(h.dims, [7, 5, 3]);
    assert_eq!(h.datatype, DataType::I16);
    assert_eq!(h.bytes_per_voxel, 2);
    assert_eq!(h.vox_offset, 352);
    assert_eq!(h.data_bytes, 7 * 5 * 3 * 2);
    assert_eq!(
        h.description,
        format!("coapt {}", env!("CARGO_PKG_VERSION"))
    );
    assert_eq!((h.sform_code, h.qform_code), (1, 1));
    assert_eq!(h.pixdim[0], -1.0, "left-handed grid → qfac -1");
    assert_eq!(h.scl_slope, Some(1.0));
    assert_eq!(h.scl_inter, None);
    let s = vol.spacing();
    for (stored, spacing) in h.pixdim[1..4].iter().zip(s) {
        assert_eq!(*stored, spacing as f32 as f64);
    }
    assert_eq!(std::fs::metadata(&p).unwrap().len(), 352 + 7 * 5 * 3 * 2);
}

#[test]
fn gzip_output_is_deterministic_and_sniffed_not_named() {
    let dir = tmpdir("sniff");
    let mut rng = SplitMix64::new(3);
    let vol = random_volume(&mut rng, [9, 8, 7], false, gen_i16);
    let a = encode_bytes(&vol, true);
    let b = encode_bytes(&vol, true);
    assert_eq!(a, b, "same input must give the same bytes");
    let plain = encode_bytes(&vol, false);
    assert_eq!(gunzip(&a), plain);
    // gzip content under a .nii name, plain content under a .nii.gz name
    let p1 = put_file(&dir, "really_gz.nii", &a);
    let p2 = put_file(&dir, "really_plain.nii.gz", &plain);
    assert_eq!(read_i16(&p1).unwrap(), read_i16(&p2).unwrap());
    assert_eq!(read_i16(&p1).unwrap().as_slice(), vol.as_slice());
    // Multi-member gzip (concatenated streams) is one valid file.
    let mut two = gzip(&plain[..100]);
    two.extend(gzip(&plain[100..]));
    assert_eq!(
        read_i16(&put_file(&dir, "multi.nii.gz", &two))
            .unwrap()
            .as_slice(),
        vol.as_slice()
    );
}

#[test]
fn parallel_gzip_blocks_form_one_standard_stream() {
    let mut rng = SplitMix64::new(11);
    let vol = random_volume(&mut rng, [33, 17, 9], true, gen_i16);
    let hdr = header_bytes(&vol).unwrap();
    let data = le_bytes(vol.as_slice());
    let plain = [&hdr[..], &data[..]].concat();
    let pool = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
    };
    for block in [1, 7, 1000, 4096, 1 << 20] {
        let gz = |n: usize| {
            pool(n).install(|| {
                let mut z = Vec::new();
                write_gzip(&mut z, &[&hdr, &data], 1, block).unwrap();
                z
            })
        };
        let one = gz(1);
        assert_eq!(
            one,
            gz(2),
            "block {block}: output depends on the thread count"
        );
        // A single-member decoder (not Multi) must see the whole file.
        let mut out = Vec::new();
        flate2::read::GzDecoder::new(&one[..])
            .read_to_end(&mut out)
            .unwrap();
        assert_eq!(out, plain, "block {block}");
    }
    // The gzip path of `encode` is this stream with 4 MiB blocks.
    assert_eq!(gunzip(&encode_bytes(&vol, true)), plain);
}

/// Byte-swap a little-endian NIfTI-1 file (header fields and voxels).
fn to_big_endian_v1(le: &[u8], bpv: usize) -> Vec<u8> {
    let mut b = le.to_vec();
    let fields: &[(usize, usize, usize)] = &[
        (0, 4, 1),    // sizeof_hdr
        (32, 4, 1),   // extents
        (36, 2, 1),   // session_error
        (40, 2, 8),   // dim
        (56, 4, 3),   // intent_p1..3
        (68, 2, 4),   // intent_code, datatype, bitpix, slice_start
        (76, 4, 11),  // pixdim, vox_offset, scl_slope, scl_inter
        (120, 2, 1),  // slice_end
        (124, 4, 6),  // cal_max, cal_min, slice_duration, toffset, glmax, glmin
        (252, 2, 2),  // qform_code, sform_code
        (256, 4, 18), // quatern, qoffset, srow
    ];
    for &(off, size, count) in fields {
        for k in 0..count {
            b[off + k * size..off + (k + 1) * size].reverse();
        }
    }
    for v in b[352..].chunks_mut(bpv) {
        v.reverse();
    }
    b
}

#[test]
fn big_endian_reads_the_same() {
    let dir = tmpdir("be");
    let mut rng = SplitMix64::new(5);
    let v16 = random_volume(&mut rng, [7, 5, 3], true, gen_i16);
    let le = encode_bytes(&v16, false);
    let be = to_big_endian_v1(&le, 2);
    assert_ne!(le, be);
    let p = put_file(&dir, "be.nii", &be);
    assert_eq!(read_header(&p).unwrap().endian, Endian::Big);
    let back = read_i16(&p).unwrap();
    assert_eq!(back.as_slice(), v16.as_slice());
    assert_eq!(*back.affine(), f32_rounded(v16.affine()));
    // Converting path (i16 → f32) and gzip, big-endian.
    let pg = put_file(&dir, "be.nii.gz", &gzip(&be));
    let f = read_f32(&pg).unwrap();
    assert!(
        f.as_slice()
            .iter()
            .zip(v16.as_slice())
            .all(|(a, b)| *a == *b as f32)
    );
    let vf = random_volume(&mut rng, [4, 3, 2], false, gen_f32);
    let be = to_big_endian_v1(&encode_bytes(&vf, false), 4);
    assert_eq!(
        read_f32(&put_file(&dir, "bef.nii", &be))
            .unwrap()
            .as_slice(),
        vf.as_slice()
    );
}

#[test]
fn scaling_and_integer_targets() {
    let dir = tmpdir("scale");
    let raw: Vec<i16> = (0..7 * 5 * 3)
        .map(|k| (k * 37 % 2000) as i16 - 500)
        .collect();
    let vol = Volume::from_fortran_vec([7, 5, 3], Matrix4::identity(), raw.clone()).unwrap();
    let mut b = encode_bytes(&vol, false);
    set_f32(&mut b, 112, 2.0);
    set_f32(&mut b, 116, -1024.0);
    let p = put_file(&dir, "scaled.nii", &b);
    let h = read_header(&p).unwrap();
    assert_eq!(h.scaling(), Some((2.0, -1024.0)));
    let f = read_f32(&p).unwrap();
    for (got, r) in f.as_slice().iter().zip(&raw) {
        assert_eq!(*got, *r as f32 * 2.0 - 1024.0);
    }
    // Integral and in range: int16 works too.
    let i = read_i16(&p).unwrap();
    assert!(
        i.as_slice()
            .iter()
            .zip(&raw)
            .all(|(g, r)| *g as i32 == *r as i32 * 2 - 1024)
    );
    // Out of range for uint8: clear error naming the voxel and the fix.
    let e = read_u8(&p).unwrap_err().to_string();
    assert!(
        e.contains("voxel [0, 0, 0] is -2024 after scl_slope/scl_inter scaling"),
        "{e}"
    );
    assert!(e.contains("read_f32"), "{e}");
    // slope 0 or NaN: no scaling
    for s in [0.0, f32::NAN] {
        set_f32(&mut b, 112, s);
        let p = put_file(&dir, "noscale.nii", &b);
        assert_eq!(read_header(&p).unwrap().scl_slope, None);
        assert_eq!(read_i16(&p).unwrap().as_slice(), &raw[..]);
    }
    // Scaled values overflowing int16
    set_f32(&mut b, 112, 100.0);
    set_f32(&mut b, 116, 0.0);
    let e = read_i16(&put_file(&dir, "big.nii", &b))
        .unwrap_err()
        .to_string();
    assert!(e.contains("-50000") && e.contains("int16"), "{e}");
}

#[test]
fn float_file_as_integers() {
    let dir = tmpdir("float");
    let whole: Vec<f32> = (0..24).map(|k| k as f32 - 3.0).collect();
    let v = Volume::from_fortran_vec([4, 3, 2], Matrix4::identity(), whole.clone()).unwrap();
    let p = dir.join("whole.nii.gz");
    write(&p, &v).unwrap();
    let i = read_i16(&p).unwrap();
    assert!(
        i.as_slice()
            .iter()
            .zip(&whole)
            .all(|(a, b)| *a as f32 == *b)
    );
    let e = read_u8(&p).unwrap_err().to_string();
    assert!(e.contains("-3") && e.contains("uint8"), "{e}");
    let mut frac = whole;
    frac[5] = 2.5;
    let v = Volume::from_fortran_vec([4, 3, 2], Matrix4::identity(), frac).unwrap();
    write(&p, &v).unwrap();
    let e = read_i16(&p).unwrap_err();
    assert_eq!(e.exit_code(), 2);
    let e = e.to_string();
    assert!(
        e.contains("voxel [1, 1, 0] is 2.5 as stored (float32 data)"),
        "{e}"
    );
    assert!(e.contains("read_f32"), "{e}");
}

/// A NIfTI-2 single file: 540-byte header, empty extension flag, data.
fn nifti2_bytes(
    dim: [i64; 8],
    datatype: i16,
    bitpix: i16,
    pixdim: [f64; 8],
    srow: Option<[[f64; 4]; 3]>,
    data: &[u8],
) -> Vec<u8> {
    let mut h = vec![0u8; 544];
    h[0..4].copy_from_slice(&540i32.to_le_bytes());
    h[4..12].copy_from_slice(b"n+2\0\r\n\x1a\n");
    h[12..14].copy_from_slice(&datatype.to_le_bytes());
    h[14..16].copy_from_slice(&bitpix.to_le_bytes());
    for i in 0..8 {
        h[16 + 8 * i..24 + 8 * i].copy_from_slice(&dim[i].to_le_bytes());
        h[104 + 8 * i..112 + 8 * i].copy_from_slice(&pixdim[i].to_le_bytes());
    }
    h[168..176].copy_from_slice(&544i64.to_le_bytes());
    h[500..504].copy_from_slice(&2i32.to_le_bytes());
    if let Some(s) = srow {
        h[348..352].copy_from_slice(&1i32.to_le_bytes());
        for (r, row) in s.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                let o = 400 + 32 * r + 8 * c;
                h[o..o + 8].copy_from_slice(&v.to_le_bytes());
            }
        }
    }
    h.extend_from_slice(data);
    h
}

#[test]
fn nifti2_reads_with_f64_sform() {
    let dir = tmpdir("n2");
    let vals: Vec<i16> = (0..30).map(|k| k * 3 - 40).collect();
    let data: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
    let srow = [
        [0.1234567891, 0.0, 0.5, -100.123456789],
        [0.0, -0.7, 0.0, 50.0],
        [0.0, 0.0, 1.3, 7.0],
    ];
    let b = nifti2_bytes([3, 5, 3, 2, 1, 1, 1, 1], 4, 16, [1.0; 8], Some(srow), &data);
    let p = put_file(&dir, "n2.nii", &b);
    let h = read_header(&p).unwrap();
    assert_eq!(h.version, 2);
    assert_eq!(h.vox_offset, 544);
    let v = read_i16(&p).unwrap();
    assert_eq!(v.as_slice(), &vals[..]);
    // f64 precision survives; x and y rows negated (RAS → LPS).
    assert_eq!(v.affine()[(0, 0)], -0.1234567891);
    assert_eq!(v.affine()[(0, 3)], 100.123456789);
    assert_eq!(v.affine()[(1, 1)], 0.7);
    assert_eq!(v.affine()[(2, 2)], 1.3);
    let pg = put_file(&dir, "n2.nii.gz", &gzip(&b));
    assert_eq!(
        read_f32(&pg)
            .unwrap()
            .as_slice()
            .iter()
            .map(|x| *x as i16)
            .collect::<Vec<_>>(),
        vals
    );
}

#[test]
fn pixdim_only_transform() {
    let dir = tmpdir("pixdim");
    let vol = Volume::filled([3, 3, 3], Matrix4::identity(), 1u8).unwrap();
    let mut b = encode_bytes(&vol, false);
    set_i16(&mut b, 252, 0);
    set_i16(&mut b, 254, 0);
    for (i, s) in [0.5f32, 0.75, 2.0].iter().enumerate() {
        set_f32(&mut b, 80 + 4 * i, *s);
    }
    let p = put_file(&dir, "p.nii", &b);
    let h = read_header(&p).unwrap();
    assert_eq!(h.transform_source, TransformSource::Pixdim);
    let expect = Matrix4::from_diagonal(&nalgebra::Vector4::new(-0.5, -0.75, 2.0, 1.0));
    assert_eq!(h.affine_lps, expect);
    // Zero spacing on this path is refused, naming the field.
    set_f32(&mut b, 84, 0.0);
    let e = read_u8(&put_file(&dir, "p0.nii", &b))
        .unwrap_err()
        .to_string();
    assert!(e.contains("pixdim[2]") && e.contains("positive"), "{e}");
}

#[test]
fn extensions_are_skipped() {
    let dir = tmpdir("ext");
    let vol = Volume::from_fortran_vec([2, 2, 2], Matrix4::identity(), (0..8).collect::<Vec<u8>>())
        .unwrap();
    let b = encode_bytes(&vol, false);
    let mut e = b[..352].to_vec();
    e[348] = 1; // extension flag
    e.extend_from_slice(&32i32.to_le_bytes()); // esize
    e.extend_from_slice(&6i32.to_le_bytes()); // ecode (comment)
    e.extend_from_slice(&[b'x'; 24]);
    set_f32(&mut e, 108, 384.0);
    e.extend_from_slice(&b[352..]);
    assert_eq!(
        read_u8(&put_file(&dir, "ext.nii", &e)).unwrap().as_slice(),
        vol.as_slice()
    );
    assert_eq!(
        read_u8(&put_file(&dir, "ext.nii.gz", &gzip(&e)))
            .unwrap()
            .as_slice(),
        vol.as_slice()
    );
    // An extension claiming to run past vox_offset is corrupt.
    e[352..356].copy_from_slice(&64i32.to_le_bytes());
    let msg = read_u8(&put_file(&dir, "bad.nii", &e))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("extension"), "{msg}");
}

fn small_i16_file() -> Vec<u8> {
    let vals: Vec<i16> = (0..7 * 5 * 3).collect();
    let mut rng = SplitMix64::new(9);
    let vol = Volume::from_fortran_vec([7, 5, 3], random_affine(&mut rng, false), vals).unwrap();
    encode_bytes(&vol, false)
}

/// Expect `read_f32` to fail on `bytes` with a bad-input error containing
/// every one of `needles`.
fn expect_bad(dir: &Path, name: &str, bytes: &[u8], needles: &[&str]) {
    let p = put_file(dir, name, bytes);
    let err = read_f32(&p).unwrap_err();
    assert!(matches!(err, Error::BadInput { .. }), "{name}: {err:?}");
    assert_eq!(err.exit_code(), 2);
    let msg = err.to_string();
    assert!(
        msg.contains(name),
        "{name}: message does not name the file: {msg}"
    );
    for n in needles {
        assert!(msg.contains(n), "{name}: expected {n:?} in: {msg}");
    }
}

#[test]
fn truncated_files() {
    let dir = tmpdir("trunc");
    let b = small_i16_file();
    expect_bad(
        &dir,
        "cut.nii",
        &b[..b.len() - 10],
        &["truncated: expected 210 bytes of voxel data, found 200"],
    );
    let gz = gzip(&b);
    expect_bad(&dir, "half.nii.gz", &gz[..gz.len() / 2], &["gzip"]);
    // Missing gzip trailer only (all voxel bytes present): checksum unverifiable.
    expect_bad(&dir, "notrailer.nii.gz", &gz[..gz.len() - 4], &["gzip"]);
    // A flipped byte inside the deflate data.
    let mut bad = gzip(&b);
    let mid = bad.len() / 2;
    bad[mid] ^= 0x55;
    expect_bad(&dir, "flipped.nii.gz", &bad, &["gzip"]);
    expect_bad(
        &dir,
        "hdronly.nii",
        &b[..200],
        &["too short for a NIfTI header"],
    );
    let mut past = b.clone();
    set_f32(&mut past, 108, 1e6);
    expect_bad(
        &dir,
        "voxpast.nii",
        &past,
        &["vox_offset", "beyond the end"],
    );
    set_f32(&mut past, 108, 100.0);
    expect_bad(&dir, "voxlow.nii", &past, &["vox_offset"]);
}

#[test]
fn absurd_sizes_are_refused_instantly() {
    let dir = tmpdir("huge");
    let t = std::time::Instant::now();
    let b = nifti2_bytes(
        [3, 1_000_000, 1_000_000, 1_000_000, 1, 1, 1, 1],
        4,
        16,
        [1.0; 8],
        None,
        &[0; 16],
    );
    expect_bad(&dir, "huge2.nii", &b, &["1000000", "corrupt"]);
    let b = nifti2_bytes(
        [3, 100_000, 100_000, 100_000, 1, 1, 1, 1],
        4,
        16,
        [1.0; 8],
        None,
        &[0; 16],
    );
    expect_bad(
        &dir,
        "big2.nii.gz",
        &gzip(&b),
        &["2000000000000000 bytes", "COAPT_MAX_VOLUME_BYTES"],
    );
    let mut b = small_i16_file();
    for a in 1..4 {
        set_i16(&mut b, 40 + 2 * a, 32767);
    }
    expect_bad(
        &dir,
        "huge1.nii",
        &b,
        &["32767×32767×32767", "COAPT_MAX_VOLUME_BYTES"],
    );
    assert!(t.elapsed().as_secs_f64() < 1.0, "took {:?}", t.elapsed());
    // The limit is configurable, and the output type counts too.
    let p = put_file(&dir, "ok.nii", &small_i16_file());
    let small = ReadOptions { max_bytes: 300 };
    assert!(read_with::<i16>(&p, &small).is_ok()); // 210 bytes
    let e = read_with::<f32>(&p, &small).unwrap_err().to_string(); // 420 bytes as f32
    assert!(e.contains("COAPT_MAX_VOLUME_BYTES"), "{e}");
    assert!(read_header_with(&p, &ReadOptions { max_bytes: 200 }).is_err());
}

#[test]
fn max_bytes_env_value() {
    assert_eq!(max_bytes_from(None), 2 * 1024 * 1024 * 1024);
    assert_eq!(max_bytes_from(Some(" 5000000000 ")), 5_000_000_000);
    for bad in ["", "abc", "-1", "0", "2GiB"] {
        assert_eq!(max_bytes_from(Some(bad)), DEFAULT_MAX_BYTES, "{bad:?}");
    }
}

#[test]
fn bad_headers_name_the_problem() {
    let dir = tmpdir("badhdr");
    let good = small_i16_file();
    let with = |f: &dyn Fn(&mut Vec<u8>)| {
        let mut b = good.clone();
        f(&mut b);
        b
    };
    expect_bad(
        &dir,
        "nanpix.nii",
        &with(&|b| set_f32(b, 80, f32::NAN)),
        &["pixdim[1]", "NaN"],
    );
    expect_bad(
        &dir,
        "infpix.nii.gz",
        &gzip(&with(&|b| set_f32(b, 88, f32::INFINITY))),
        &["pixdim[3]"],
    );
    // qfac 0 matters only when the qform is the transform in use.
    let qfac0 = with(&|b| set_f32(b, 76, 0.0));
    assert!(read_f32(&put_file(&dir, "qfac0_sform.nii", &qfac0)).is_ok());
    let mut q = qfac0.clone();
    set_i16(&mut q, 254, 0);
    expect_bad(&dir, "qfac0.nii", &q, &["pixdim[0] (qfac) is 0", "1 or -1"]);
    let mut q = good.clone();
    set_i16(&mut q, 254, 0);
    set_f32(&mut q, 84, -0.5);
    expect_bad(&dir, "negpix.nii", &q, &["pixdim[2]", "-0.5"]);
    let mut q = good.clone();
    set_i16(&mut q, 254, 0);
    set_f32(&mut q, 256, 0.9);
    set_f32(&mut q, 260, 0.9);
    expect_bad(&dir, "badquat.nii", &q, &["quaternion"]);
    // 4-D
    let four = with(&|b| {
        set_i16(b, 40, 4);
        set_i16(b, 48, 5);
    });
    expect_bad(
        &dir,
        "fourd.nii",
        &four,
        &["4-D volume 7×5×3×5", "extract a single time point"],
    );
    let four1 = with(&|b| {
        set_i16(b, 40, 4);
        set_i16(b, 48, 1);
    });
    assert_eq!(
        read_i16(&put_file(&dir, "fourd1.nii", &four1))
            .unwrap()
            .dims(),
        [7, 5, 3]
    );
    expect_bad(&dir, "dim0.nii", &with(&|b| set_i16(b, 40, 0)), &["dim[0]"]);
    expect_bad(
        &dir,
        "dim0big.nii",
        &with(&|b| set_i16(b, 40, 9)),
        &["dim[0]"],
    );
    expect_bad(
        &dir,
        "negdim.nii",
        &with(&|b| set_i16(b, 44, -5)),
        &["dim[2] is -5"],
    );
    expect_bad(
        &dir,
        "zerodim.nii",
        &with(&|b| set_i16(b, 46, 0)),
        &["dim[3] is 0"],
    );
    expect_bad(
        &dir,
        "dtype.nii",
        &with(&|b| set_i16(b, 70, 999)),
        &["unknown datatype code 999"],
    );
    expect_bad(
        &dir,
        "rgb.nii",
        &with(&|b| {
            set_i16(b, 70, 128);
            set_i16(b, 72, 24);
        }),
        &["RGB24", "not supported"],
    );
    expect_bad(
        &dir,
        "bitpix.nii",
        &with(&|b| set_i16(b, 72, 8)),
        &["bitpix is 8"],
    );
    expect_bad(
        &dir,
        "magic.nii",
        &with(&|b| b[344..348].copy_from_slice(b"abc\0")),
        &["wrong magic"],
    );
    expect_bad(
        &dir,
        "pair.hdr",
        &with(&|b| b[344..348].copy_from_slice(b"ni1\0")),
        &[".hdr/.img pair", "single-file"],
    );
    expect_bad(
        &dir,
        "analyze.hdr",
        &with(&|b| b[344..348].copy_from_slice(&[0; 4])),
        &["Analyze", "single-file"],
    );
    expect_bad(
        &dir,
        "nans.nii",
        &with(&|b| set_f32(b, 280, f32::NAN)),
        &["srow_x", "non-finite"],
    );
    expect_bad(
        &dir,
        "singular.nii",
        &with(&|b| {
            for k in 0..3 {
                set_f32(b, 296 + 4 * k, 0.0);
            }
        }),
        &["singular"],
    );
    expect_bad(
        &dir,
        "slope.nii",
        &with(&|b| set_f32(b, 112, f32::INFINITY)),
        &["scl_slope"],
    );
    expect_bad(
        &dir,
        "garbage.nii",
        b"this is not a nifti file at all, just some text that goes on",
        &["not a NIfTI file"],
    );
    expect_bad(&dir, "empty.nii.gz", b"", &["empty file"]);
    expect_bad(&dir, "tiny.nii", b"\x5c\x01", &["too short"]);
    expect_bad(
        &dir,
        "gzgarbage.nii.gz",
        b"\x1f\x8b\x08\x00garbage-garbage-garbage",
        &["gzip"],
    );
    expect_bad(
        &dir,
        "n2magic.nii",
        &{
            let mut b = nifti2_bytes([3, 1, 1, 1, 1, 1, 1, 1], 2, 8, [1.0; 8], None, &[0]);
            b[8] = b'\n';
            b
        },
        &["text mode"],
    );
    // A file that cannot be opened is a read error, not a format error.
    let missing = read_f32(&dir.join("missing.nii")).unwrap_err();
    assert!(matches!(missing, Error::Read { .. }), "{missing:?}");
}

#[test]
fn write_refuses_dims_beyond_nifti1() {
    let vol = Volume::filled([40_000, 1, 1], Matrix4::identity(), 0u8).unwrap();
    let e = header_bytes(&vol).unwrap_err().to_string();
    assert!(e.contains("32767"), "{e}");
    let dir = tmpdir("wbig");
    assert!(write(&dir.join("x.nii"), &vol).is_err());
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        0,
        "no partial file left"
    );
}
