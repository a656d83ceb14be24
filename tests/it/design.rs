//! `coapt design`: leaflet sizing on the committed sample. The recommended
//! size meets every criterion and every smaller size tried does not, or,
//! when no size's closure can be judged (leaflets crossing each other),
//! nothing is recommended and each size says why; the design report shows
//! the sweep; the answer holds under h → h/2 and does not depend on the
//! thread count; a second run redoes nothing.

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::common::*;
use crate::report_html::{browser, check, errors, strings};

/// The sample's run config (closure settings of pipelines/close.toml) with
/// a [design] section and the leaflet mesh size `h`.
fn config(dir: &Path, h: &str, sizes: &str) -> PathBuf {
    config_with(dir, h, sizes, "")
}

/// The same with more lines of the [leaflets] section.
pub fn config_with(dir: &Path, h: &str, sizes: &str, leaflets: &str) -> PathBuf {
    let r = repo();
    let cfg = dir.join("run.toml");
    std::fs::write(
        &cfg,
        format!(
            "[run]\ndir = \"run\"\n[inputs]\nct = \"{}\"\nlandmarks = \"{}\"\ntemplate = \"{}\"\nconfig = \"{}\"\n\
             [leaflets]\nh = \"{h}\"\n{leaflets}[design]\nsizes = {sizes}\n",
            s(&r.join("sample_data/ct.nii.gz")),
            s(&r.join("sample_data/landmarks.mrk.json")),
            s(&r.join("pipelines/templates/ozaki_default.toml")),
            s(&r.join("pipelines/close.toml")),
        ),
    )
    .unwrap();
    cfg
}

fn design(cfg: &Path, extra: &[&str]) -> (Value, String) {
    let mut args = vec!["design", cfg.to_str().unwrap(), "--quiet"];
    args.extend_from_slice(extra);
    let o = coapt(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let d = json(&cfg.parent().unwrap().join("run/design/design.json"));
    (d, String::from_utf8_lossy(&o.stdout).into_owned())
}

#[test]
fn design_recommends_the_smallest_size_meeting_every_criterion_stable_under_h_halved() {
    const SIZES: &str = "[13, 15, 17]";
    let coarse = tmpdir("design-h1");
    let cfg = config(&coarse, "1 mm", SIZES);
    let (d, table) = design(&cfg, &[]);
    assert_eq!(d["schema"], "coapt-design/1");
    // With "planes" contact the sample's leaflets cross each other at every
    // size (closure.json), so no closure is assessable and none may be
    // recommended; should a size become assessable and meet every
    // criterion, the smallest such is the one.
    let best = d["recommended_size"].as_u64();
    let run = coarse.join("run/design");
    let sizes = d["sizes"].as_array().unwrap();
    assert_eq!(sizes.len(), 3);
    let mut first_meeting = None;
    for e in sizes {
        let size = e["size"].as_u64().unwrap();
        let dir = run.join(format!("size-{size}"));
        let rep = json(&dir.join("report.json"));
        let meets = rep["verdict"]["meets_all_criteria"].as_bool().unwrap();
        assert_eq!(
            e["meets_all_criteria"].as_bool(),
            Some(meets),
            "size {size}"
        );
        assert_eq!(
            e["central_coaptation_height_mm"], rep["metrics"]["central_coaptation_height_mm"],
            "size {size}"
        );
        assert_eq!(
            e["effective_height_mm"],
            rep["metrics"]["effective_height_mm"]
        );
        if meets && first_meeting.is_none() {
            first_meeting = Some(size);
        }
        if !meets {
            assert!(!strings(&e["failures"]).is_empty(), "{e}");
        }
        // Crossing leaflets: not assessable, and the sweep's first failure
        // says so with the count.
        let crossing = json(&dir.join("closure.json"))["intersecting_triangle_pairs"]
            .as_u64()
            .unwrap();
        if crossing > 0 {
            assert!(
                !meets && rep["verdict"]["status"] == "not_assessable",
                "size {size}"
            );
            let first = strings(&e["failures"])[0].clone();
            assert!(
                first.starts_with(&format!("not assessable: {crossing} pairs of triangles")),
                "size {size}: {first}"
            );
        }
    }
    assert_eq!(best, first_meeting, "{}", d["reason"]);
    // Without --quiet, each size says how it ended as it ends (here from
    // the sweep just run: every stage is reused).
    let o = coapt(&["design", cfg.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let log = stderr(&o);
    for e in sizes {
        let size = e["size"].as_u64().unwrap();
        let line = log
            .lines()
            .find(|l| {
                l.starts_with(&format!("size {size}: ")) && l.ends_with(" of 4 closures done)")
            })
            .unwrap_or_else(|| panic!("no end-of-size line for size {size}:\n{log}"));
        let meets = e["meets_all_criteria"].as_bool() == Some(true);
        assert_eq!(line.contains(": meets every criterion ("), meets, "{line}");
    }
    let reason = d["reason"].as_str().unwrap();
    match best {
        Some(best) => {
            assert!(table.contains("← recommended"), "{table}");
            // The reason names the failure just below, or says the sweep
            // starts there.
            assert!(
                reason.contains(&format!("Size {best} is the smallest")),
                "{reason}"
            );
            if best > 13 {
                assert!(
                    reason.contains(&format!("size {} fails", best - 2)),
                    "{reason}"
                );
            } else {
                assert!(reason.contains("widen the sweep downwards"), "{reason}");
            }
        }
        None => {
            assert!(!table.contains("← recommended"), "{table}");
            assert!(
                reason.starts_with("No size tried meets every criterion"),
                "{reason}"
            );
        }
    }
    // Ozaki's rule beside the answer: the sample's intercommissural
    // distances (22.4 / 23.4 / 23.8 mm) are all nearest 23.
    assert_eq!(d["ozaki_rule_sizes"], serde_json::json!([23, 23, 23]));
    let rule = d["ozaki_rule"].as_str().unwrap();
    assert!(rule.contains("cuts 23 / 23 / 23"), "{rule}");
    assert!(table.contains(rule), "{table}");
    if let Some(best) = best {
        let below = (23 - best) / 2;
        assert!(rule.contains(&format!("is {below} size")), "{rule}");
    }
    // The rule is closed too (23 for all three is not a size of this
    // sweep), in its own run directory, and judged like a size.
    let c = &d["ozaki_rule_closure"];
    assert_eq!(c["run"], "ozaki-rule", "{c}");
    assert_eq!(c["leaflet_sizes"], serde_json::json!([23, 23, 23]));
    assert_eq!(c["status"], "measured", "{c}");
    let rule_rep = json(&run.join("ozaki-rule/report.json"));
    assert_eq!(
        c["meets_all_criteria"], rule_rep["verdict"]["meets_all_criteria"],
        "{c}"
    );
    let rule_line = table
        .lines()
        .find(|l| l.starts_with("Closed as Ozaki's rule cuts it (ozaki-rule/)"))
        .unwrap_or_else(|| panic!("no rule closure line:\n{table}"));
    assert!(rule_line.contains(" criteria"), "{rule_line}");
    // The shown size misses the criteria it fails by the least.
    let missed: Vec<f64> = sizes
        .iter()
        .map(|e| e["criteria_shortfall_mm"].as_f64().unwrap())
        .collect();
    assert!(missed.iter().all(|&x| x >= 0.0), "{missed:?}");
    // Leaflet area grows with size (same template family, same mesher).
    let areas: Vec<f64> = sizes
        .iter()
        .map(|e| e["leaflet_area_mm2"].as_f64().unwrap())
        .collect();
    assert!(areas.windows(2).all(|w| w[1] > w[0]), "{areas:?}");

    // The design report: the recommended valve with the sweep, valid and clean.
    let rep = json(&run.join("report.json"));
    let errs = errors(&rep);
    assert!(
        errs.is_empty(),
        "design report.json breaks its schema: {errs:#?}"
    );
    assert_eq!(rep["design"]["recommended_size"], d["recommended_size"]);
    let page = run.join("report.html");
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("<section id=\"sizing\">"));
    assert!(html.contains(&match best {
        Some(b) => format!("Recommended: Ozaki size {b}"),
        None => "No size of the sweep meets every criterion.".to_string(),
    }));
    assert!(html.contains("id=\"fig-sizing-heights\"") && html.contains("id=\"fig-sizing-areas\""));
    assert!(
        html.contains("<p>Ozaki&#39;s rule (the sizer size nearest"),
        "no Ozaki's rule in the design page"
    );
    assert!(
        html.contains("<a href=\"ozaki-rule/report.html\">"),
        "no link to the rule's closure"
    );
    if let Some(b) = browser() {
        let (v, code) = check(&b, &page);
        assert!(strings(&v["console_errors"]).is_empty(), "{v}");
        assert!(strings(&v["external_requests"]).is_empty(), "{v}");
        assert_eq!(v["images"]["total"], v["images"]["decoded"], "{v}");
        assert_eq!(code, 0, "{v}");
    }

    // Again: every size is skipped, the answer is the same bytes.
    let before = std::fs::read(run.join("design.json")).unwrap();
    design(&cfg, &[]);
    for dir in ["size-13", "size-15", "size-17", "ozaki-rule"] {
        let m = json(&run.join(format!("{dir}/manifest.json")));
        for st in m["stages"].as_array().unwrap() {
            assert_eq!(st["status"], "skipped", "{dir}: {st}");
        }
    }
    assert_eq!(std::fs::read(run.join("design.json")).unwrap(), before);

    // One thread: the same design.json, byte for byte.
    let one = tmpdir("design-h1-t1");
    let cfg1 = config(&one, "1 mm", SIZES);
    design(&cfg1, &["--threads", "1"]);
    assert_eq!(
        std::fs::read(one.join("run/design/design.json")).unwrap(),
        before,
        "design.json depends on the thread count"
    );

    // h → h/2: the same recommendation.
    let fine = tmpdir("design-h05");
    let cfg2 = config(&fine, "0.5 mm", SIZES);
    let (d2, _) = design(&cfg2, &[]);
    assert_eq!(
        d2["recommended_size"].as_u64(),
        best,
        "h 1 mm: {}\nh 0.5 mm: {}",
        d["reason"],
        d2["reason"]
    );
}

#[test]
fn design_refuses_bad_sizes_and_a_chain_without_leaflets() {
    let d = tmpdir("design-bad");
    let cfg = config(&d, "1 mm", "[20]");
    let o = coapt(&["design", &s(&cfg), "--quiet"]);
    assert_bad_input(&o, &cfg, &["design.sizes", "not in the Ozaki sizer table"]);
    let o = coapt(&["design", &s(&cfg), "--sizes", "36-40"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--sizes 36-40"), "{}", stderr(&o));
    // A config that stops at the suture paths cannot be sized.
    let r = repo();
    let short = d.join("short.toml");
    std::fs::write(
        &short,
        format!(
            "[run]\ndir = \"run\"\n[inputs]\nct = \"{}\"\nlandmarks = \"{}\"\n",
            s(&r.join("sample_data/ct.nii.gz")),
            s(&r.join("sample_data/landmarks.mrk.json")),
        ),
    )
    .unwrap();
    let o = coapt(&["design", &s(&short), "--quiet"]);
    assert_bad_input(&o, &short, &["leaflets, close and report", "template"]);
    assert!(!d.join("run").exists(), "nothing may be written");
}
