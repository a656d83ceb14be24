//! report.json's schema, and report.html in a real browser.
//!
//! The schema tests validate `schemas/report.example.json` against
//! `schemas/report.schema.json` and make sure corrupted copies fail. The
//! browser tests open the page `coapt::report::html::render` makes in
//! headless Chromium through `tools/browser_check.mjs` (playwright-core):
//! no console error, no request leaving file:/data:, every image decodes, a
//! screenshot that is not blank — and show the checker can fail.
//! Without node, playwright-core or chromium they print why and pass, unless
//! `COAPT_REQUIRE_BROWSER=1` (CI sets it), where that is a failure.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use coapt::io::png::{Rgb, encode};
use coapt::report::Figure;
use serde_json::{Value, json};

use crate::common::{repo, s, tmpdir};

fn load(rel: &str) -> Value {
    let p = repo().join(rel);
    let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn schema() -> Value {
    load("schemas/report.schema.json")
}

fn example() -> Value {
    load("schemas/report.example.json")
}

/// The validation errors of `instance`, as "path: message".
pub(crate) fn errors(instance: &Value) -> Vec<String> {
    let validator = jsonschema::draft202012::new(&schema()).expect("the schema compiles");
    validator
        .iter_errors(instance)
        .map(|e| format!("{}: {e}", e.instance_path()))
        .collect()
}

#[test]
fn schema_is_valid_draft_2020_12() {
    let s = schema();
    assert_eq!(s["$schema"], "https://json-schema.org/draft/2020-12/schema");
    if let Err(e) = jsonschema::meta::validate(&s) {
        panic!("the schema breaks its meta-schema: {e}");
    }
}

#[test]
fn schema_accepts_the_example() {
    let errs = errors(&example());
    assert!(errs.is_empty(), "{errs:#?}");
}

/// Assert `bad` is rejected with an error at `path`.
fn assert_rejected(bad: &Value, path: &str, what: &str) {
    let errs = errors(bad);
    assert!(
        errs.iter().any(|e| e.starts_with(&format!("{path}:"))),
        "{what}: expected an error at {path}, got {errs:#?}"
    );
}

#[test]
fn schema_rejects_a_missing_key() {
    let cases: [(&[&str], &str); 6] = [
        (&["metrics", "h_avr_mm"], "/metrics"),
        (
            &["metrics", "coaptation_area_mm2", "min"],
            "/metrics/coaptation_area_mm2",
        ),
        (&["solver"], ""),
        (&["verdict", "summary"], "/verdict"),
        (&["conventions", "slicerheart"], "/conventions"),
        (&["inputs", "ct", "blake3"], "/inputs/ct"),
    ];
    for (keys, at) in cases {
        let mut v = example();
        let (last, parents) = keys.split_last().unwrap();
        let mut obj = &mut v;
        for k in parents {
            obj = &mut obj[*k];
        }
        assert!(
            obj.as_object_mut().unwrap().remove(*last).is_some(),
            "{keys:?}"
        );
        assert_rejected(&v, at, &format!("without {keys:?}"));
    }
    // A leaflet without its index, a criterion without its result.
    let mut v = example();
    v["leaflets"][0].as_object_mut().unwrap().remove("index");
    assert_rejected(&v, "/leaflets/0", "leaflet without index");
    let mut v = example();
    v["criteria"][1].as_object_mut().unwrap().remove("pass");
    assert_rejected(&v, "/criteria/1", "criterion without pass");
}

#[test]
fn schema_rejects_a_wrong_type() {
    let cases: [(&str, Value); 10] = [
        ("/metrics/coaptation_height_mm", json!("5.43")),
        ("/metrics/closed", json!(null)),
        ("/metrics/ncca", json!(24.6)), // a percentage where a fraction belongs
        ("/metrics/free_edge_length_mm/1", json!("28.1")),
        ("/criteria/0/value", json!("4.6")),
        ("/criteria/3/threshold", json!(1)),
        ("/solver/iterations", json!(3.5)),
        ("/leaflets/2/index", json!(0)),
        ("/inputs/ct/blake3", json!("not-hex")),
        ("/timing_s/close", json!("4.86 s")),
    ];
    for (path, bad) in cases {
        let mut v = example();
        *v.pointer_mut(path).unwrap_or_else(|| panic!("{path}")) = bad.clone();
        // oneOf branches report at the criterion itself.
        let at = if path.starts_with("/criteria/") {
            path.rsplit_once('/').unwrap().0
        } else {
            path
        };
        assert_rejected(&v, at, &format!("{path} = {bad}"));
    }
}

#[test]
fn schema_rejects_an_unknown_or_renamed_key() {
    let mut v = example();
    v["metrics"]["coaptation_length_mm"] = json!(3.0);
    assert_rejected(&v, "/metrics", "unknown key in metrics");
    let mut v = example();
    let h = v["metrics"]
        .as_object_mut()
        .unwrap()
        .remove("effective_height_mm")
        .unwrap();
    v["metrics"]["effective_height"] = h;
    assert_rejected(&v, "/metrics", "effective_height_mm renamed");
    let mut v = example();
    v["surprise"] = json!({});
    assert_rejected(&v, "", "unknown top-level key");
    let mut v = example();
    v["criteria"][0]["id"] = json!("central_coaptation_height");
    assert_rejected(&v, "/criteria/0", "unknown criterion id");
    let mut v = example();
    v["schema"] = json!("coapt-report/1");
    assert_rejected(&v, "/schema", "other format version");
}

/// Every property the schema names has a description, and those of keys
/// with a unit suffix name the unit.
#[test]
fn schema_describes_every_property_with_its_unit() {
    fn walk(node: &Value, at: &str, bad: &mut Vec<String>, n: &mut usize) {
        match node {
            Value::Object(o) => {
                if let Some(Value::Object(props)) = o.get("properties") {
                    for (k, p) in props {
                        *n += 1;
                        let d = p.get("description").and_then(Value::as_str).unwrap_or("");
                        let unit = if k.ends_with("_mm2") {
                            Some("mm²")
                        } else if k.ends_with("_mm") {
                            Some("mm")
                        } else if k.ends_with("_s") {
                            Some(" s")
                        } else if k.ends_with("_n") {
                            Some("N")
                        } else {
                            None
                        };
                        if d.len() < 8 || unit.is_some_and(|u| !d.contains(u)) {
                            bad.push(format!("{at}/{k}: {d:?}"));
                        }
                    }
                }
                for (k, x) in o {
                    walk(x, &format!("{at}/{k}"), bad, n);
                }
            }
            Value::Array(a) => a
                .iter()
                .enumerate()
                .for_each(|(i, x)| walk(x, &format!("{at}/{i}"), bad, n)),
            _ => {}
        }
    }
    let (mut bad, mut n) = (Vec::new(), 0);
    walk(&schema(), "", &mut bad, &mut n);
    assert!(n > 80, "only {n} properties");
    assert!(bad.is_empty(), "{bad:#?}");
}

// ---------------------------------------------------------------- browser

pub(crate) struct Browser {
    node_modules: PathBuf,
    chromium: PathBuf,
}

/// What the browser check needs, or `None` (after saying why) when it is
/// missing and not required.
pub(crate) fn browser() -> Option<Browser> {
    let required = std::env::var("COAPT_REQUIRE_BROWSER").is_ok_and(|v| v == "1");
    let missing = |why: String| {
        if required {
            panic!("COAPT_REQUIRE_BROWSER=1 but {why}");
        }
        // Straight to the process's stderr, past libtest's capture, so a
        // skip is visible without --nocapture.
        let _ = writeln!(
            std::io::stderr(),
            "skipping the browser check: {why} (set COAPT_REQUIRE_BROWSER=1 to make this a failure)"
        );
        None
    };
    match Command::new("node").arg("--version").output() {
        Ok(o) if o.status.success() => {}
        _ => return missing("node is not on PATH".into()),
    }
    let mut candidates: Vec<PathBuf> = Vec::new();
    if let Some(d) = std::env::var_os("COAPT_NODE_MODULES") {
        candidates.push(d.into());
    }
    candidates.push(repo().join("tools/node_modules"));
    if let Some(h) = std::env::var_os("HOME") {
        candidates.push(Path::new(&h).join(".cache/coapt-node/node_modules"));
    }
    let Some(node_modules) = candidates
        .iter()
        .find(|d| d.join("playwright-core/package.json").is_file())
    else {
        return missing(format!(
            "playwright-core is in none of {candidates:?} (see .ci/run)"
        ));
    };
    let chromium: PathBuf =
        std::env::var_os("COAPT_CHROMIUM").map_or("/usr/bin/chromium".into(), PathBuf::from);
    if !chromium.is_file() {
        return missing(format!(
            "{} does not exist (apt-get install chromium)",
            chromium.display()
        ));
    }
    Some(Browser {
        node_modules: node_modules.clone(),
        chromium,
    })
}

/// Run tools/browser_check.mjs on `page`; its JSON verdict and exit code.
pub(crate) fn check(b: &Browser, page: &Path) -> (Value, i32) {
    let shot = page.with_extension("png");
    let out = Command::new("node")
        .arg(repo().join("tools/browser_check.mjs"))
        .arg(page)
        .arg("--screenshot")
        .arg(&shot)
        .env("COAPT_NODE_MODULES", &b.node_modules)
        .env("COAPT_CHROMIUM", &b.chromium)
        .output()
        .expect("node starts");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let line = stdout.lines().last().unwrap_or("");
    let v: Value = serde_json::from_str(line)
        .unwrap_or_else(|e| panic!("no JSON verdict ({e}); stdout: {stdout}; stderr: {stderr}"));
    let code = out.status.code().unwrap_or(-1);
    assert_ne!(code, 2, "the check could not run: {v}; stderr: {stderr}");
    (v, code)
}

pub(crate) fn strings(v: &Value) -> Vec<String> {
    v.as_array()
        .map(|a| {
            a.iter()
                .map(|x| x.as_str().unwrap_or("").to_string())
                .collect()
        })
        .unwrap_or_default()
}

/// Three small synthetic figures, as the report stage will hand them over.
fn figures() -> Vec<Figure> {
    let make = |id: &str, w: usize, h: usize, f: &dyn Fn(usize, usize) -> [u8; 3]| {
        let px = (0..w * h).map(|i| f(i % w, i / w)).collect();
        Figure {
            id: id.into(),
            title: format!("Synthetic {id}"),
            caption: "A test image: colours carry no meaning.".into(),
            width: w as u32,
            height: h as u32,
            png: encode(&Rgb { w, h, px }),
        }
    };
    vec![
        make("gradient", 320, 200, &|x, y| {
            [(x * 255 / 319) as u8, (y * 255 / 199) as u8, 90]
        }),
        make("checker", 160, 160, &|x, y| {
            if (x / 20 + y / 20) % 2 == 0 {
                [20, 40, 160]
            } else {
                [240, 200, 40]
            }
        }),
        make("disc", 240, 240, &|x, y| {
            let (dx, dy) = (x as f64 - 120.0, y as f64 - 120.0);
            if dx.hypot(dy) < 90.0 {
                [200, 30, 30]
            } else {
                [255, 255, 255]
            }
        }),
    ]
}

#[test]
fn report_page_opens_clean_in_headless_chromium() {
    let Some(b) = browser() else { return };
    let dir = tmpdir("report-html");
    let page = dir.join("report.html");
    std::fs::write(
        &page,
        coapt::report::html::render(
            &serde_json::from_value(example()).unwrap(),
            &figures(),
            None,
        ),
    )
    .unwrap();
    let (v, code) = check(&b, &page);
    eprintln!("page and screenshot in {}", dir.display());
    assert!(strings(&v["console_errors"]).is_empty(), "{v}");
    assert!(strings(&v["page_errors"]).is_empty(), "{v}");
    assert!(strings(&v["external_requests"]).is_empty(), "{v}");
    assert_eq!(v["images"]["total"], 3, "{v}");
    assert_eq!(v["images"]["decoded"], 3, "{v}");
    let shot = &v["screenshot"];
    assert_eq!(shot["blank"], false, "{v}");
    assert_eq!(shot["decoder_mismatches"], 0, "{v}");
    assert!(
        shot["height"].as_u64().unwrap() > 900,
        "full page, longer than the viewport: {v}"
    );
    assert!(v["text_chars"].as_u64().unwrap() > 1000, "{v}");
    assert_eq!(v["ok"], true, "{v}");
    assert_eq!(code, 0);
}

/// The checker can fail: a broken image, an external request and a console
/// error are each reported.
#[test]
fn browser_check_flags_a_broken_page() {
    let Some(b) = browser() else { return };
    let dir = tmpdir("report-html-bad");
    let page = dir.join("bad.html");
    let body: String = (0..40)
        .map(|i| format!("<p>Paragraph {i} of a page with enough text to not be blank.</p>\n"))
        .collect();
    std::fs::write(
        &page,
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>bad</title></head><body>\n\
             <h1>A page with three faults</h1>\n{body}\
             <img src=\"data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAAB\" alt=\"truncated\">\n\
             <img src=\"http://example.invalid/x.png\" alt=\"external\">\n\
             <script>console.error('deliberate console error');</script>\n</body></html>\n"
        ),
    )
    .unwrap();
    let (v, code) = check(&b, &page);
    assert_eq!(v["ok"], false, "{v}");
    assert_eq!(code, 1);
    assert!(
        strings(&v["console_errors"])
            .iter()
            .any(|e| e.contains("deliberate console error")),
        "{v}"
    );
    assert_eq!(
        strings(&v["external_requests"]),
        ["http://example.invalid/x.png"],
        "{v}"
    );
    let broken = strings(&v["images"]["broken"]);
    assert!(
        broken
            .iter()
            .any(|s| s.starts_with("data:image/png;base64,iVBOR")),
        "{v}"
    );
    assert_eq!(v["images"]["decoded"], 0, "{v}");
    assert_eq!(
        v["screenshot"]["blank"], false,
        "the faults, not blankness, fail it: {v}"
    );
}

/// The checker can fail: an empty white page is blank.
#[test]
fn browser_check_flags_a_blank_page() {
    let Some(b) = browser() else { return };
    let dir = tmpdir("report-html-blank");
    let page = dir.join("blank.html");
    std::fs::write(&page, "<!DOCTYPE html>\n<html lang=\"en\"><head><title>blank</title></head><body></body></html>\n").unwrap();
    let (v, code) = check(&b, &page);
    assert_eq!(v["ok"], false, "{v}");
    assert_eq!(code, 1);
    assert_eq!(v["screenshot"]["blank"], true, "{v}");
    assert_eq!(v["screenshot"]["distinct_colours"], 1, "{v}");
    assert_eq!(v["screenshot"]["decoder_mismatches"], 0, "{v}");
    assert!(strings(&v["console_errors"]).is_empty(), "{v}");
}

/// The interactive 3-D view of a real run's report (the sample's chain at a
/// coarse mesh) draws the valve, turns under a drag, zooms under the wheel,
/// comes back with Reset, is left out of print, and the page stays clean
/// (tools/view3d_check.mjs, WebGL on Chromium's CPU renderer). Without
/// WebGL the view says so in words.
#[test]
fn the_3d_view_draws_turns_zooms_and_resets_in_headless_chromium() {
    let Some(b) = browser() else { return };
    let dir = tmpdir("view3d");
    let data = repo().join("sample_data");
    let run = crate::common::run_chain(
        &dir,
        &[
            ("ct", &data.join("ct.nii.gz")),
            ("landmarks", &data.join("landmarks.mrk.json")),
        ],
        &repo().join("pipelines/templates/ozaki_default.toml"),
        "\n[leaflets]\nh = \"1.5 mm\"\n",
    );
    let page = run.join("report.html");
    let view = |extra: &[&str]| -> (Value, i32) {
        let out = Command::new("node")
            .arg(repo().join("tools/view3d_check.mjs"))
            .arg(&page)
            .args(extra)
            .env("COAPT_NODE_MODULES", &b.node_modules)
            .env("COAPT_CHROMIUM", &b.chromium)
            .output()
            .expect("node starts");
        let stdout = String::from_utf8_lossy(&out.stdout);
        let line = stdout.lines().last().unwrap_or("");
        let v: Value = serde_json::from_str(line).unwrap_or_else(|e| {
            panic!(
                "no JSON verdict ({e}); stdout: {stdout}; stderr: {}",
                String::from_utf8_lossy(&out.stderr)
            )
        });
        (v, out.status.code().unwrap_or(-1))
    };
    let (v, code) = view(&["--out", &s(&dir.join("shots"))]);
    assert_eq!(v["state"], "drawn", "{v}");
    for key in [
        "drawn_fraction",
        "drag_changed_fraction",
        "zoom_changed_fraction",
    ] {
        // The checker's own bounds (view3d_check.mjs): 2 % of the canvas.
        assert!(v[key].as_f64().unwrap() >= 0.02, "{key}: {v}");
    }
    assert!(
        v["reset_difference_fraction"].as_f64().unwrap() <= 0.001,
        "{v}"
    );
    assert_eq!(v["hidden_in_print"], true, "{v}");
    assert!(strings(&v["console_errors"]).is_empty(), "{v}");
    assert!(strings(&v["external_requests"]).is_empty(), "{v}");
    assert_eq!((v["ok"].as_bool(), code), (Some(true), 0), "{v}");
    let (v, code) = view(&["--no-webgl"]);
    assert_eq!(v["state"], "unavailable", "{v}");
    assert_eq!((v["ok"].as_bool(), code), (Some(true), 0), "{v}");
}
