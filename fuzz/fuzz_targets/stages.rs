//! The stages on a small case with one input replaced by the fuzzer's
//! bytes: a CT's or mask's header in front of the case's own voxels (so a
//! mutated spacing, affine, size or type reaches the algorithms), or a whole
//! landmarks file, valve.json, template, close.toml or mesh. A stage may
//! refuse; it may not panic, hang or allocate without a bound.
#![no_main]
use std::path::Path;

use libfuzzer_sys::fuzz_target;

#[path = "scratch.rs"]
mod scratch;
#[path = "small_case.rs"]
mod small_case;

use small_case::{case, stage};

/// A NIfTI-1 file: the fuzzer's header (352 bytes: 348 and the extension
/// flag) in front of the case's voxels.
fn with_header(header: &[u8], image: &Path, name: &str) -> std::path::PathBuf {
    let full = std::fs::read(image).expect("case file");
    let mut bytes = header.to_vec();
    bytes.truncate(352);
    bytes.resize(352, 0);
    bytes.extend_from_slice(&full[352.min(full.len())..]);
    scratch::file(name, &bytes)
}

fuzz_target!(|data: &[u8]| {
    let Some((&pick, bytes)) = data.split_first() else {
        return;
    };
    let c = case();
    let f = |n: &str| c.join(n);
    let out = scratch::dir("out");
    let _ = match pick % 12 {
        0 => stage("segment", &[("ct", &with_header(bytes, &f("ct.nii"), "ct.nii"))], &[], &out),
        1 => stage(
            "segment",
            &[
                ("ct", &with_header(bytes, &f("ct.nii"), "ct.nii")),
                ("landmarks", &f("landmarks.mrk.json")),
            ],
            &[],
            &out,
        ),
        2 => stage("surface", &[("mask", &with_header(bytes, &f("mask.nii"), "mask.nii"))], &[], &out),
        3 => stage(
            "landmarks",
            &[
                ("mask", &with_header(bytes, &f("mask.nii"), "mask.nii")),
                ("surface", &f("aorta.vtp")),
            ],
            &[],
            &out,
        ),
        4 => stage(
            "valve",
            &[
                ("surface", &f("aorta.vtp")),
                ("landmarks", &scratch::file("landmarks.mrk.json", bytes)),
            ],
            &[("spacing", "1 mm")],
            &out,
        ),
        5 | 6 => {
            let (valve, template) = if pick % 12 == 5 {
                (scratch::file("valve.json", bytes), f("template.toml"))
            } else {
                (f("valve.json"), scratch::file("template.toml", bytes))
            };
            stage(
                "leaflets",
                &[
                    ("valve", &valve),
                    ("paths", &f("paths.vtp")),
                    ("surface", &f("aorta.vtp")),
                    ("template", &template),
                ],
                &[("h", "2 mm")],
                &out,
            )
        }
        7 | 8 => {
            let (leaflets, config) = if pick % 12 == 7 {
                // A config may ask for an hour; the harness keeps to seconds.
                let Ok(text) = std::str::from_utf8(bytes) else {
                    return;
                };
                match coapt::mech::config::parse(text) {
                    Ok(c) if c.time_limit <= 1.0 => {}
                    Ok(_) => return,
                    Err(_) => {}
                }
                (f("leaflets.vtp"), scratch::file("close.toml", bytes))
            } else {
                (scratch::file("leaflets.vtp", bytes), f("close.toml"))
            };
            stage(
                "close",
                &[
                    ("leaflets", &leaflets),
                    ("surface", &f("aorta.vtp")),
                    ("config", &config),
                    ("valve", &f("valve.json")),
                ],
                &[],
                &out,
            )
        }
        // The report on a mutated closed mesh, closure.json or leaflets.json.
        n => {
            let (closed, log, summary) = match n {
                9 => (scratch::file("closed.vtp", bytes), f("closure.json"), f("leaflets.json")),
                10 => (f("closed.vtp"), scratch::file("closure.json", bytes), f("leaflets.json")),
                _ => (f("closed.vtp"), f("closure.json"), scratch::file("leaflets.json", bytes)),
            };
            stage(
                "report",
                &[
                    ("closed", &closed),
                    ("leaflets", &f("leaflets.vtp")),
                    ("valve", &f("valve.json")),
                    ("log", &log),
                    ("summary", &summary),
                ],
                &[],
                &out,
            )
        }
    };
});
