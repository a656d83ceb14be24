//! A small case (the sample phantom at 2 mm: every stage runs in well under
//! a second), made once per fuzzing process by coapt's own stages, and a way
//! to run one stage as `coapt <stage>` would.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use coapt::pipeline::execute::Invocation;
use coapt::pipeline::{Params, StageIo, params, runner};

/// Run one stage on these inputs with these parameters (as the user writes
/// them), every output under `out`.
pub fn stage(
    name: &str,
    inputs: &[(&str, &Path)],
    given: &[(&str, &str)],
    out: &Path,
) -> coapt::Result<()> {
    let spec = *coapt::stages::registry()
        .iter()
        .find(|s| s.name == name)
        .expect("a registered stage");
    let mut values = BTreeMap::new();
    for (k, text) in given {
        let p = spec.param(k).expect("a declared parameter");
        values.insert(k.to_string(), params::parse_text(p, text)?);
    }
    let params = Params::resolve(spec, values)?;
    let mut io = StageIo::default();
    for (n, p) in inputs {
        let port = spec.input(n).expect("a declared input");
        io.inputs.push((port.name, p.to_path_buf()));
    }
    for port in spec.outputs {
        io.outputs.push((port.name, out.join(port.file)));
    }
    let out_dir = spec.out_dir.map(|_| out);
    runner::run_single(spec, &io, &params, out_dir, &Invocation::default())
}

/// The case's files: phantom, segment, surface, valve, leaflets and close
/// outputs under their run-directory names, plus `ct.nii` and `mask.nii`
/// (uncompressed, so a header can be swapped in front of their voxels),
/// `template.toml` and `close.toml`.
pub fn case() -> &'static Path {
    static CASE: OnceLock<PathBuf> = OnceLock::new();
    CASE.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("coapt-fuzz-case-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("case dir");
        let f = |n: &str| d.join(n);
        std::fs::write(f("template.toml"), TEMPLATE).expect("template");
        // The case's own closure may take its time under the sanitizer; the
        // fuzzed ones get CLOSE's second.
        std::fs::write(f("close.toml"), CLOSE.replace("time_limit = \"1 s\"", "time_limit = \"300 s\"").replace("max_iterations = 20", "max_iterations = 100"))
            .expect("close.toml");
        let must = |r: coapt::Result<()>, what: &str| {
            if let Err(e) = r {
                panic!("the small case's {what} failed: {e}");
            }
        };
        must(
            stage("phantom", &[], &[("preset", "sample"), ("spacing", "2, 2, 2 mm")], &d),
            "phantom",
        );
        must(
            stage("segment", &[("ct", &f("ct.nii.gz")), ("landmarks", &f("landmarks.mrk.json"))], &[], &d),
            "segment",
        );
        must(stage("surface", &[("mask", &f("mask.nii.gz"))], &[], &d), "surface");
        must(
            stage(
                "valve",
                &[("surface", &f("aorta.vtp")), ("landmarks", &f("landmarks.mrk.json"))],
                &[("spacing", "1 mm")],
                &d,
            ),
            "valve",
        );
        must(
            stage(
                "leaflets",
                &[
                    ("valve", &f("valve.json")),
                    ("paths", &f("paths.vtp")),
                    ("surface", &f("aorta.vtp")),
                    ("template", &f("template.toml")),
                ],
                &[("h", "2 mm")],
                &d,
            ),
            "leaflets",
        );
        must(
            stage(
                "close",
                &[
                    ("leaflets", &f("leaflets.vtp")),
                    ("surface", &f("aorta.vtp")),
                    ("config", &f("close.toml")),
                    ("valve", &f("valve.json")),
                ],
                &[],
                &d,
            ),
            "close",
        );
        let ct = coapt::io::volume_file::read_ct(&f("ct.nii.gz")).expect("the case's CT");
        coapt::io::nifti::write(&f("ct.nii"), &ct).expect("uncompressed CT");
        let mask = coapt::io::nifti::read_u8(&f("mask.nii.gz")).expect("the case's mask");
        coapt::io::nifti::write(&f("mask.nii"), &mask).expect("uncompressed mask");
        std::fs::write(f("close.toml"), CLOSE).expect("close.toml");
        d
    })
}

const TEMPLATE: &str = "[leaflet1]\nkind = \"ozaki_size\"\nsize = 21\n\
[leaflet2]\nkind = \"ozaki_size\"\nsize = 21\n[leaflet3]\nkind = \"ozaki_size\"\nsize = 21\n";

pub const CLOSE: &str = "model = \"neo-hookean\"\nmu = \"900 kPa\"\nthickness = \"0.5 mm\"\n\
pressure = \"80 mmHg\"\nbending = true\ntolerance = \"1e-4 N\"\nmax_iterations = 20\ntime_limit = \"1 s\"\n";
