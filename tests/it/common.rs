use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use coapt::geom::Volume;
use coapt::io::scratch::Scratch;

/// A fresh, empty directory for one test, removed when the test passes
/// and kept when it fails (its files are the evidence).
pub fn tmpdir(tag: &str) -> Scratch {
    Scratch::at(std::env::temp_dir().join(format!("coapt-it-{tag}-{}", std::process::id())))
}

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Run the coapt binary.
pub fn coapt(args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_coapt"))
        .args(args)
        .output()
        .expect("coapt starts");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "coapt panicked: {stderr}");
    out
}

/// A path as a command-line argument.
pub fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

/// A JSON file, or a panic naming it.
pub fn json(p: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display())))
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Assert exit code 2 with a one-line `error:` naming `file` and containing `words`.
pub fn assert_bad_input(o: &Output, file: &Path, words: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "expected exit 2, stderr: {err}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "expected one line, got: {err}");
    assert!(lines[0].starts_with("error: "), "{err}");
    let name = file.file_name().unwrap().to_string_lossy();
    assert!(
        lines[0].contains(name.as_ref()),
        "error does not name {name}: {err}"
    );
    for w in words {
        assert!(
            lines[0].to_lowercase().contains(&w.to_lowercase()),
            "error lacks '{w}': {err}"
        );
    }
}

/// Names of the entries of a directory, sorted.
pub fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// `coapt phantom --preset sample <extra> --out dir --quiet`, which must succeed.
pub fn sample_phantom(dir: &Path, extra: &[&str]) {
    let mut args = vec!["phantom", "--preset", "sample"];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--out", dir.to_str().unwrap(), "--quiet"]);
    let o = coapt(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// Mean CT value over the truth mask of a phantom directory (the grids must match).
pub fn mean_hu_in_truth_mask(dir: &Path) -> f64 {
    let ct = coapt::io::nifti::read_i16(&dir.join("ct.nii.gz")).unwrap();
    let mask = coapt::io::nifti::read_u8(&dir.join("truth_mask.nii.gz")).unwrap();
    assert!(ct.same_grid(&mask, 1e-4));
    let (mut sum, mut n) = (0.0, 0usize);
    for (c, m) in ct.as_slice().iter().zip(mask.as_slice()) {
        if *m == 1 {
            sum += *c as f64;
            n += 1;
        }
    }
    sum / n as f64
}

/// `coapt valve` then `coapt leaflets` on the committed sample's truth
/// surface, writing valve.json, paths.vtp and leaflets.vtp into `d`;
/// returns the surface used.
pub fn sample_valve_and_leaflets(d: &Path, template: &str, extra: &[&str]) -> PathBuf {
    let data = repo().join("sample_data");
    let surface = data.join("truth_surface.vtp");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let o = coapt(&[
        "valve",
        "--surface",
        &s(&surface),
        "--landmarks",
        &s(&data.join("landmarks.mrk.json")),
        "--out",
        &s(&d.join("valve.json")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut args = vec![
        "leaflets".to_string(),
        "--valve".into(),
        s(&d.join("valve.json")),
        "--paths".into(),
        s(&d.join("paths.vtp")),
        "--surface".into(),
        s(&surface),
        "--template".into(),
        s(&repo().join(template)),
        "--out".into(),
        s(&d.join("leaflets.vtp")),
    ];
    args.extend(extra.iter().map(|a| a.to_string()));
    let o = coapt(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    surface
}

/// Dice of a mask on a cropped grid against the truth on the CT grid.
pub fn dice(mask: &Volume<u8>, truth: &Volume<u8>) -> f64 {
    let o = truth
        .world_to_index(&mask.index_to_world([0.0; 3]))
        .map(|x| x.round() as usize);
    let [mi, mj, mk] = mask.dims();
    let (mut inter, mut m_n) = (0usize, 0usize);
    for k in 0..mk {
        for j in 0..mj {
            for i in 0..mi {
                if mask.as_slice()[mask.linear_index(i, j, k)] != 0 {
                    m_n += 1;
                    if truth.as_slice()[truth.linear_index(i + o[0], j + o[1], k + o[2])] != 0 {
                        inter += 1;
                    }
                }
            }
        }
    }
    let t_n = truth.as_slice().iter().filter(|&&v| v != 0).count();
    2.0 * inter as f64 / (m_n + t_n) as f64
}

/// Run the whole chain (`coapt run`) into `dir/run` with the committed
/// template and closure config, `inputs` added to `[inputs]` and `extra`
/// appended (e.g. a `[phantom]` section); the run directory.
pub fn run_default_chain(dir: &Path, inputs: &[(&str, &Path)], extra: &str) -> PathBuf {
    let template = repo().join("pipelines/templates/ozaki_default.toml");
    run_chain(dir, inputs, &template, extra)
}

/// `coapt run` of the whole chain with `template` and the default mechanics
/// (`pipelines/close.toml`); `extra` is appended to the configuration.
pub fn run_chain(dir: &Path, inputs: &[(&str, &Path)], template: &Path, extra: &str) -> PathBuf {
    let close = repo().join("pipelines/close.toml");
    run_chain_with(dir, inputs, template, &close, extra)
}

/// [`run_chain`] with the mechanics of `close`.
pub fn run_chain_with(
    dir: &Path,
    inputs: &[(&str, &Path)],
    template: &Path,
    close: &Path,
    extra: &str,
) -> PathBuf {
    let cfg = chain_config(dir, inputs, template, close, extra);
    let o = coapt(&["run", &s(&cfg), "--quiet"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    dir.join("run")
}

/// `dir/chain.toml`: a run config of `inputs`, `template` and the mechanics
/// of `close` into `dir/run`, `extra` appended.
pub fn chain_config(
    dir: &Path,
    inputs: &[(&str, &Path)],
    template: &Path,
    close: &Path,
    extra: &str,
) -> PathBuf {
    let mut text = format!(
        "[run]\ndir = \"{}\"\n\n[inputs]\n",
        dir.join("run").display()
    );
    for (k, v) in inputs {
        text += &format!("{k} = \"{}\"\n", v.display());
    }
    text += &format!(
        "template = \"{}\"\nconfig = \"{}\"\n{extra}",
        template.display(),
        close.display()
    );
    let cfg = dir.join("chain.toml");
    std::fs::write(&cfg, text).unwrap();
    cfg
}

/// A run's verdict (`run/report.json`) is its criteria's conjunction when
/// the closure is assessable and never green otherwise; a valve that does
/// not close is never green; leaflets crossing each other (closure.json)
/// make it not assessable, naming their count; and the solver converged.
pub fn assert_honest_verdict(run: &Path) {
    let report = json(&run.join("report.json"));
    let log = json(&run.join("closure.json"));
    let v = &report["verdict"];
    let all = v["meets_all_criteria"].as_bool().unwrap();
    let reasons = v["not_assessable_reasons"].as_array().unwrap();
    let assessable = v["assessable"].as_bool().unwrap();
    assert_eq!(assessable, reasons.is_empty(), "{v}");
    let criteria = report["criteria"].as_array().unwrap();
    assert_eq!(
        all,
        assessable && criteria.iter().all(|c| c["pass"].as_bool() == Some(true)),
        "{report}"
    );
    assert_eq!(v["status"] == "meets_all_criteria", all, "{v}");
    if report["metrics"]["closed"].as_bool() == Some(false) {
        assert!(!all, "an open valve meets all criteria: {v}");
    }
    let crossing = log["intersecting_triangle_pairs"].as_u64().unwrap();
    if crossing > 0 {
        assert_eq!(
            v["status"], "not_assessable",
            "{crossing} crossing pairs: {v}"
        );
        let words = format!("{crossing} pairs of triangles of different leaflets cross");
        assert!(
            reasons.iter().any(|r| r.as_str().unwrap().contains(&words)),
            "{v}"
        );
    }
    assert!(
        report["solver"]["converged"].as_bool().unwrap(),
        "{}",
        report["solver"]
    );
}

/// (stage, status) of every stage the run's manifest records, in order.
pub fn stage_statuses(run: &Path) -> Vec<(String, String)> {
    json(&run.join("manifest.json"))["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            let f = |k: &str| r[k].as_str().unwrap().to_string();
            (f("stage"), f("status"))
        })
        .collect()
}

/// The stages a run directory's manifest records, in order.
pub fn manifest_stages(run: &Path) -> (serde_json::Value, Vec<String>) {
    let manifest = json(&run.join("manifest.json"));
    let stages = manifest["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["stage"].as_str().unwrap().to_string())
        .collect();
    (manifest, stages)
}

/// The points `labels` of the landmarks file `from`, written to `to`: a
/// user who placed only some of them (say the commissures).
pub fn some_points(from: &Path, to: &Path, labels: &[&str]) {
    use coapt::io::markups;
    let all = markups::read(from).unwrap();
    let mut c = coapt::geom::Landmarks::new(coapt::geom::Frame::Lps);
    for l in labels {
        c.push(*l, all.get(l).unwrap());
    }
    markups::write_mrk_json(to, &c, coapt::geom::Frame::Lps).unwrap();
}
