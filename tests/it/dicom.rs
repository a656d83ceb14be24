//! The CT as a folder of a DICOM series (issue 24): written here from the
//! sample phantom and from small oblique volumes with dicom-rs (shuffled
//! file names, InstanceNumbers in reverse, a wrong SliceThickness, per-slice
//! rescale, uncompressed and RLE), read back identical to the NIfTI and
//! segmented to the same mask bytes; every malformed series refused.

use std::path::{Path, PathBuf};

use coapt::geom::Volume;
use coapt::io::nifti;
use dicom_core::value::PixelFragmentSequence;
use dicom_core::{DataElement, PrimitiveValue, VR, dicom_value};
use dicom_dictionary_std::{tags, uids};
use dicom_object::{FileMetaTableBuilder, InMemDicomObject};

use crate::common::*;

/// How to write a series; each field breaks or varies one thing.
#[derive(Clone)]
struct Spec {
    uid: String,
    number: i32,
    modality: &'static str,
    image_type: &'static str,
    rle: bool,
    /// Slices left out (a missing slice).
    skip: Option<usize>,
    /// In-plane shift per slice along the rows (gantry tilt), mm.
    shear_mm: f64,
    /// Extra offset of one slice along the normal (uneven steps), mm.
    jolt: Option<(usize, f64)>,
}

impl Spec {
    fn new(uid: &str, number: i32) -> Self {
        Spec {
            uid: uid.into(),
            number,
            modality: "CT",
            image_type: "ORIGINAL\\PRIMARY\\AXIAL",
            rle: false,
            skip: None,
            shear_mm: 0.0,
            jolt: None,
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

/// Write `v` as a series into `dir`: file names shuffled, InstanceNumber
/// counting down, slope 1 and an intercept that alternates per slice.
fn write_series(dir: &Path, v: &Volume<i16>, spec: &Spec) {
    std::fs::create_dir_all(dir).unwrap();
    let a = v.affine();
    let [ni, nj, nk] = v.dims();
    let col = |c: usize| nalgebra::Vector3::new(a[(0, c)], a[(1, c)], a[(2, c)]);
    let (ci, cj, ck) = (col(0), col(1), col(2));
    let (si, sj) = (ci.norm(), cj.norm());
    let (row, coldir) = (ci / si, cj / sj);
    let normal = row.cross(&coldir);
    for k in 0..nk {
        if spec.skip == Some(k) {
            continue;
        }
        let mut p = col(3) + ck * k as f64 + row * spec.shear_mm * k as f64;
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
        let sop = format!("{}.{}", spec.uid, k + 1);
        let pixel = if spec.rle {
            DataElement::new(
                tags::PIXEL_DATA,
                VR::OB,
                PixelFragmentSequence::new(Vec::<u32>::new(), vec![rle_frame(&stored)]),
            )
        } else {
            DataElement::new(
                tags::PIXEL_DATA,
                VR::OW,
                PrimitiveValue::U16(stored.into_iter().collect()),
            )
        };
        let o = [row.x, row.y, row.z, coldir.x, coldir.y, coldir.z].map(ds);
        let obj = InMemDicomObject::from_element_iter([
            DataElement::new(
                tags::SOP_CLASS_UID,
                VR::UI,
                PrimitiveValue::from(uids::CT_IMAGE_STORAGE),
            ),
            DataElement::new(
                tags::SOP_INSTANCE_UID,
                VR::UI,
                PrimitiveValue::from(sop.as_str()),
            ),
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
                PrimitiveValue::from("CTA 1.0 test"),
            ),
            DataElement::new(
                tags::IMAGE_TYPE,
                VR::CS,
                PrimitiveValue::from(spec.image_type),
            ),
            DataElement::new(
                tags::INSTANCE_NUMBER,
                VR::IS,
                PrimitiveValue::from((nk - k).to_string()),
            ),
            DataElement::new(tags::SLICE_THICKNESS, VR::DS, PrimitiveValue::from("5.0")),
            DataElement::new(
                tags::IMAGE_POSITION_PATIENT,
                VR::DS,
                dicom_value!(Strs, [ds(p.x), ds(p.y), ds(p.z)]),
            ),
            DataElement::new(
                tags::IMAGE_ORIENTATION_PATIENT,
                VR::DS,
                dicom_value!(
                    Strs,
                    [
                        o[0].clone(),
                        o[1].clone(),
                        o[2].clone(),
                        o[3].clone(),
                        o[4].clone(),
                        o[5].clone()
                    ]
                ),
            ),
            DataElement::new(
                tags::PIXEL_SPACING,
                VR::DS,
                dicom_value!(Strs, [ds(sj), ds(si)]),
            ),
            DataElement::new(tags::ROWS, VR::US, PrimitiveValue::from(nj as u16)),
            DataElement::new(tags::COLUMNS, VR::US, PrimitiveValue::from(ni as u16)),
            DataElement::new(tags::SAMPLES_PER_PIXEL, VR::US, PrimitiveValue::from(1u16)),
            DataElement::new(
                tags::PHOTOMETRIC_INTERPRETATION,
                VR::CS,
                PrimitiveValue::from("MONOCHROME2"),
            ),
            DataElement::new(tags::BITS_ALLOCATED, VR::US, PrimitiveValue::from(16u16)),
            DataElement::new(tags::BITS_STORED, VR::US, PrimitiveValue::from(16u16)),
            DataElement::new(tags::HIGH_BIT, VR::US, PrimitiveValue::from(15u16)),
            DataElement::new(
                tags::PIXEL_REPRESENTATION,
                VR::US,
                PrimitiveValue::from(1u16),
            ),
            DataElement::new(
                tags::RESCALE_INTERCEPT,
                VR::DS,
                PrimitiveValue::from(ds(intercept)),
            ),
            DataElement::new(tags::RESCALE_SLOPE, VR::DS, PrimitiveValue::from("1")),
            pixel,
        ]);
        let ts = if spec.rle {
            uids::RLE_LOSSLESS
        } else {
            uids::EXPLICIT_VR_LITTLE_ENDIAN
        };
        let file = obj
            .with_meta(
                FileMetaTableBuilder::new()
                    .transfer_syntax(ts)
                    .media_storage_sop_class_uid(uids::CT_IMAGE_STORAGE)
                    .media_storage_sop_instance_uid(sop.as_str()),
            )
            .unwrap();
        // Names in a shuffled order, unrelated to the position.
        let name = format!("IM{:05}", (k * 7919 + 13) % 10007);
        file.write_to_file(dir.join(format!("{}-{name}", spec.number)))
            .unwrap();
    }
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
    spec.rle = true;
    write_series(&rle, &v, &spec);
    std::fs::write(plain.join("README.txt"), "not an image\n").unwrap();
    for dir in [&plain, &rle] {
        let got = coapt::io::volume_file::read_ct(dir).unwrap();
        assert_same(&got, &v, &dir.display().to_string());
    }
    let masks: Vec<Vec<u8>> = [&nii, &plain]
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
    other.rle = true;
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
        &["single DICOM file", "folder"],
    );
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
