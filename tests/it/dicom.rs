//! The CT as a folder of a DICOM series (issue 24): written here from the
//! sample phantom and from small oblique volumes with dicom-rs (shuffled
//! file names, InstanceNumbers in reverse, a wrong SliceThickness, per-slice
//! rescale, uncompressed and RLE), read back identical to the NIfTI and
//! segmented to the same mask bytes; every malformed series refused.

use std::path::{Path, PathBuf};

use coapt::geom::Volume;
use coapt::io::nifti;
use dicom_core::value::{DataSetSequence, PixelFragmentSequence};
use dicom_core::{DataElement, PrimitiveValue, VR, dicom_value};
use dicom_dictionary_std::{tags, uids};
use dicom_object::mem::InMemElement;
use dicom_object::{FileMetaTableBuilder, InMemDicomObject};

use crate::common::*;

/// How a series' pixel data are encoded.
#[derive(Clone, Copy, PartialEq)]
enum Codec {
    Plain,
    Rle,
    /// JPEG lossless, Process 14, selection value 1 (1.2.840.10008.1.2.4.70).
    JpegLossless,
    /// Encapsulated pixel data under this transfer syntax whose single
    /// fragment is no codestream: for refusals decided by the syntax alone.
    Refused(&'static str),
}

/// How to write a series; each field breaks or varies one thing.
#[derive(Clone)]
pub(crate) struct Spec {
    uid: String,
    number: i32,
    modality: &'static str,
    image_type: &'static str,
    description: &'static str,
    codec: Codec,
    /// Slices left out (a missing slice).
    skip: Option<usize>,
    /// In-plane shift per slice along the rows (gantry tilt), mm.
    shear_mm: f64,
    /// Extra offset of one slice along the normal (uneven steps), mm.
    jolt: Option<(usize, f64)>,
}

impl Spec {
    pub(crate) fn new(uid: &str, number: i32) -> Self {
        Spec {
            uid: uid.into(),
            number,
            modality: "CT",
            image_type: "ORIGINAL\\PRIMARY\\AXIAL",
            description: "CTA 1.0 test",
            codec: Codec::Plain,
            skip: None,
            shear_mm: 0.0,
            jolt: None,
        }
    }

    fn transfer_syntax(&self) -> &'static str {
        match self.codec {
            Codec::Plain => uids::EXPLICIT_VR_LITTLE_ENDIAN,
            Codec::Rle => uids::RLE_LOSSLESS,
            Codec::JpegLossless => uids::JPEG_LOSSLESS_SV1,
            Codec::Refused(ts) => ts,
        }
    }
}

/// A decimal string of at most 16 characters (DICOM's DS limit).
fn ds(x: f64) -> String {
    let s = format!("{x}");
    if s.len() <= 16 {
        return s;
    }
    for p in (0..16).rev() {
        let t = format!("{x:.p$}");
        if t.len() <= 16 {
            return t;
        }
    }
    format!("{x:.3e}")
}

/// PackBits, as DICOM RLE wants it: replicate runs of 3 or more, literals
/// otherwise, padded to an even length with a no-op.
fn packbits(b: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let mut run = 1;
        while i + run < b.len() && run < 128 && b[i + run] == b[i] {
            run += 1;
        }
        if run >= 3 {
            out.push((257 - run) as u8);
            out.push(b[i]);
            i += run;
        } else {
            let start = i;
            while i < b.len() && i - start < 128 {
                if i + 2 < b.len() && b[i] == b[i + 1] && b[i] == b[i + 2] {
                    break;
                }
                i += 1;
            }
            out.push((i - start - 1) as u8);
            out.extend_from_slice(&b[start..i]);
        }
    }
    if out.len() % 2 == 1 {
        out.push(0x80);
    }
    out
}

/// One 16-bit frame as DICOM RLE: header, high bytes, low bytes.
fn rle_frame(px: &[u16]) -> Vec<u8> {
    let hi = packbits(&px.iter().map(|x| (x >> 8) as u8).collect::<Vec<_>>());
    let lo = packbits(&px.iter().map(|x| *x as u8).collect::<Vec<_>>());
    let mut h = vec![0u8; 64];
    h[0..4].copy_from_slice(&2u32.to_le_bytes());
    h[4..8].copy_from_slice(&64u32.to_le_bytes());
    h[8..12].copy_from_slice(&(64 + hi.len() as u32).to_le_bytes());
    [h, hi, lo].concat()
}

/// Bits into bytes, most significant first, with JPEG's 0xFF00 stuffing.
struct BitWriter {
    out: Vec<u8>,
    acc: u32,
    n: u32,
}

impl BitWriter {
    fn put(&mut self, value: u32, bits: u32) {
        for b in (0..bits).rev() {
            self.acc = (self.acc << 1) | ((value >> b) & 1);
            self.n += 1;
            if self.n == 8 {
                self.out.push(self.acc as u8);
                if self.acc == 0xFF {
                    self.out.push(0);
                }
                self.acc = 0;
                self.n = 0;
            }
        }
    }

    /// Pad the last byte with 1-bits (T.81 F.1.2.3).
    fn finish(mut self) -> Vec<u8> {
        while self.n != 0 {
            self.put(1, 1);
        }
        self.out
    }
}

/// One 16-bit greyscale frame as lossless JPEG (ITU T.81 Annex H, Process
/// 14, first-order prediction: selection value 1), with a Huffman table
/// that gives each of the 17 difference categories a 5-bit code. Written
/// here from the standard so the test owns its reference encoder; the
/// decoder it is checked against is dicom-rs's (jpeg-decoder).
fn jpeg_lossless_frame(px: &[u16], cols: usize, rows: usize) -> Vec<u8> {
    let mut j = vec![0xFF, 0xD8];
    // SOF3: precision 16, rows, columns, one component (id 1, 1×1, Tq 0).
    j.extend_from_slice(&[0xFF, 0xC3, 0, 11, 16]);
    j.extend_from_slice(&(rows as u16).to_be_bytes());
    j.extend_from_slice(&(cols as u16).to_be_bytes());
    j.extend_from_slice(&[1, 1, 0x11, 0]);
    // DHT: DC table 0, 17 codes of length 5 for the categories 0…16.
    j.extend_from_slice(&[0xFF, 0xC4, 0, 2 + 1 + 16 + 17, 0x00]);
    let mut counts = [0u8; 16];
    counts[4] = 17;
    j.extend_from_slice(&counts);
    j.extend((0..17).map(|c| c as u8));
    // SOS: one component with table 0, predictor 1, Se 0, point transform 0.
    j.extend_from_slice(&[0xFF, 0xDA, 0, 8, 1, 1, 0x00, 1, 0, 0]);
    let mut w = BitWriter {
        out: Vec::new(),
        acc: 0,
        n: 0,
    };
    for r in 0..rows {
        for c in 0..cols {
            let x = px[r * cols + c] as i32;
            let pred = match (r, c) {
                (0, 0) => 1 << 15,
                (_, 0) => px[(r - 1) * cols] as i32,
                _ => px[r * cols + c - 1] as i32,
            };
            // The difference modulo 2^16, as −32768…32767.
            let mut d = (x - pred) & 0xFFFF;
            if d >= 0x8000 {
                d -= 0x10000;
            }
            if d == -0x8000 {
                // Category 16 stands for 32768 and has no extra bits.
                w.put(16, 5);
                continue;
            }
            let cat = 32 - d.unsigned_abs().leading_zeros();
            w.put(cat, 5);
            if cat > 0 {
                let extra = if d > 0 { d } else { d + (1 << cat) - 1 };
                w.put(extra as u32, cat);
            }
        }
    }
    j.extend(w.finish());
    j.extend_from_slice(&[0xFF, 0xD9]);
    if j.len() % 2 == 1 {
        j.push(0);
    }
    j
}

/// The slices `spec` writes of `v`: index k, Image Position (Patient),
/// Rescale Intercept (alternating per slice) and the stored values.
fn slices(v: &Volume<i16>, spec: &Spec) -> Vec<(usize, nalgebra::Vector3<f64>, f64, Vec<u16>)> {
    let a = v.affine();
    let [ni, nj, nk] = v.dims();
    let col = |c: usize| nalgebra::Vector3::new(a[(0, c)], a[(1, c)], a[(2, c)]);
    let row = col(0).normalize();
    let normal = row.cross(&col(1).normalize());
    (0..nk)
        .filter(|&k| spec.skip != Some(k))
        .map(|k| {
            let mut p = col(3) + col(2) * k as f64 + row * spec.shear_mm * k as f64;
            if let Some((kk, d)) = spec.jolt {
                if kk == k {
                    p += normal * d;
                }
            }
            let intercept = if k % 2 == 0 { -1024.0 } else { 0.0 };
            let stored: Vec<u16> = v.as_slice()[k * ni * nj..(k + 1) * ni * nj]
                .iter()
                .map(|&hu| (hu as f64 - intercept) as i16 as u16)
                .collect();
            (k, p, intercept, stored)
        })
        .collect()
}

/// Image Orientation (Patient) and Pixel Spacing of `v`.
fn plane(v: &Volume<i16>) -> (PrimitiveValue, PrimitiveValue) {
    let a = v.affine();
    let col = |c: usize| nalgebra::Vector3::new(a[(0, c)], a[(1, c)], a[(2, c)]);
    let (si, sj) = (col(0).norm(), col(1).norm());
    let (r, c) = (col(0) / si, col(1) / sj);
    let o = [r.x, r.y, r.z, c.x, c.y, c.z].map(ds);
    (
        PrimitiveValue::Strs(o.into_iter().collect()),
        dicom_value!(Strs, [ds(sj), ds(si)]),
    )
}

fn ds3(p: &nalgebra::Vector3<f64>) -> PrimitiveValue {
    dicom_value!(Strs, [ds(p.x), ds(p.y), ds(p.z)])
}

/// The pixel data element of `frames` (each cols × rows) in `codec`.
fn pixel_data(frames: &[&[u16]], cols: usize, rows: usize, codec: Codec) -> InMemElement {
    let encoded = |f: &[u16]| match codec {
        Codec::Rle => rle_frame(f),
        Codec::JpegLossless => jpeg_lossless_frame(f, cols, rows),
        _ => vec![0xFF, 0xD8, 0xFF, 0xD9],
    };
    match codec {
        Codec::Plain => DataElement::new(
            tags::PIXEL_DATA,
            VR::OW,
            PrimitiveValue::U16(frames.iter().flat_map(|f| f.iter().copied()).collect()),
        ),
        _ => DataElement::new(
            tags::PIXEL_DATA,
            VR::OB,
            PixelFragmentSequence::new(
                Vec::<u32>::new(),
                frames.iter().map(|f| encoded(f)).collect::<Vec<_>>(),
            ),
        ),
    }
}

/// The attributes every image of the series shares.
fn common(v: &Volume<i16>, spec: &Spec, sop_class: &str, sop: &str) -> Vec<InMemElement> {
    let [ni, nj, _] = v.dims();
    let us = |tag, x: u16| DataElement::new(tag, VR::US, PrimitiveValue::from(x));
    vec![
        DataElement::new(tags::SOP_CLASS_UID, VR::UI, PrimitiveValue::from(sop_class)),
        DataElement::new(tags::SOP_INSTANCE_UID, VR::UI, PrimitiveValue::from(sop)),
        DataElement::new(tags::MODALITY, VR::CS, PrimitiveValue::from(spec.modality)),
        DataElement::new(
            tags::SERIES_INSTANCE_UID,
            VR::UI,
            PrimitiveValue::from(spec.uid.as_str()),
        ),
        DataElement::new(
            tags::SERIES_NUMBER,
            VR::IS,
            PrimitiveValue::from(spec.number.to_string()),
        ),
        DataElement::new(
            tags::SERIES_DESCRIPTION,
            VR::LO,
            PrimitiveValue::from(spec.description),
        ),
        DataElement::new(
            tags::IMAGE_TYPE,
            VR::CS,
            PrimitiveValue::from(spec.image_type),
        ),
        us(tags::ROWS, nj as u16),
        us(tags::COLUMNS, ni as u16),
        us(tags::SAMPLES_PER_PIXEL, 1),
        DataElement::new(
            tags::PHOTOMETRIC_INTERPRETATION,
            VR::CS,
            PrimitiveValue::from("MONOCHROME2"),
        ),
        us(tags::BITS_ALLOCATED, 16),
        us(tags::BITS_STORED, 16),
        us(tags::HIGH_BIT, 15),
        us(tags::PIXEL_REPRESENTATION, 1),
    ]
}

fn save(obj: InMemDicomObject, spec: &Spec, sop_class: &str, sop: &str, path: &Path) {
    obj.with_meta(
        FileMetaTableBuilder::new()
            .transfer_syntax(spec.transfer_syntax())
            .media_storage_sop_class_uid(sop_class)
            .media_storage_sop_instance_uid(sop),
    )
    .unwrap()
    .write_to_file(path)
    .unwrap();
}

/// Write `v` as a series into `dir`: file names shuffled, InstanceNumber
/// counting down, slope 1 and an intercept that alternates per slice.
pub(crate) fn write_series(dir: &Path, v: &Volume<i16>, spec: &Spec) {
    std::fs::create_dir_all(dir).unwrap();
    let [ni, nj, nk] = v.dims();
    let (orientation, spacing) = plane(v);
    for (k, p, intercept, stored) in slices(v, spec) {
        let sop = format!("{}.{}", spec.uid, k + 1);
        let mut e = common(v, spec, uids::CT_IMAGE_STORAGE, &sop);
        e.extend([
            DataElement::new(
                tags::INSTANCE_NUMBER,
                VR::IS,
                PrimitiveValue::from((nk - k).to_string()),
            ),
            DataElement::new(tags::SLICE_THICKNESS, VR::DS, PrimitiveValue::from("5.0")),
            DataElement::new(tags::IMAGE_POSITION_PATIENT, VR::DS, ds3(&p)),
            DataElement::new(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, orientation.clone()),
            DataElement::new(tags::PIXEL_SPACING, VR::DS, spacing.clone()),
            DataElement::new(
                tags::RESCALE_INTERCEPT,
                VR::DS,
                PrimitiveValue::from(ds(intercept)),
            ),
            DataElement::new(tags::RESCALE_SLOPE, VR::DS, PrimitiveValue::from("1")),
            pixel_data(&[&stored], ni, nj, spec.codec),
        ]);
        // Names in a shuffled order, unrelated to the position.
        let name = format!("IM{:05}", (k * 7919 + 13) % 10007);
        let path = dir.join(format!("{}-{name}", spec.number));
        save(
            InMemDicomObject::from_element_iter(e),
            spec,
            uids::CT_IMAGE_STORAGE,
            &sop,
            &path,
        );
    }
}

fn sequence(tag: dicom_core::Tag, items: Vec<InMemDicomObject>) -> InMemElement {
    DataElement::new(tag, VR::SQ, DataSetSequence::from(items))
}

fn item(elements: Vec<InMemElement>) -> InMemDicomObject {
    InMemDicomObject::from_element_iter(elements)
}

/// Write `v` as one multi-frame file of SOP class `sop_class` (Enhanced CT
/// or Legacy Converted Enhanced CT): orientation and pixel spacing in the
/// Shared Functional Groups, each frame's position and rescale in its
/// Per-frame Functional Groups item, frames stored in a shuffled order.
fn write_multiframe(path: &Path, v: &Volume<i16>, spec: &Spec, sop_class: &str) {
    let [ni, nj, _] = v.dims();
    let (orientation, spacing) = plane(v);
    let mut frames = slices(v, spec);
    let n = frames.len();
    // A permutation of the slices (5 is prime to every count used here).
    assert!(n % 5 != 0);
    let order: Vec<usize> = (0..n).map(|f| (f * 5 + 3) % n).collect();
    frames = order.iter().map(|&i| frames[i].clone()).collect();
    let ds_el = |tag, x: f64| DataElement::new(tag, VR::DS, PrimitiveValue::from(ds(x)));
    let shared = item(vec![
        sequence(
            tags::PLANE_ORIENTATION_SEQUENCE,
            vec![item(vec![DataElement::new(
                tags::IMAGE_ORIENTATION_PATIENT,
                VR::DS,
                orientation,
            )])],
        ),
        sequence(
            tags::PIXEL_MEASURES_SEQUENCE,
            vec![item(vec![
                DataElement::new(tags::PIXEL_SPACING, VR::DS, spacing),
                // Wrong on purpose: the step comes from the positions.
                DataElement::new(tags::SLICE_THICKNESS, VR::DS, PrimitiveValue::from("5.0")),
            ])],
        ),
    ]);
    let per_frame: Vec<InMemDicomObject> = frames
        .iter()
        .map(|(_, p, intercept, _)| {
            item(vec![
                sequence(
                    tags::PLANE_POSITION_SEQUENCE,
                    vec![item(vec![DataElement::new(
                        tags::IMAGE_POSITION_PATIENT,
                        VR::DS,
                        ds3(p),
                    )])],
                ),
                sequence(
                    tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE,
                    vec![item(vec![
                        ds_el(tags::RESCALE_INTERCEPT, *intercept),
                        ds_el(tags::RESCALE_SLOPE, 1.0),
                        DataElement::new(tags::RESCALE_TYPE, VR::LO, PrimitiveValue::from("HU")),
                    ])],
                ),
            ])
        })
        .collect();
    let sop = format!("{}.1", spec.uid);
    let mut e = common(v, spec, sop_class, &sop);
    let pixels: Vec<&[u16]> = frames.iter().map(|f| f.3.as_slice()).collect();
    e.extend([
        DataElement::new(
            tags::NUMBER_OF_FRAMES,
            VR::IS,
            PrimitiveValue::from(n.to_string()),
        ),
        sequence(tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE, vec![shared]),
        sequence(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE, per_frame),
        pixel_data(&pixels, ni, nj, spec.codec),
    ]);
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    save(item(e), spec, sop_class, &sop, path);
}

/// 9×8×7 int16, rotated obliquely (right-handed), spacings 0.6/0.7/1.25 mm.
fn oblique() -> Volume<i16> {
    let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.9);
    let a = coapt::geom::volume::affine_from_parts(
        [0.6, 0.7, 1.25],
        r.matrix(),
        coapt::geom::Point3::new(-20.5, 11.25, 140.0),
    );
    let vals = (0..9 * 8 * 7)
        .map(|x| (x * 37 % 2500 - 1100) as i16)
        .collect();
    Volume::from_fortran_vec([9, 8, 7], a, vals).unwrap()
}

fn assert_same(got: &Volume<i16>, want: &Volume<i16>, what: &str) {
    assert_eq!(got.dims(), want.dims(), "{what}");
    assert!(got.as_slice() == want.as_slice(), "{what}: HU differ");
    let off = (got.affine() - want.affine()).abs().max();
    assert!(off < 1e-6, "{what}: affine off by {off} mm");
}

#[test]
fn sample_ct_as_a_dicom_series_segments_to_the_same_mask_bytes() {
    let d = tmpdir("dicom-sample");
    let sample = repo().join("sample_data");
    let nii = sample.join("ct.nii.gz");
    let lm = sample.join("landmarks.mrk.json");
    let v = nifti::read_i16(&nii).unwrap();
    let plain = d.join("plain");
    write_series(&plain, &v, &Spec::new("1.2.826.0.1.3680043.2.1125.1", 3));
    let rle = d.join("rle");
    let mut spec = Spec::new("1.2.826.0.1.3680043.2.1125.2", 4);
    spec.codec = Codec::Rle;
    write_series(&rle, &v, &spec);
    std::fs::write(plain.join("README.txt"), "not an image\n").unwrap();
    // The same as one Enhanced CT file, frames placed by functional groups.
    let enhanced = d.join("enhanced").join("CT.dcm");
    write_multiframe(
        &enhanced,
        &v,
        &Spec::new("1.2.826.0.1.3680043.2.1125.3", 5),
        uids::ENHANCED_CT_IMAGE_STORAGE,
    );
    for dir in [&plain, &rle, &enhanced] {
        let got = coapt::io::volume_file::read_ct(dir).unwrap();
        assert_same(&got, &v, &dir.display().to_string());
    }
    let masks: Vec<Vec<u8>> = [&nii, &plain, &enhanced]
        .iter()
        .enumerate()
        .map(|(k, ct)| {
            let out = d.join(format!("mask{k}.nii.gz"));
            let o = coapt(&[
                "segment",
                "--ct",
                &s(ct),
                "--landmarks",
                &s(&lm),
                "--out",
                &s(&out),
                "--quiet",
            ]);
            assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
            std::fs::read(out).unwrap()
        })
        .collect();
    assert!(
        masks[0] == masks[1],
        "the DICOM series segments differently"
    );
    assert!(
        masks[0] == masks[2],
        "the multi-frame file segments differently"
    );
    // `info` lists the series and describes its volume.
    let o = coapt(&["info", "--json", &s(&plain)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let i: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(i["series"].as_array().unwrap().len(), 1);
    assert_eq!(i["series"][0]["number"], 3);
    assert_eq!(i["series"][0]["images"], 112);
    assert_eq!(i["other_files"], 1);
    assert_eq!(i["volume"]["dims"], serde_json::json!([112, 112, 112]));
    assert_eq!(i["volume"]["format"], "DICOM");
}

#[test]
fn oblique_series_and_a_choice_between_two() {
    let d = tmpdir("dicom-oblique");
    let v = oblique();
    let dir = d.join("study");
    write_series(&dir, &v, &Spec::new("1.2.3.4.100", 2));
    let mut other = Spec::new("1.2.3.4.200", 5);
    other.codec = Codec::Rle;
    write_series(&dir, &v, &other);
    // Two series: refused without a choice, listing both.
    let o = coapt(&["check", "--ct", &s(&dir)]);
    assert_bad_input(
        &o,
        &dir,
        &["2 series", "--series", "1.2.3.4.100", "1.2.3.4.200"],
    );
    let o = coapt(&["info", &s(&dir)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("several series"));
    // Chosen by number or UID, each reads back as the volume.
    for pick in ["2", "1.2.3.4.200"] {
        let o = coapt(&["--series", pick, "check", "--ct", &s(&dir)]);
        assert_eq!(o.status.code(), Some(0), "{pick}: {}", stderr(&o));
        let out = d.join(format!("v{pick}.nrrd"));
        let o = coapt(&["--series", pick, "convert", &s(&dir), &s(&out)]);
        assert_eq!(o.status.code(), Some(0), "{pick}: {}", stderr(&o));
        let got = coapt::io::volume_file::read_ct(&out).unwrap();
        assert_same(&got, &v, pick);
    }
    let o = coapt(&["--series", "9", "check", "--ct", &s(&dir)]);
    assert_bad_input(&o, &dir, &["no series 9"]);
}

#[test]
fn malformed_series_are_refused_with_exit_2_and_nothing_written() {
    let v = oblique();
    let base = Spec::new("1.2.3.9", 1);
    let cases: Vec<(&str, Spec, &[&str])> = vec![
        (
            "missing",
            Spec {
                skip: Some(3),
                ..base.clone()
            },
            &["1 slice is missing"],
        ),
        (
            "mr",
            Spec {
                modality: "MR",
                ..base.clone()
            },
            &["modality", "not CT"],
        ),
        (
            "tilt",
            Spec {
                shear_mm: 0.3,
                ..base.clone()
            },
            &["sheared", "gantry tilt"],
        ),
        (
            "uneven",
            Spec {
                jolt: Some((4, 0.4)),
                ..base.clone()
            },
            &["not uniform"],
        ),
        (
            "scout",
            Spec {
                image_type: "ORIGINAL\\PRIMARY\\LOCALIZER",
                ..base.clone()
            },
            &["localiser"],
        ),
    ];
    for (name, spec, words) in cases {
        let d = tmpdir(&format!("dicom-bad-{name}"));
        let dir = d.join(name);
        write_series(&dir, &v, &spec);
        let out = d.join("out");
        let o = coapt(&[
            "segment",
            "--ct",
            &s(&dir),
            "--out",
            &s(&out.join("mask.nii.gz")),
            "--quiet",
        ]);
        assert_bad_input(&o, &dir, words);
        assert!(!out.exists(), "{name}: segment wrote {out:?}");
        assert_bad_input(&coapt(&["check", "--ct", &s(&dir)]), &dir, words);
        // The same stack as one multi-frame file: the same refusal.
        let file = d.join(format!("{name}.dcm"));
        write_multiframe(&file, &v, &spec, uids::ENHANCED_CT_IMAGE_STORAGE);
        assert_bad_input(&coapt(&["check", "--ct", &s(&file)]), &file, words);
    }
    // An empty folder, and one DICOM file given instead of its folder.
    let d = tmpdir("dicom-bad-other");
    let empty = d.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    assert_bad_input(
        &coapt(&["check", "--ct", &s(&empty)]),
        &empty,
        &["no DICOM images", "NRRD"],
    );
    let one = d.join("one");
    write_series(&one, &v, &base);
    let file: PathBuf = std::fs::read_dir(&one)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    assert_bad_input(
        &coapt(&["check", "--ct", &s(&file)]),
        &file,
        &["single-frame DICOM image", "folder"],
    );
}

/// A single multi-frame file (Enhanced CT, Legacy Converted Enhanced CT),
/// plain and JPEG lossless, reads back as the volume; `info` describes it;
/// a multi-frame file without functional groups is refused, since nothing
/// says where its frames lie.
#[test]
fn multiframe_files_read_back_and_one_without_functional_groups_is_refused() {
    let d = tmpdir("dicom-multiframe");
    let v = oblique();
    for (name, sop_class, codec) in [
        ("enhanced", uids::ENHANCED_CT_IMAGE_STORAGE, Codec::Plain),
        (
            "legacy",
            uids::LEGACY_CONVERTED_ENHANCED_CT_IMAGE_STORAGE,
            Codec::Plain,
        ),
        (
            "enhanced-jpeg",
            uids::ENHANCED_CT_IMAGE_STORAGE,
            Codec::JpegLossless,
        ),
        ("enhanced-rle", uids::ENHANCED_CT_IMAGE_STORAGE, Codec::Rle),
    ] {
        let file = d.join(format!("{name}.dcm"));
        let mut spec = Spec::new("1.2.3.5.1", 7);
        spec.codec = codec;
        write_multiframe(&file, &v, &spec, sop_class);
        let got = coapt::io::volume_file::read_ct(&file).unwrap();
        assert_same(&got, &v, name);
        let out = d.join(format!("{name}.nii.gz"));
        let o = coapt(&["convert", &s(&file), &s(&out)]);
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
        assert_same(&nifti::read_i16(&out).unwrap(), &v, name);
    }
    let o = coapt(&["info", "--json", &s(&d.join("legacy.dcm"))]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let i: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(i["format"], "DICOM file");
    assert_eq!(i["series"][0]["images"], 7);
    assert_eq!(i["volume"]["dims"], serde_json::json!([9, 8, 7]));
    // Frames without functional groups: Image Position (Patient) is the
    // first frame's only.
    let [ni, nj, nk] = v.dims();
    let spec = Spec::new("1.2.3.5.2", 8);
    let (orientation, spacing) = plane(&v);
    let mut e = common(&v, &spec, uids::CT_IMAGE_STORAGE, "1.2.3.5.2.1");
    e.extend([
        DataElement::new(
            tags::NUMBER_OF_FRAMES,
            VR::IS,
            PrimitiveValue::from(nk.to_string()),
        ),
        DataElement::new(
            tags::IMAGE_POSITION_PATIENT,
            VR::DS,
            dicom_value!(Strs, ["0".to_string(), "0".to_string(), "0".to_string()]),
        ),
        DataElement::new(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, orientation),
        DataElement::new(tags::PIXEL_SPACING, VR::DS, spacing),
        pixel_data(&[&vec![0u16; ni * nj * nk]], ni, nj, Codec::Plain),
    ]);
    let file = d.join("old-style.dcm");
    save(item(e), &spec, uids::CT_IMAGE_STORAGE, "1.2.3.5.2.1", &file);
    assert_bad_input(
        &coapt(&["check", "--ct", &s(&file)]),
        &file,
        &["7 frames", "no Per-frame Functional Groups", "dcm2niix"],
    );
}

/// [`oblique`] with int16's extremes side by side in slice 1 (whose Rescale
/// Intercept is 0, so any int16 is a stored value).
fn oblique_with_extremes() -> Volume<i16> {
    let mut vals = oblique().as_slice().to_vec();
    let at = 9 * 8;
    vals[at..at + 6].copy_from_slice(&[0, i16::MIN, i16::MAX, i16::MIN, -1, 1]);
    Volume::from_fortran_vec([9, 8, 7], *oblique().affine(), vals).unwrap()
}

/// JPEG as another encoder writes it: dcmtk's dcmcjpeg compressed the
/// uncompressed series of [`oblique_with_extremes`] (see
/// tests/data/dicom/make_fixtures.sh). Its lossless SV1 and Process 14
/// predictor-6 series read back bit-identical; its baseline series — which
/// dcmcjpeg made by rescaling to 8 bits, about 16 HU per grey level, before
/// the lossy DCT — is refused.
#[test]
fn dcmtk_jpeg_lossless_series_read_bit_identical_and_its_baseline_is_refused() {
    let data = repo().join("tests/data/dicom");
    let v = oblique_with_extremes();
    for (kind, ts) in [
        ("dcmtk_sv1", uids::JPEG_LOSSLESS_SV1),
        ("dcmtk_p14_sv6", "1.2.840.10008.1.2.4.57"),
    ] {
        let dir = data.join(kind);
        for e in std::fs::read_dir(&dir).unwrap() {
            let obj = dicom_object::open_file(e.unwrap().path()).unwrap();
            assert_eq!(obj.meta().transfer_syntax().trim_end_matches('\0'), ts);
        }
        let got = coapt::io::volume_file::read_ct(&dir).unwrap();
        assert_same(&got, &v, kind);
    }
    let dir = data.join("dcmtk_baseline");
    let first = std::fs::read_dir(&dir)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let obj = dicom_object::open_file(first).unwrap();
    assert_eq!(
        obj.element(tags::BITS_STORED)
            .unwrap()
            .to_int::<u16>()
            .unwrap(),
        8
    );
    assert_bad_input(
        &coapt(&["check", "--ct", &s(&dir)]),
        &dir,
        &[
            "JPEG baseline",
            "1.2.840.10008.1.2.4.50",
            "8-bit",
            "12 bits",
        ],
    );
}

/// JPEG lossless (Process 14, SV1) decodes exactly: a series with values
/// over the whole int16 range (−32768 next to 0 is the difference category
/// 16 that has no extra bits) and the sample CT read back bit-identical to
/// the uncompressed series.
#[test]
fn jpeg_lossless_series_read_back_bit_identical_to_uncompressed() {
    let d = tmpdir("dicom-jpeg-lossless");
    let v = oblique_with_extremes();
    let sample = nifti::read_i16(&repo().join("sample_data").join("ct.nii.gz")).unwrap();
    for (name, vol) in [("oblique", &v), ("sample", &sample)] {
        let plain = d.join(format!("{name}-plain"));
        write_series(&plain, vol, &Spec::new("1.2.3.6.1", 1));
        let jpeg = d.join(format!("{name}-jpeg"));
        let mut spec = Spec::new("1.2.3.6.2", 2);
        spec.codec = Codec::JpegLossless;
        write_series(&jpeg, vol, &spec);
        // The images really are JPEG: encapsulated, and smaller.
        let size = |dir: &Path| -> u64 {
            std::fs::read_dir(dir)
                .unwrap()
                .map(|e| e.unwrap().metadata().unwrap().len())
                .sum()
        };
        let first = std::fs::read_dir(&jpeg)
            .unwrap()
            .next()
            .unwrap()
            .unwrap()
            .path();
        let obj = dicom_object::open_file(&first).unwrap();
        assert_eq!(
            obj.meta().transfer_syntax().trim_end_matches('\0'),
            uids::JPEG_LOSSLESS_SV1
        );
        if name == "sample" {
            assert!(size(&jpeg) < size(&plain), "{name}: JPEG not smaller");
        }
        let a = coapt::io::volume_file::read_ct(&plain).unwrap();
        let b = coapt::io::volume_file::read_ct(&jpeg).unwrap();
        assert_same(&b, &a, name);
        assert_same(&b, vol, name);
    }
}

/// JPEG baseline is refused: 8-bit samples cannot hold HU (decided and
/// documented in docs/artifacts.md); JPEG-LS and JPEG 2000 are not decoded. Each
/// message names the transfer syntax. The pixel data here are no real
/// codestreams: the refusal comes from the syntax alone, before decoding.
#[test]
fn jpeg_baseline_jpeg_ls_and_jpeg_2000_are_refused_naming_the_syntax() {
    let d = tmpdir("dicom-jpeg-refused");
    let v = oblique();
    for (ts, words) in [
        (
            "1.2.840.10008.1.2.4.50",
            &[
                "JPEG baseline",
                "1.2.840.10008.1.2.4.50",
                "8-bit",
                "12 bits",
            ][..],
        ),
        (
            "1.2.840.10008.1.2.4.80",
            &["JPEG-LS", "1.2.840.10008.1.2.4.80", "not decoded"][..],
        ),
        (
            "1.2.840.10008.1.2.4.91",
            &["JPEG 2000", "1.2.840.10008.1.2.4.91", "not decoded"][..],
        ),
    ] {
        let dir = d.join(ts);
        let mut spec = Spec::new("1.2.3.7", 1);
        spec.codec = Codec::Refused(ts);
        write_series(&dir, &v, &spec);
        assert_bad_input(&coapt(&["check", "--ct", &s(&dir)]), &dir, words);
        let out = d.join("out.nii.gz");
        assert_bad_input(&coapt(&["convert", &s(&dir), &s(&out)]), &dir, words);
        assert!(!out.exists());
    }
}

/// dicom-rs reserves a value's declared length before reading it: a 16 kB
/// image claiming 4 GiB of pixel data cost 4.2 GB of memory. coapt walks the
/// element lengths first and refuses the file; random damage to an image
/// ends in a volume or an exit-2 refusal, never a panic.
#[test]
fn hostile_lengths_and_random_damage_are_refused_without_a_panic() {
    let v = oblique();
    let d = tmpdir("dicom-hostile");
    let dir = d.join("series");
    write_series(&dir, &v, &Spec::new("1.2.3.77", 1));
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    let victim = files[3].clone();
    let good = std::fs::read(&victim).unwrap();
    let at = good
        .windows(6)
        .position(|w| w == [0xE0, 0x7F, 0x10, 0x00, b'O', b'W'])
        .unwrap();
    let mut b = good.clone();
    b[at + 8..at + 12].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
    std::fs::write(&victim, &b).unwrap();
    for args in [vec!["check", "--ct"], vec!["info"]] {
        let mut a = args.clone();
        let ds = s(&dir);
        a.push(&ds);
        assert_bad_input(&coapt(&a), &victim, &["claims 4294967280 bytes", "corrupt"]);
    }
    let mut rng = coapt::rng::SplitMix64::new(2024);
    let (mut ok, mut refused) = (0, 0);
    for _ in 0..150 {
        let mut b = good.clone();
        for _ in 0..1 + rng.next_u64() % 3 {
            let i = (rng.next_u64() % b.len() as u64) as usize;
            match rng.next_u64() % 3 {
                0 => b[i] = rng.next_u64() as u8,
                1 => b.truncate(i.max(1)),
                _ => {
                    b.remove(i);
                }
            }
        }
        std::fs::write(&victim, &b).unwrap();
        let o = coapt(&["info", &s(&dir)]);
        match o.status.code() {
            Some(0) => ok += 1,
            Some(2) => refused += 1,
            c => panic!("exit {c:?}: {}", stderr(&o)),
        }
    }
    assert!(refused > 50, "{refused} refused, {ok} read");
}

/// Damaged compressed pixel data end in a volume or an exit-2 refusal that
/// writes nothing, never a panic: dicom-rs's own RLE and JPEG adapters
/// indexed past their buffers on such data (16 of 300 RLE and 10 of 400
/// JPEG damages panicked `convert`), so coapt decodes both itself.
#[test]
fn damaged_rle_and_jpeg_pixel_data_are_refused_without_a_panic() {
    let v = oblique();
    let d = tmpdir("dicom-damaged-codecs");
    let mut rng = coapt::rng::SplitMix64::new(24);
    for (name, codec, multiframe) in [
        ("rle", Codec::Rle, false),
        ("jpeg", Codec::JpegLossless, false),
        ("rle-mf", Codec::Rle, true),
        ("jpeg-mf", Codec::JpegLossless, true),
    ] {
        let dir = d.join(name);
        let mut spec = Spec::new("1.2.3.78", 1);
        spec.codec = codec;
        if multiframe {
            write_multiframe(
                &dir.join("mf.dcm"),
                &v,
                &spec,
                uids::ENHANCED_CT_IMAGE_STORAGE,
            );
        } else {
            write_series(&dir, &v, &spec);
        }
        let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        files.sort();
        let victim = files[files.len() / 2].clone();
        let good = std::fs::read(&victim).unwrap();
        let pixels = good
            .windows(4)
            .rposition(|w| w == [0xE0, 0x7F, 0x10, 0x00])
            .unwrap();
        let out = d.join("out.nii");
        let (mut ok, mut refused) = (0, 0);
        for _ in 0..100 {
            let mut b = good.clone();
            for _ in 0..1 + rng.next_u64() % 4 {
                let span = (b.len() - pixels - 12) as u64;
                let i = pixels + 12 + (rng.next_u64() % span) as usize;
                match rng.next_u64() % 4 {
                    0 | 1 => b[i] = rng.next_u64() as u8,
                    2 => {
                        b.remove(i);
                    }
                    _ => b.insert(i, rng.next_u64() as u8),
                }
            }
            std::fs::write(&victim, &b).unwrap();
            let _ = std::fs::remove_file(&out);
            let o = coapt(&["convert", &s(&dir), &s(&out)]);
            match o.status.code() {
                Some(0) => ok += 1,
                Some(2) => {
                    refused += 1;
                    assert!(!out.exists(), "{name}: exit 2 left {out:?}");
                }
                c => panic!("{name}: exit {c:?}: {}", stderr(&o)),
            }
        }
        assert!(refused > 30, "{name}: {refused} refused, {ok} read");
    }
}

/// The manifest's record of the `ct` input of segment.
fn ct_record(run: &Path) -> serde_json::Value {
    let m = json(&run.join("manifest.json"));
    m["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["stage"] == "segment")
        .unwrap()["inputs"]["ct"]
        .clone()
}

fn run_config(d: &Path, ct: &Path, extra_run: &str) -> PathBuf {
    let lm = repo().join("sample_data/landmarks.mrk.json");
    let cfg = d.join("run.toml");
    std::fs::write(
        &cfg,
        format!(
            "[run]\ndir = \"{}\"\n{extra_run}\n[inputs]\nct = \"{}\"\nlandmarks = \"{}\"\n",
            s(&d.join("run")),
            s(ct),
            s(&lm)
        ),
    )
    .unwrap();
    cfg
}

/// A study folder with the CTA and a localiser: `run` reads the CTA, says
/// so on stderr and in the manifest, which names the series (UID, number,
/// description) beside the hash of its files.
#[test]
fn run_reads_the_only_plausible_cta_of_a_study_and_records_its_uid() {
    let d = tmpdir("dicom-run-pick");
    let v = nifti::read_i16(&repo().join("sample_data/ct.nii.gz")).unwrap();
    let study = d.join("study");
    write_series(&study.join("cta"), &v, &Spec::new("1.2.3.8.1", 4));
    let mut scout = Spec::new("1.2.3.8.2", 1);
    scout.image_type = "ORIGINAL\\PRIMARY\\LOCALIZER";
    scout.description = "Topogram";
    write_series(&study.join("scout"), &oblique(), &scout);
    let cfg = run_config(&d, &study, "");
    let o = coapt(&["run", &s(&cfg), "--until", "segment"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("only plausible CTA")
            && err.contains("1.2.3.8.1")
            && err.contains("localiser"),
        "{err}"
    );
    let ct = ct_record(&d.join("run"));
    let series = &ct["dicom_series"];
    assert_eq!(series["series_instance_uid"], "1.2.3.8.1", "{ct}");
    assert_eq!(series["series_number"], 4);
    assert_eq!(series["series_description"], "CTA 1.0 test");
    assert_eq!(series["slices"], 112);
    assert_eq!(series["files"], 112);
    assert!(
        series["chosen"].as_str().unwrap().contains("1.2.3.8.2"),
        "{ct}"
    );
    // `info` on the study folder says which it reads, and why.
    let o = coapt(&["info", "--json", &s(&study)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let i: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(i["series"].as_array().unwrap().len(), 2);
    assert_eq!(i["chosen"]["uid"], "1.2.3.8.1");
    assert!(
        i["chosen"]["how"].as_str().unwrap().contains("localiser"),
        "{i}"
    );
    assert_eq!(i["volume"]["dims"], serde_json::json!([112, 112, 112]));
    // The hash covers the CTA's files only, not the localiser's.
    let cta_bytes: u64 = std::fs::read_dir(study.join("cta"))
        .unwrap()
        .map(|e| e.unwrap().metadata().unwrap().len())
        .sum();
    assert_eq!(ct["bytes"].as_u64().unwrap(), cta_bytes);
    // The mask is the NIfTI's.
    let reference = d.join("reference.nii.gz");
    let lm = repo().join("sample_data/landmarks.mrk.json");
    let o = coapt(&[
        "segment",
        "--ct",
        &s(&repo().join("sample_data/ct.nii.gz")),
        "--landmarks",
        &s(&lm),
        "--out",
        &s(&reference),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        std::fs::read(&reference).unwrap() == std::fs::read(d.join("run/mask.nii.gz")).unwrap()
    );
}

/// Two plausible CTA series (two phases): `run` refuses with exit 2, lists
/// both (UID, number, description, slices, spacing) and says how to choose;
/// `series =` under [run] (or `--series`) chooses; the two disagreeing is
/// refused.
#[test]
fn run_refuses_to_guess_between_two_ctas_and_series_in_the_config_chooses() {
    let d = tmpdir("dicom-run-two");
    let v = nifti::read_i16(&repo().join("sample_data/ct.nii.gz")).unwrap();
    let study = d.join("study");
    let mut art = Spec::new("1.2.3.9.1", 3);
    art.description = "CTA arterial";
    write_series(&study, &v, &art);
    let mut late = Spec::new("1.2.3.9.2", 6);
    late.description = "CTA delayed";
    write_series(&study, &v, &late);
    let cfg = run_config(&d, &study, "");
    let o = coapt(&["run", &s(&cfg), "--until", "segment", "--quiet"]);
    assert_bad_input(
        &o,
        &study,
        &[
            "2 series that could each be the CT angiogram",
            "1.2.3.9.1",
            "1.2.3.9.2",
            "CTA arterial",
            "CTA delayed",
            "112 slices",
            "1.000 mm",
            "--series",
            "series = ",
        ],
    );
    assert!(!d.join("run").join("mask.nii.gz").exists());
    // Chosen in the config…
    let cfg = run_config(&d, &study, "series = \"6\"\n");
    let o = coapt(&["run", &s(&cfg), "--until", "segment", "--quiet"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let ct = ct_record(&d.join("run"));
    assert_eq!(
        ct["dicom_series"]["series_instance_uid"], "1.2.3.9.2",
        "{ct}"
    );
    assert_eq!(ct["dicom_series"]["chosen"], "chosen with series 6");
    // …or on the command line; both, disagreeing, is an error.
    let o = coapt(&[
        "--series",
        "3",
        "run",
        &s(&cfg),
        "--until",
        "segment",
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("run.series") && stderr(&o).contains("--series chose 3"));
}

/// `convert` leaves OUT.provenance.json beside its output: the input's
/// format, the DICOM series read, each file's blake3 and the output's;
/// the same conversion again writes the same bytes.
#[test]
fn convert_writes_a_provenance_record_beside_its_output() {
    let d = tmpdir("dicom-convert-provenance");
    let v = oblique();
    let dir = d.join("series");
    let mut spec = Spec::new("1.2.3.10.1", 9);
    spec.description = "CTA 0.6";
    write_series(&dir, &v, &spec);
    let out = d.join("ct.nii.gz");
    let o = coapt(&["convert", &s(&dir), &s(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let side = d.join("ct.nii.gz.provenance.json");
    let first = std::fs::read(&side).unwrap();
    let p = json(&side);
    assert_eq!(p["format"], "coapt-provenance/1");
    assert_eq!(p["command"], "convert");
    assert_eq!(p["input"]["format"], "DICOM");
    assert_eq!(
        p["input"]["dicom_series"]["series_instance_uid"],
        "1.2.3.10.1"
    );
    assert_eq!(p["input"]["dicom_series"]["series_number"], 9);
    assert_eq!(p["input"]["dicom_series"]["series_description"], "CTA 0.6");
    let files = p["input"]["files"].as_array().unwrap();
    assert_eq!(files.len(), 7);
    let mut names: Vec<String> = entries(&dir);
    names.sort();
    for (f, name) in files.iter().zip(&names) {
        // Inside the output's folder: recorded relative to it.
        assert_eq!(f["path"], format!("series/{name}"));
        let bytes = std::fs::read(dir.join(name)).unwrap();
        assert_eq!(f["bytes"].as_u64().unwrap(), bytes.len() as u64);
        assert_eq!(f["blake3"], blake3::hash(&bytes).to_hex().to_string());
    }
    let nii = std::fs::read(&out).unwrap();
    assert_eq!(p["output"]["path"], "ct.nii.gz");
    assert_eq!(
        p["output"]["blake3"],
        blake3::hash(&nii).to_hex().to_string()
    );
    // No time stamp: the record is a function of the files.
    let mut keys: Vec<&String> = p.as_object().unwrap().keys().collect();
    keys.sort();
    assert_eq!(
        keys,
        [
            "coapt_version",
            "command",
            "format",
            "git_commit",
            "input",
            "output"
        ]
    );
    let o = coapt(&["convert", &s(&dir), &s(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(std::fs::read(&side).unwrap() == first, "not reproducible");
    // A NRRD input: its format, no series.
    let o = coapt(&["convert", &s(&out), &s(&d.join("ct.nrrd"))]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let p = json(&d.join("ct.nrrd.provenance.json"));
    assert_eq!(p["input"]["format"], "NIfTI-1");
    assert!(p["input"]["dicom_series"].is_null());
    assert_eq!(
        p["input"]["files"][0]["blake3"],
        blake3::hash(&nii).to_hex().to_string()
    );
}
