//! Round trips: one oblique, anisotropic, left-handed int16 volume written as
//! every NRRD and MetaImage variant (by hand here, independent of coapt's
//! writer) reads back with the same values and affine as the NIfTI.

use std::io::Write;
use std::path::Path;

use flate2::Compression;
use flate2::write::{GzEncoder, ZlibEncoder};
use nalgebra::{Rotation3, Unit, Vector3};

use super::*;
use crate::scratch::{Scratch, scratch};
use coapt_geom::volume::affine_from_parts;
use coapt_geom::{Matrix3, Point3};

fn tmp(tag: &str) -> Scratch {
    scratch(&format!("vf-{tag}"))
}

/// 7×6×5 int16, rotated about an oblique axis, spacings 0.4/0.7/1.3 mm, the
/// k axis flipped (left-handed), values covering negatives and > 255.
fn oblique() -> Volume<i16> {
    let r = Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::new(1.0, 2.0, 3.0)), 0.7);
    let mut dir: Matrix3 = *r.matrix();
    dir.column_mut(2).neg_mut();
    let a = affine_from_parts([0.4, 0.7, 1.3], &dir, Point3::new(-12.5, 40.25, -300.0));
    let vals = (0..7 * 6 * 5)
        .map(|x| (x * 97 % 3001 - 1024) as i16)
        .collect();
    Volume::from_fortran_vec([7, 6, 5], a, vals).unwrap()
}

fn le_bytes(v: &Volume<i16>, big: bool) -> Vec<u8> {
    v.as_slice()
        .iter()
        .flat_map(|x| {
            if big {
                x.to_be_bytes()
            } else {
                x.to_le_bytes()
            }
        })
        .collect()
}

fn gzip(b: &[u8]) -> Vec<u8> {
    let mut e = GzEncoder::new(Vec::new(), Compression::default());
    e.write_all(b).unwrap();
    e.finish().unwrap()
}

fn zlib(b: &[u8]) -> Vec<u8> {
    let mut e = ZlibEncoder::new(Vec::new(), Compression::default());
    e.write_all(b).unwrap();
    e.finish().unwrap()
}

/// A NRRD header for `v` in `space` ("LPS" or "RAS" spelled out).
fn nrrd_header(v: &Volume<i16>, space: &str, encoding: &str, extra: &str) -> String {
    let a = v.affine();
    let (sx, sy) = if space.starts_with("right") {
        (-1.0, -1.0)
    } else {
        (1.0, 1.0)
    };
    let col = |c: usize| {
        format!(
            "({:?},{:?},{:?})",
            sx * a[(0, c)],
            sy * a[(1, c)],
            a[(2, c)]
        )
    };
    let [ni, nj, nk] = v.dims();
    let endian = if extra.contains("endian: big\n") {
        "big"
    } else {
        "little"
    };
    let extra = extra.replace("endian: big\n", "");
    format!(
        "NRRD0005\n# test\ntype: short\ndimension: 3\nspace: {space}\nsizes: {ni} {nj} {nk}\n\
         space directions: {} {} {}\nkinds: domain domain domain\nendian: {}\n\
         encoding: {encoding}\nspace origin: {}\n{extra}",
        col(0),
        col(1),
        col(2),
        endian,
        col(3)
    )
}

fn assert_same(path: &Path, v: &Volume<i16>) {
    let got: Volume<i16> =
        read(path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(got.dims(), v.dims(), "{}", path.display());
    assert_eq!(got.as_slice(), v.as_slice(), "{}", path.display());
    let d = (got.affine() - v.affine()).abs().max();
    assert!(d < 1e-6, "{}: affine off by {d}", path.display());
    // The header alone agrees with the volume.
    let h = read_header(path, &ReadOptions::default()).unwrap();
    assert_eq!(h.dims, v.dims());
    assert!((h.affine_lps - v.affine()).abs().max() < 1e-6);
}

#[test]
fn nrrd_variants_read_back_identical() {
    let d = tmp("nrrd");
    let v = oblique();
    let raw = le_bytes(&v, false);
    for (space, tag) in [
        ("left-posterior-superior", "lps"),
        ("right-anterior-superior", "ras"),
    ] {
        // Attached raw and gzip.
        let p = d.join(format!("{tag}-raw.nrrd"));
        let mut f = nrrd_header(&v, space, "raw", "\n").into_bytes();
        f.extend_from_slice(&raw);
        std::fs::write(&p, f).unwrap();
        assert_same(&p, &v);
        let p = d.join(format!("{tag}-gz.nrrd"));
        let mut f = nrrd_header(&v, space, "gzip", "\n").into_bytes();
        f.extend_from_slice(&gzip(&raw));
        std::fs::write(&p, f).unwrap();
        assert_same(&p, &v);
        // Detached raw (in a subfolder, relative name) and gzip.
        std::fs::create_dir_all(d.join("data")).unwrap();
        std::fs::write(d.join(format!("data/{tag}.raw")), &raw).unwrap();
        let p = d.join(format!("{tag}-raw.nhdr"));
        let h = nrrd_header(&v, space, "raw", &format!("data file: data/{tag}.raw\n"));
        std::fs::write(&p, h).unwrap();
        assert_same(&p, &v);
        std::fs::write(d.join(format!("{tag}.raw.gz")), gzip(&raw)).unwrap();
        let p = d.join(format!("{tag}-gz.nhdr"));
        let h = nrrd_header(&v, space, "gz", &format!("datafile: {tag}.raw.gz\n"));
        std::fs::write(&p, h).unwrap();
        assert_same(&p, &v);
    }
    // Big-endian, with the data at the end of a file that starts with junk.
    let mut f = b"some preamble".to_vec();
    f.extend_from_slice(&le_bytes(&v, true));
    std::fs::write(d.join("be.raw"), f).unwrap();
    let p = d.join("be.nhdr");
    let h = nrrd_header(
        &v,
        "left-posterior-superior",
        "raw",
        "endian: big\ndata file: be.raw\nbyte skip: -1\n",
    );
    std::fs::write(&p, h).unwrap();
    assert_same(&p, &v);
}

fn mha_header(v: &Volume<i16>, compressed: bool, big: bool, file: &str) -> String {
    let a = v.affine();
    let sp = v.spacing();
    // Axis i's unit direction, axis after axis.
    let m: Vec<String> = (0..3)
        .flat_map(|c| (0..3).map(move |r| (r, c)))
        .map(|(r, c)| format!("{:?}", a[(r, c)] / sp[c]))
        .collect();
    let [ni, nj, nk] = v.dims();
    format!(
        "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = {}\n\
         CompressedData = {}\nTransformMatrix = {}\nOffset = {:?} {:?} {:?}\n\
         CenterOfRotation = 0 0 0\nAnatomicalOrientation = RAI\n\
         ElementSpacing = {:?} {:?} {:?}\nDimSize = {ni} {nj} {nk}\nElementType = MET_SHORT\n\
         ElementDataFile = {file}\n",
        if big { "True" } else { "False" },
        if compressed { "True" } else { "False" },
        m.join(" "),
        a[(0, 3)],
        a[(1, 3)],
        a[(2, 3)],
        sp[0],
        sp[1],
        sp[2],
    )
}

#[test]
fn metaimage_variants_read_back_identical() {
    let d = tmp("mha");
    let v = oblique();
    let raw = le_bytes(&v, false);
    for compressed in [false, true] {
        let data = if compressed { zlib(&raw) } else { raw.clone() };
        let p = d.join(format!("att-{compressed}.mha"));
        let mut f = mha_header(&v, compressed, false, "LOCAL").into_bytes();
        f.extend_from_slice(&data);
        std::fs::write(&p, f).unwrap();
        assert_same(&p, &v);
        let name = format!(
            "det-{compressed}.{}",
            if compressed { "zraw" } else { "raw" }
        );
        std::fs::write(d.join(&name), &data).unwrap();
        let p = d.join(format!("det-{compressed}.mhd"));
        std::fs::write(&p, mha_header(&v, compressed, false, &name)).unwrap();
        assert_same(&p, &v);
    }
    // Big-endian, CRLF line ends (headers edited on Windows).
    let p = d.join("be.mha");
    let mut f = mha_header(&v, false, true, "LOCAL")
        .replace('\n', "\r\n")
        .into_bytes();
    f.extend_from_slice(&le_bytes(&v, true));
    std::fs::write(&p, f).unwrap();
    assert_same(&p, &v);
}

#[test]
fn float_data_read_as_int16_when_integral_and_refused_when_not() {
    let d = tmp("float");
    let v = oblique();
    let mut f = nrrd_header(&v, "left-posterior-superior", "raw", "\n")
        .replace("type: short", "type: float")
        .into_bytes();
    let floats: Vec<u8> = v
        .as_slice()
        .iter()
        .flat_map(|&x| (x as f32).to_le_bytes())
        .collect();
    f.extend_from_slice(&floats);
    let p = d.join("f.nrrd");
    std::fs::write(&p, &f).unwrap();
    assert_same(&p, &v);
    let n = f.len();
    f[n - 4..].copy_from_slice(&0.5f32.to_le_bytes());
    std::fs::write(&p, &f).unwrap();
    let e = read::<i16>(&p, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("voxel [6, 5, 4] is 0.5") && e.contains("int16"),
        "{e}"
    );
}

#[test]
fn data_of_the_wrong_length_is_refused_before_decoding() {
    let d = tmp("len");
    let v = oblique();
    let raw = le_bytes(&v, false);
    let cases: [(&str, Vec<u8>, &str, &str); 4] = [
        (
            "raw",
            raw[..raw.len() - 1].to_vec(),
            "truncated",
            "found 419",
        ),
        (
            "raw",
            [raw.as_slice(), &[0]].concat(),
            "holds 421 bytes",
            "need 420",
        ),
        ("gzip", gzip(&raw[..100]), "truncated", "found 100"),
        (
            "gzip",
            gzip(&[raw.as_slice(), &[0, 0]].concat()),
            "longer than the 420",
            "",
        ),
    ];
    for (k, (enc, data, w1, w2)) in cases.into_iter().enumerate() {
        let p = d.join(format!("c{k}.nrrd"));
        let mut f = nrrd_header(&v, "left-posterior-superior", enc, "\n").into_bytes();
        f.extend_from_slice(&data);
        std::fs::write(&p, f).unwrap();
        let e = read::<i16>(&p, &ReadOptions::default()).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        let e = e.to_string();
        assert!(e.contains(w1) && e.contains(w2), "case {k}: {e}");
        assert!(e.starts_with(&p.display().to_string()), "{e}");
    }
    // A corrupt gzip stream (a flipped byte in the middle).
    let mut z = gzip(&raw);
    let m = z.len() / 2;
    z[m] ^= 0xff;
    let mut f = nrrd_header(&v, "left-posterior-superior", "gzip", "\n").into_bytes();
    f.extend_from_slice(&z);
    let p = d.join("corrupt.nrrd");
    std::fs::write(&p, f).unwrap();
    let e = read::<i16>(&p, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("gzip") || e.contains("truncated"), "{e}");
    // A detached data file that is missing names the header and the file.
    let p = d.join("lost.nhdr");
    let h = nrrd_header(
        &v,
        "left-posterior-superior",
        "raw",
        "data file: lost.raw\n",
    );
    std::fs::write(&p, h).unwrap();
    let e = read_header(&p, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("lost.nhdr") && e.contains("lost.raw does not exist"),
        "{e}"
    );
}

#[test]
fn byte_limit_applies_to_the_output_type_too() {
    let d = tmp("limit");
    let v = oblique();
    let mut f = nrrd_header(&v, "left-posterior-superior", "raw", "\n")
        .replace("type: short", "type: uchar")
        .replace("endian: little\n", "")
        .into_bytes();
    f.extend(v.as_slice().iter().map(|&x| x as u8));
    let p = d.join("u8.nrrd");
    std::fs::write(&p, f).unwrap();
    // 210 bytes stored, 840 as float32.
    let opts = ReadOptions { max_bytes: 400 };
    assert!(read::<u8>(&p, &opts).is_ok());
    let e = read::<f32>(&p, &opts).unwrap_err().to_string();
    assert!(e.contains("above the limit of 400 bytes"), "{e}");
}

#[test]
fn sniffing_is_by_content_and_lists_the_formats_when_unknown() {
    let d = tmp("sniff");
    let v = oblique();
    // A NRRD named .nii.gz, a MetaImage named .dat: read as what they are.
    let mut f = nrrd_header(&v, "left-posterior-superior", "raw", "\n").into_bytes();
    f.extend_from_slice(&le_bytes(&v, false));
    let p = d.join("misnamed.nii.gz");
    std::fs::write(&p, &f).unwrap();
    assert_eq!(sniff(&p).unwrap(), Format::Nrrd);
    assert_same(&p, &v);
    let mut f = mha_header(&v, false, false, "LOCAL").into_bytes();
    f.extend_from_slice(&le_bytes(&v, false));
    let p = d.join("volume.dat");
    std::fs::write(&p, &f).unwrap();
    assert_eq!(sniff(&p).unwrap(), Format::MetaImage);
    // A NIfTI named .img.
    let p = d.join("ct.img");
    nifti::write(&d.join("ct.nii"), &v).unwrap();
    std::fs::rename(d.join("ct.nii"), &p).unwrap();
    assert_eq!(sniff(&p).unwrap(), Format::Nifti);
    // Unknown content, a DICOM file, a directory, an empty file.
    std::fs::write(d.join("notes.txt"), "hello\n").unwrap();
    let mut dcm = vec![0u8; 128];
    dcm.extend_from_slice(b"DICM");
    std::fs::write(d.join("IM0001"), dcm).unwrap();
    std::fs::write(d.join("empty.bin"), b"").unwrap();
    std::fs::create_dir_all(d.join("empty-folder")).unwrap();
    for (name, words) in [
        ("notes.txt", "not a volume coapt recognises"),
        ("IM0001", "not a readable DICOM file"),
        ("empty-folder", "holds no DICOM images"),
        ("empty.bin", "empty"),
    ] {
        let p = d.join(name);
        let e = read_ct(&p).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        let e = e.to_string();
        assert!(e.contains(words), "{name}: {e}");
        // A DICOM file is read as one (it may be a multi-frame CT), so its
        // refusal is the DICOM reader's; the others list what coapt reads.
        assert!(
            e.contains("NRRD") && e.contains("MetaImage")
                || e.contains("folder")
                || e.contains("DICOM file"),
            "{name}: {e}"
        );
    }
    // A folder whose only DICOM-marked file is broken names that file.
    let e = read_ct(&d).unwrap_err().to_string();
    assert!(e.contains("IM0001") && e.contains("DICOM"), "{e}");
}

#[test]
fn coapt_nrrd_writer_round_trips_exactly() {
    let d = tmp("nrrdw");
    let v = oblique();
    let p = d.join("w.nrrd");
    crate::nrrd::write(&p, &v).unwrap();
    let got: Volume<i16> = read(&p, &ReadOptions::default()).unwrap();
    assert_eq!(got.as_slice(), v.as_slice());
    // `{:?}` keeps every bit of the affine.
    assert_eq!(got.affine(), v.affine());
    let m =
        coapt_geom::Volume::from_fortran_vec([2, 2, 1], *v.affine(), vec![0u8, 1, 2, 255]).unwrap();
    crate::nrrd::write(&p, &m).unwrap();
    let got: Volume<u8> = read(&p, &ReadOptions::default()).unwrap();
    assert_eq!(got.as_slice(), &[0, 1, 2, 255]);
}

/// Damaged files never panic and never allocate what a header merely
/// claims: thousands of random byte edits, deletions and truncations of a
/// valid NRRD (raw, gzip) and MetaImage (raw, zlib) each end in a volume or
/// in a bad-input error, under a byte limit a little above the real size.
#[test]
fn random_damage_is_refused_or_read_never_a_panic() {
    let d = tmp("damage");
    let v = oblique();
    let raw = le_bytes(&v, false);
    let originals: Vec<(&str, Vec<u8>)> = vec![
        (
            "a.nrrd",
            [
                nrrd_header(&v, "right-anterior-superior", "raw", "\n").into_bytes(),
                raw.clone(),
            ]
            .concat(),
        ),
        (
            "b.nrrd",
            [
                nrrd_header(&v, "left-posterior-superior", "gzip", "\n").into_bytes(),
                gzip(&raw),
            ]
            .concat(),
        ),
        (
            "c.mha",
            [
                mha_header(&v, false, false, "LOCAL").into_bytes(),
                raw.clone(),
            ]
            .concat(),
        ),
        (
            "d.mha",
            [
                mha_header(&v, true, false, "LOCAL").into_bytes(),
                zlib(&raw),
            ]
            .concat(),
        ),
    ];
    let opts = ReadOptions { max_bytes: 4096 };
    let mut rng = coapt_base::rng::SplitMix64::new(24);
    let (mut read_ok, mut refused) = (0, 0);
    for (name, bytes) in &originals {
        for _ in 0..1500 {
            let mut b = bytes.clone();
            let edits = 1 + rng.next_u64() % 4;
            for _ in 0..edits {
                let at = (rng.next_u64() % b.len() as u64) as usize;
                match rng.next_u64() % 4 {
                    0 => b[at] = rng.next_u64() as u8,
                    1 => b[at] = b"0123456789-.e (),: =\n"[(rng.next_u64() % 21) as usize],
                    2 => {
                        b.remove(at);
                    }
                    _ => b.truncate(at.max(1)),
                }
            }
            let p = d.join(name);
            std::fs::write(&p, &b).unwrap();
            match read::<i16>(&p, &opts) {
                Ok(got) => {
                    assert!(got.len() as u64 * 2 <= opts.max_bytes);
                    read_ok += 1;
                }
                Err(e) => {
                    assert_eq!(e.exit_code(), 2, "{e}");
                    refused += 1;
                }
            }
        }
    }
    // Both outcomes occur: edits in comments or digits of values can leave
    // a valid file.
    assert!(
        refused > 3000 && read_ok > 10,
        "{refused} refused, {read_ok} read"
    );
}

/// A float CT (what resampling tools write) reads as the nearest whole HU,
/// in NIfTI and NRRD alike; a NaN or a value beyond int16 is refused with
/// its voxel, exit code 2.
#[test]
fn a_float_ct_is_rounded_to_whole_hu_and_a_nan_is_refused() {
    let d = tmp("float-ct");
    let v = oblique();
    // Off by up to ±0.45 HU from the integers, as a trilinear resample leaves them.
    let f = v.map(|&x| f32::from(x) + 0.45 * if x % 2 == 0 { 1.0 } else { -1.0 });
    let nii = d.join("ct.nii.gz");
    nifti::write(&nii, &f).unwrap();
    let got = read_ct(&nii).unwrap();
    assert_eq!(got.as_slice(), v.as_slice());
    // The sform is stored in float32.
    assert!((got.affine() - v.affine()).abs().max() < 1e-5);
    let f64s = v.map(|&x| f64::from(x) - 0.3);
    let nrrd = d.join("ct.nrrd");
    crate::nrrd::write(&nrrd, &f64s).unwrap();
    assert_eq!(read_ct(&nrrd).unwrap().as_slice(), v.as_slice());
    for (bad, words) in [
        (f32::NAN, "NaN"),
        (40000.0, "40000"),
        (-32768.7, "-32768.7"),
    ] {
        let mut b = f.clone();
        b[[3, 2, 1]] = bad;
        let p = d.join("bad.nii");
        nifti::write(&p, &b).unwrap();
        let e = read_ct(&p).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        let e = e.to_string();
        assert!(e.contains("[3, 2, 1]") && e.contains(words), "{e}");
    }
}
