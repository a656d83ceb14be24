//! The CT as NRRD and MetaImage (issue 24): the committed sample CT written
//! in each (by hand here, not by coapt) reads as the same volume and
//! segments to the same mask bytes as the NIfTI; `run` takes an `.nhdr` as
//! `ct =` and re-runs when its data file changes; every malformed header is
//! refused with exit 2, one line naming the file, and nothing written.

use std::io::Write;
use std::path::{Path, PathBuf};

use coapt::geom::Volume;
use coapt::io::nifti;
use flate2::Compression;
use flate2::write::{GzEncoder, ZlibEncoder};

use crate::common::*;

fn gzip(b: &[u8]) -> Vec<u8> {
    let mut e = GzEncoder::new(Vec::new(), Compression::fast());
    e.write_all(b).unwrap();
    e.finish().unwrap()
}

fn zlib(b: &[u8]) -> Vec<u8> {
    let mut e = ZlibEncoder::new(Vec::new(), Compression::fast());
    e.write_all(b).unwrap();
    e.finish().unwrap()
}

pub(crate) fn le(v: &Volume<i16>) -> Vec<u8> {
    v.as_slice().iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// A NRRD header for `v`; `ras` writes the directions and origin in RAS.
pub(crate) fn nrrd_header(v: &Volume<i16>, ras: bool, encoding: &str, extra: &str) -> String {
    let a = v.affine();
    let s = if ras { -1.0 } else { 1.0 };
    let col = |c: usize| format!("({:?},{:?},{:?})", s * a[(0, c)], s * a[(1, c)], a[(2, c)]);
    let [ni, nj, nk] = v.dims();
    let space = if ras {
        "right-anterior-superior"
    } else {
        "left-posterior-superior"
    };
    format!(
        "NRRD0004\ntype: short\ndimension: 3\nspace: {space}\nsizes: {ni} {nj} {nk}\n\
         space directions: {} {} {}\nendian: little\nencoding: {encoding}\n\
         space origin: {}\n{extra}",
        col(0),
        col(1),
        col(2),
        col(3)
    )
}

/// A MetaImage header for `v` (ITK's field order and TransformMatrix layout).
pub(crate) fn mha_header(v: &Volume<i16>, compressed: bool, file: &str) -> String {
    let a = v.affine();
    let sp = v.spacing();
    let m: Vec<String> = (0..9)
        .map(|k| format!("{:?}", a[(k % 3, k / 3)] / sp[k / 3]))
        .collect();
    let [ni, nj, nk] = v.dims();
    format!(
        "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n\
         CompressedData = {}\nTransformMatrix = {}\nOffset = {:?} {:?} {:?}\n\
         AnatomicalOrientation = RAI\nElementSpacing = {:?} {:?} {:?}\n\
         DimSize = {ni} {nj} {nk}\nElementType = MET_SHORT\nElementDataFile = {file}\n",
        if compressed { "True" } else { "False" },
        m.join(" "),
        a[(0, 3)],
        a[(1, 3)],
        a[(2, 3)],
        sp[0],
        sp[1],
        sp[2]
    )
}

pub(crate) fn attached(path: &Path, header: String, data: &[u8]) -> PathBuf {
    let mut f = header.into_bytes();
    f.extend_from_slice(data);
    std::fs::write(path, f).unwrap();
    path.to_path_buf()
}

fn segment_output(ct: &Path, out: &Path, lm: &Path) -> std::process::Output {
    coapt(&[
        "segment",
        "--ct",
        &s(ct),
        "--landmarks",
        &s(lm),
        "--out",
        &s(out),
        "--quiet",
    ])
}

fn segment(ct: &Path, out: &Path, lm: &Path) -> Vec<u8> {
    let o = segment_output(ct, out, lm);
    assert_eq!(o.status.code(), Some(0), "{}: {}", ct.display(), stderr(&o));
    std::fs::read(out).unwrap()
}

fn info(p: &Path) -> serde_json::Value {
    let o = coapt(&["info", "--json", &s(p)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn sample_ct_as_nrrd_and_metaimage_segments_to_the_same_mask_bytes() {
    let d = tmpdir("formats-same");
    let sample = repo().join("sample_data");
    let nii = sample.join("ct.nii.gz");
    let lm = sample.join("landmarks.mrk.json");
    let v = nifti::read_i16(&nii).unwrap();
    let raw = le(&v);

    let converted = d.join("converted.nrrd");
    let o = coapt(&["convert", &s(&nii), &s(&converted)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    std::fs::write(d.join("ras.raw.gz"), gzip(&raw)).unwrap();
    let ras = d.join("ras.nhdr");
    std::fs::write(
        &ras,
        nrrd_header(&v, true, "gzip", "data file: ras.raw.gz\n"),
    )
    .unwrap();
    let lps_raw = attached(
        &d.join("lps.nrrd"),
        nrrd_header(&v, false, "raw", "\n"),
        &raw,
    );
    let mha = attached(
        &d.join("ct.mha"),
        mha_header(&v, true, "LOCAL"),
        &zlib(&raw),
    );
    std::fs::write(d.join("ct.raw"), &raw).unwrap();
    let mhd = d.join("ct.mhd");
    std::fs::write(&mhd, mha_header(&v, false, "ct.raw")).unwrap();

    let want = info(&nii);
    let reference = segment(&nii, &d.join("mask-nii.nii.gz"), &lm);
    for (k, p) in [&converted, &ras, &lps_raw, &mha, &mhd]
        .into_iter()
        .enumerate()
    {
        // The library reads the same voxels and grid.
        let got = coapt::io::volume_file::read_ct(p).unwrap();
        assert_eq!(got.dims(), v.dims(), "{}", p.display());
        assert_eq!(got.as_slice(), v.as_slice(), "{}", p.display());
        let off = (got.affine() - v.affine()).abs().max();
        assert!(off < 1e-6, "{}: affine off by {off} mm", p.display());
        // `info` says so too.
        let i = info(p);
        assert_eq!(i["dims"], want["dims"]);
        assert_eq!(i["value_mean"], want["value_mean"], "{}", p.display());
        for (r, row) in want["affine_voxel_to_lps"]
            .as_array()
            .unwrap()
            .iter()
            .enumerate()
        {
            for (c, x) in row.as_array().unwrap().iter().enumerate() {
                let y = &i["affine_voxel_to_lps"][r][c];
                assert!((x.as_f64().unwrap() - y.as_f64().unwrap()).abs() < 1e-6);
            }
        }
        // And the segmentation is the same, byte for byte.
        let mask = segment(p, &d.join(format!("mask-{k}.nii.gz")), &lm);
        assert!(mask == reference, "{}: mask differs", p.display());
    }
    assert_eq!(info(&ras)["transform"], "space RAS");
    assert_eq!(info(&ras)["encoding"], "gzip");
    assert!(
        info(&ras)["data_file"]
            .as_str()
            .unwrap()
            .ends_with("ras.raw.gz")
    );
    assert_eq!(info(&mha)["format"], "MetaImage");
    // `check` accepts all of them as a CT.
    let o = coapt(&["check", "--ct", &s(&ras), "--ct", &s(&mhd)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// A float32 CT with fractional HU, as resampling tools write it, segments
/// to the same mask bytes as the int16 CT it rounds to (before, it was
/// refused: "reading as int16 needs integers"); a NaN voxel is refused
/// with its index, exit code 2 and no mask.
#[test]
fn a_float_ct_segments_as_the_int16_ct_it_rounds_to() {
    let d = tmpdir("formats-float");
    let sample = repo().join("sample_data");
    let nii = sample.join("ct.nii.gz");
    let lm = sample.join("landmarks.mrk.json");
    let v = nifti::read_i16(&nii).unwrap();
    let f = v.map(|&x| f32::from(x) + if x % 2 == 0 { 0.4 } else { -0.4 });
    let float = d.join("float.nii.gz");
    nifti::write(&float, &f).unwrap();
    let reference = segment(&nii, &d.join("mask-int16.nii.gz"), &lm);
    let got = segment(&float, &d.join("mask-float.nii.gz"), &lm);
    assert!(got == reference, "the float CT's mask differs");
    let mut bad = f.clone();
    bad[[10, 20, 30]] = f32::NAN;
    let nan = d.join("nan.nii.gz");
    nifti::write(&nan, &bad).unwrap();
    let out = d.join("mask-nan.nii.gz");
    let o = segment_output(&nan, &out, &lm);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("nan.nii.gz") && e.contains("[10, 20, 30]") && e.contains("NaN"),
        "{e}"
    );
    assert!(!out.exists(), "a mask was written for a refused CT");
}

#[test]
fn run_takes_an_nhdr_ct_and_reruns_when_its_data_file_changes() {
    let d = tmpdir("formats-run");
    let sample = repo().join("sample_data");
    let lm = sample.join("landmarks.mrk.json");
    let v = nifti::read_i16(&sample.join("ct.nii.gz")).unwrap();
    let mut raw = le(&v);
    std::fs::write(d.join("ct.raw"), &raw).unwrap();
    let nhdr = d.join("ct.nhdr");
    std::fs::write(&nhdr, nrrd_header(&v, false, "raw", "data file: ct.raw\n")).unwrap();
    let cfg = d.join("run.toml");
    std::fs::write(
        &cfg,
        format!(
            "[run]\ndir = \"{}\"\n\n[inputs]\nct = \"{}\"\nlandmarks = \"{}\"\n",
            s(&d.join("run")),
            s(&nhdr),
            s(&lm)
        ),
    )
    .unwrap();
    let run = |tag: &str| {
        let o = coapt(&["run", &s(&cfg), "--until", "segment", "--quiet"]);
        assert_eq!(o.status.code(), Some(0), "{tag}: {}", stderr(&o));
        let m = json(&d.join("run/manifest.json"));
        let rec = m["stages"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["stage"] == "segment")
            .unwrap()
            .clone();
        (rec["status"].as_str().unwrap().to_string(), rec)
    };
    let (status, rec) = run("first");
    assert_eq!(status, "ran");
    // The header and its data file are hashed together.
    assert_eq!(
        rec["inputs"]["ct"]["bytes"].as_u64().unwrap(),
        std::fs::metadata(&nhdr).unwrap().len() + raw.len() as u64
    );
    let reference = segment(&sample.join("ct.nii.gz"), &d.join("reference.nii.gz"), &lm);
    assert!(std::fs::read(d.join("run/mask.nii.gz")).unwrap() == reference);
    assert_eq!(run("again").0, "skipped");
    // One voxel of the data file changes, the header does not.
    raw[0] ^= 1;
    std::fs::write(d.join("ct.raw"), &raw).unwrap();
    let (status, rec) = run("changed data");
    assert_eq!(status, "ran", "{rec}");
    assert!(
        rec["reason"].as_str().unwrap().contains("input ct changed"),
        "{rec}"
    );
}

/// A small valid CT (6×5×4 int16) to break in one way at a time.
fn small() -> Volume<i16> {
    let a = coapt::geom::volume::affine_from_parts(
        [0.5, 0.5, 0.8],
        &coapt::geom::Matrix3::identity(),
        coapt::geom::Point3::new(1.0, 2.0, 3.0),
    );
    Volume::from_fortran_vec([6, 5, 4], a, (0..120).map(|x| x as i16).collect()).unwrap()
}

/// `segment`, `check` and `info` refuse `file` (the file the message names
/// is `named`) with exit 2 and `words`; `segment` writes nothing. `check`
/// reads headers only (as for NIfTI): damage inside a compressed stream is
/// found when the voxels are read, so it is not asked about that.
fn refused(file: &Path, named: &Path, words: &[&str]) {
    refused_by_readers(file, named, words);
    assert_bad_input(&coapt(&["check", "--ct", &s(file)]), named, words);
}

fn refused_by_readers(file: &Path, named: &Path, words: &[&str]) {
    let out = file.parent().unwrap().join("out");
    let o = coapt(&[
        "segment",
        "--ct",
        &s(file),
        "--out",
        &s(&out.join("mask.nii.gz")),
        "--quiet",
    ]);
    assert_bad_input(&o, named, words);
    assert!(
        !out.exists() || entries(&out).is_empty(),
        "segment wrote {out:?}"
    );
    assert_bad_input(&coapt(&["info", &s(file)]), named, words);
}

#[test]
fn malformed_headers_are_refused_with_exit_2_and_nothing_written() {
    let v = small();
    let raw = le(&v);
    let nrrd = nrrd_header(&v, false, "raw", "\n");
    let mha = mha_header(&v, false, "LOCAL");
    // (name, header, data, words)
    let cases: Vec<(&str, String, Vec<u8>, Vec<&str>)> = vec![
        (
            "no-sizes.nrrd",
            nrrd.replace("sizes: 6 5 4\n", ""),
            raw.clone(),
            vec!["\"sizes\" is missing"],
        ),
        (
            "two-sizes.nrrd",
            nrrd.replace("sizes: 6 5 4", "sizes: 6 5"),
            raw.clone(),
            vec!["needs 3"],
        ),
        (
            "zero-size.nrrd",
            nrrd.replace("sizes: 6 5 4", "sizes: 6 0 4"),
            raw.clone(),
            vec!["must be ≥ 1"],
        ),
        (
            "bad-size.nrrd",
            nrrd.replace("sizes: 6 5 4", "sizes: 6 five 4"),
            raw.clone(),
            vec!["not a whole number"],
        ),
        (
            "huge.nrrd",
            nrrd.replace("sizes: 6 5 4", "sizes: 90000 90000 90000"),
            raw.clone(),
            vec!["above the limit"],
        ),
        (
            "long-axis.nrrd",
            nrrd.replace("sizes: 6 5 4", "sizes: 6 5 4000000"),
            raw.clone(),
            vec!["corrupt"],
        ),
        (
            "tiny-spacing.nrrd",
            nrrd.replace("(0.5,0.0,0.0)", "(1e-7,0.0,0.0)"),
            raw.clone(),
            vec!["spacing along axis 1"],
        ),
        (
            "flat.nrrd",
            nrrd.replace("(0.0,0.0,0.8)", "(0.0,0.0,0.0)"),
            raw.clone(),
            vec!["singular"],
        ),
        (
            "no-space.nrrd",
            nrrd.replace("space: left-posterior-superior\n", ""),
            raw.clone(),
            vec!["no \"space\" field"],
        ),
        (
            "bzip2.nrrd",
            nrrd.replace("encoding: raw", "encoding: bzip2"),
            raw.clone(),
            vec!["raw and gzip"],
        ),
        (
            "truncated.nrrd",
            nrrd.clone(),
            raw[..200].to_vec(),
            vec!["truncated", "found 200"],
        ),
        (
            "too-long.nrrd",
            nrrd.clone(),
            [raw.as_slice(), &raw].concat(),
            vec!["does not describe"],
        ),
        (
            "truncated-gz.nrrd",
            nrrd.replace("encoding: raw", "encoding: gzip"),
            gzip(&raw)[..30].to_vec(),
            vec!["gzip"],
        ),
        (
            "no-spacing.mha",
            mha.replace("ElementSpacing = 0.5 0.5 0.8\n", ""),
            raw.clone(),
            vec!["ElementSpacing is missing"],
        ),
        (
            "bad-dims.mha",
            mha.replace("DimSize = 6 5 4", "DimSize = 6 -5 4"),
            raw.clone(),
            vec!["not a whole number"],
        ),
        (
            "huge.mha",
            mha.replace("DimSize = 6 5 4", "DimSize = 99999 99999 99999"),
            raw.clone(),
            vec!["above the limit"],
        ),
        (
            "zero-spacing.mha",
            mha.replace("ElementSpacing = 0.5 0.5 0.8", "ElementSpacing = 0.5 0 0.8"),
            raw.clone(),
            vec!["singular"],
        ),
        (
            "vector.mha",
            mha.replace("NDims = 3\n", "NDims = 3\nElementNumberOfChannels = 3\n"),
            raw.clone(),
            vec!["scalar"],
        ),
        (
            "truncated.mha",
            mha.replace("CompressedData = False", "CompressedData = True"),
            zlib(&raw)[..20].to_vec(),
            vec!["zlib"],
        ),
    ];
    for (name, header, data, words) in cases {
        let d = tmpdir(&format!("formats-bad-{name}"));
        let p = attached(&d.join(name), header, &data);
        if name.starts_with("truncated-") || name.ends_with(".mha") && name.starts_with("trunc") {
            refused_by_readers(&p, &p, &words);
            let o = coapt(&["check", "--ct", &s(&p)]);
            assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
        } else {
            refused(&p, &p, &words);
        }
    }
    // A detached header whose data file is missing, or short.
    let d = tmpdir("formats-bad-detached");
    let p = d.join("ct.nhdr");
    std::fs::write(&p, nrrd_header(&v, false, "raw", "data file: ct.raw\n")).unwrap();
    refused(&p, &p, &["ct.raw does not exist"]);
    std::fs::write(d.join("ct.raw"), &raw[..100]).unwrap();
    refused(&p, &d.join("ct.raw"), &["truncated", "voxel data of"]);
    // A folder without DICOM images, a broken DICOM file, a text file.
    let d = tmpdir("formats-bad-other");
    let dir = d.join("series");
    std::fs::create_dir_all(&dir).unwrap();
    refused(&dir, &dir, &["no DICOM images", "NRRD", "MetaImage"]);
    let mut dcm = vec![0u8; 128];
    dcm.extend_from_slice(b"DICM\x02\x00\x00\x00");
    let p = d.join("IM0001.dcm");
    std::fs::write(&p, dcm).unwrap();
    // Read as DICOM (a single file may be a multi-frame CT): its damage named.
    refused(&p, &p, &["corrupt DICOM file"]);
    let p = d.join("notes.txt");
    std::fs::write(&p, "not a volume\n").unwrap();
    refused(&p, &p, &["NIfTI", "NRRD", "MetaImage"]);
}
