//! The page from the example report and from broken ones.

use super::*;
use super::{format::*, record::*};
use base64::{Engine as _, engine::general_purpose::STANDARD as BASE64};
use coapt_io::png::{Rgb, encode};
use serde_json::{Map, Value, json};

fn example() -> Value {
    serde_json::from_str(include_str!("../../../../schemas/report.example.json")).unwrap()
}

/// The typed document of a report.json's content.
fn doc(v: &Value) -> Report {
    serde_json::from_value(v.clone()).expect("a report")
}

fn figure(id: &str, w: usize, h: usize) -> Figure {
    let px = (0..w * h)
        .map(|i| [(i % w * 255 / w) as u8, (i / w * 255 / h) as u8, 128])
        .collect();
    Figure {
        id: id.into(),
        title: format!("Figure {id}"),
        caption: "Colour: height above the annulus, mm.".into(),
        width: w as u32,
        height: h as u32,
        png: encode(&Rgb { w, h, px }),
    }
}

/// Every `src="…"` and `href="…"` value of the page.
fn urls(page: &str) -> Vec<String> {
    let mut out = Vec::new();
    for attr in ["src=\"", "href=\""] {
        for (i, _) in page.match_indices(attr) {
            let rest = &page[i + attr.len()..];
            out.push(rest[..rest.find('"').unwrap()].to_string());
        }
    }
    out
}

/// The page is complete: doctype, every section opened and closed, html closed.
fn assert_whole(page: &str) {
    assert!(page.starts_with("<!DOCTYPE html>\n<html lang=\"en\">"));
    assert!(page.ends_with("</body>\n</html>\n"));
    // verdict … provenance and references; the case header when the
    // report has one, sizing for a design.
    let sections = page.matches("<section").count();
    assert!(sections >= 11, "{sections} sections");
    assert_eq!(page.matches("</section>").count(), sections);
    assert_eq!(
        page.matches("<table").count(),
        page.matches("</table>").count()
    );
    for u in urls(page) {
        assert!(
            u.starts_with("data:") || u.starts_with('#'),
            "external URL {u}"
        );
    }
}

#[test]
fn example_page_has_every_section_in_reading_order() {
    let page = render(&doc(&example()), &[figure("top_view", 40, 30)], None);
    assert_whole(&page);
    let ids = [
        "case",
        "verdict",
        "criteria",
        "findings",
        "metrics",
        "leaflets",
        "conventions",
        "figures",
        "solver",
        "timing",
        "provenance",
        "references",
    ];
    let pos: Vec<usize> = ids
        .iter()
        .map(|id| page.find(&format!("<section id=\"{id}\"")).unwrap())
        .collect();
    assert!(pos.windows(2).all(|w| w[0] < w[1]), "{pos:?}");
    for needle in [
        "<dt>Case</dt><dd>sample · predicted 2026-11-27 19:29 UTC · coapt 0.1.0</dd>",
        "<dt>Landmarks</dt><dd>given: sample_data/landmarks.mrk.json</dd>",
        "annulus 21.9 mm, sinus 30.3 mm, STJ 27.1 mm (area-equivalent diameters); intercommissural distances C1–C2 / C2–C3 / C3–C1 22.4 / 23.8 / 23.1 mm",
        "ozaki_size 23 (all three); free edge 31.6 / 31.6 / 31.6 mm, sutured edge 68.2 / 68.2 / 68.2 mm; placed hanging; mesh size 0.5 mm",
        "GOH (Gasser–Ogden–Holzapfel): μ 900 kPa, k₁ 1100 kPa, k₂ 1000, κ 0.29; thickness 0.5 mm; source: seed 001 §3",
        "80 mmHg (and 3 mmHg for the effective height); true contact between the leaflets; bending stiffness on; stress-free state: sutured",
        "<li><strong>[25]</strong> Schäfers HJ, Bierbach B, Aicher D.",
        "The valve closes",
        "<p class=\"headline\">Fails 2 of 9 criteria: Effective height, No billowing.</p>",
        "<td class=\"num\">8.62 mm</td><td class=\"num\">&gt; 9 mm</td><td><span class=\"tag fail\">&#10008; FAIL</span>",
        "<td class=\"num\">4.60 mm</td><td class=\"num\">&gt; 4 mm</td><td><span class=\"tag pass\">&#10004; PASS</span>",
        "<td class=\"num\">yes</td><td class=\"num\">yes</td>",
        "24.6 %",
        "96.2 mm²",
        "id=\"convention-seeds\"",
        "id=\"convention-slicerheart\"",
        "<td>2.10 · 4.40 · 5.60<br>3.00 · 3.80 · 4.60 · 5.10 · 5.40</td>",
        "<th scope=\"row\">1–3</th><td class=\"num\">46.1</td><td>not measured</td>",
        "<figure id=\"fig-top_view\">",
        "<figcaption><strong>Figure 1. Figure top_view</strong>",
        "3.200e-9 N",
        "CONVERGED",
        "3f2a9c4e1b7d8a0c6e5f4d3c2b1a09f8e7d6c5b4a39281706f5e4d3c2b1a0918",
        "80 mmHg",
        "<th scope=\"row\">template.kind</th><td class=\"mono\">ozaki</td>",
        "<th scope=\"row\">template.size</th><td class=\"mono\">23</td>",
        "<strong>9.80</strong>",
        "coapt 0.1.0",
    ] {
        assert!(page.contains(needle), "missing {needle:?}");
    }
    // The warning from the JSON comes before the info.
    assert!(page.find("WARNING").unwrap() < page.find("INFO</span>").unwrap());
    // Not measured per-leaflet NCCA and SlicerHeart heights say so.
    assert!(page.contains("<td class=\"num\">not measured</td></tr>"));
}

/// Parameters read with their units and without placeholders: nested
/// records by dotted key, a key's unit suffix moved to its value, unset
/// parameters (derived, shown under their own key) left out.
#[test]
fn parameters_read_with_units() {
    let mut rows = Vec::new();
    flatten(
        "",
        &json!({"margin": "unset", "margin_mm": 0.9, "closure": {"model": {"mu_kpa": 900.0, "law": "goh"}, "time_limit_s": 600.0, "suture": {"k0_n_per_mm": 64.0}}}),
        &mut rows,
    );
    let rows: Vec<(&str, &str)> = rows.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
    assert_eq!(
        rows,
        [
            ("closure.model.law", "goh"),
            ("closure.model.mu", "900 kPa"),
            ("closure.suture.k0", "64 N/mm"),
            ("closure.time_limit", "600 s"),
            ("margin", "0.9 mm"),
        ]
    );
}

#[test]
fn timing_in_pipeline_order_then_alphabetical() {
    let r = json!({"timing_s": {"zeta": 1.0, "report": 0.5, "alpha": 2.0, "segment": 3.0}});
    let page = render(&doc(&r), &[], None);
    let p: Vec<usize> = ["segment", "report", "alpha", "zeta"]
        .iter()
        .map(|s| page.find(&format!("<th scope=\"row\">{s}</th>")).unwrap())
        .collect();
    assert!(p.windows(2).all(|w| w[0] < w[1]));
    assert!(page.contains("<strong>6.50</strong>"));
}

#[test]
fn figures_are_embedded_png_data_urls_with_unique_ids() {
    let f = figure("top view", 8, 4);
    let mut bad = figure("top view", 8, 4);
    bad.png = b"not a png".to_vec();
    let page = render(&doc(&example()), &[f.clone(), f.clone(), bad], None);
    assert_whole(&page);
    let src = format!("src=\"data:image/png;base64,{}\"", BASE64.encode(&f.png));
    assert_eq!(page.matches(&src).count(), 2);
    assert!(page.contains("<figure id=\"fig-top-view\">"));
    assert!(page.contains("<figure id=\"fig-top-view-2\">"));
    assert!(page.contains("<figure id=\"fig-top-view-3\">"));
    assert!(page.contains("width=\"8\" height=\"4\""));
    assert_eq!(
        page.matches("<img ").count(),
        2,
        "the non-PNG figure gets no <img>"
    );
    assert!(page.contains("Image missing"));
    assert!(render(&doc(&example()), &[], None).contains("<p>No figures.</p>"));
}

/// The values of the document's enumerations (a status, a severity, a
/// comparison, where the landmarks came from): a report holds no other.
const ENUMERATIONS: [&str; 12] = [
    "meets_all_criteria",
    "fails_criteria",
    "not_assessable",
    "error",
    "warning",
    "info",
    ">",
    "<=",
    "is",
    "given",
    "detected",
    "measured",
];

/// Replace every string value but an enumeration's by `s` (keys are kept).
fn poison(v: &Value, s: &str) -> Value {
    match v {
        Value::String(e) if ENUMERATIONS.contains(&e.as_str()) => v.clone(),
        Value::String(_) => Value::String(s.into()),
        Value::Array(a) => Value::Array(a.iter().map(|x| poison(x, s)).collect()),
        Value::Object(o) => {
            let mut m = Map::new();
            for (k, x) in o {
                m.insert(k.clone(), poison(x, s));
            }
            Value::Object(m)
        }
        other => other.clone(),
    }
}

#[test]
fn every_string_is_escaped() {
    let evil = "<script>alert('x')</script>&\"\u{7}";
    let mut r = poison(&example(), evil);
    for k in ["timing_s", "inputs", "parameters"] {
        let inner = r[k].clone();
        r[k] = json!({ evil: inner.as_object().unwrap().values().next().unwrap() });
    }
    let mut f = figure(evil, 4, 4);
    f.title = evil.into();
    f.caption = evil.into();
    let page = render(&doc(&r), &[f], None);
    assert_whole(&page);
    assert!(!page.contains("<script"), "raw markup from the JSON");
    assert!(!page.contains('\u{7}'));
    assert!(page.contains("&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;&amp;&quot;\u{FFFD}"));
    assert!(page.contains("<figure id=\"fig--script-alert--x----script----\">"));
}

/// Every JSON path of the example, as a list of keys/indices.
fn paths(v: &Value, here: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    match v {
        Value::Object(o) => {
            for (k, x) in o {
                here.push(json!(k));
                out.push(here.clone());
                paths(x, here, out);
                here.pop();
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                here.push(json!(i));
                out.push(here.clone());
                paths(x, here, out);
                here.pop();
            }
        }
        _ => {}
    }
}

/// Remove (`None`) or replace the value at `path`.
fn mutate(root: &Value, path: &[Value], with: Option<&Value>) -> Value {
    let mut r = root.clone();
    let mut cur = &mut r;
    for step in &path[..path.len() - 1] {
        cur = match step {
            Value::String(k) => cur.get_mut(k.as_str()).unwrap(),
            _ => cur.get_mut(step.as_u64().unwrap() as usize).unwrap(),
        };
    }
    let last = &path[path.len() - 1];
    match (cur, with) {
        (Value::Object(o), None) => {
            o.remove(last.as_str().unwrap());
        }
        (Value::Array(a), None) => {
            a.remove(last.as_u64().unwrap() as usize);
        }
        (Value::Object(o), Some(w)) => {
            o.insert(last.as_str().unwrap().to_string(), w.clone());
        }
        (Value::Array(a), Some(w)) => a[last.as_u64().unwrap() as usize] = w.clone(),
        _ => unreachable!(),
    }
    r
}

/// Any key missing, null, or of any other type: the report either reads
/// into the document (and the page is whole and shows no raw markup) or
/// is refused with an error naming the key; nothing panics.
#[test]
fn every_missing_key_and_wrong_type_reads_whole_or_is_refused() {
    let ex = example();
    let mut all = Vec::new();
    paths(&ex, &mut Vec::new(), &mut all);
    assert!(all.len() > 200, "{}", all.len());
    let replacements = [
        json!(null),
        json!("<i>"),
        json!(-1e308),
        json!(1.5),
        json!(u64::MAX),
        json!(-3),
        json!(true),
        json!([]),
        json!([null, "<i>"]),
        json!({}),
        json!({"<i>": null}),
    ];
    let (mut rendered, mut refused) = (0, 0);
    for p in &all {
        for w in std::iter::once(None).chain(replacements.iter().map(Some)) {
            match serde_json::from_value::<Report>(mutate(&ex, p, w)) {
                Ok(r) => {
                    let page = render(&r, &[], None);
                    assert_whole(&page);
                    assert!(!page.contains("<i>"), "{p:?} {w:?}");
                    rendered += 1;
                }
                Err(e) => {
                    assert!(!e.to_string().is_empty());
                    refused += 1;
                }
            }
        }
    }
    // Every removal of an optional key and every null reads.
    assert!(
        rendered > 1000 && refused > 1000,
        "{rendered} read, {refused} refused"
    );
    for v in [json!(null), json!("x"), json!(3)] {
        assert!(serde_json::from_value::<Report>(v).is_err());
    }
}

#[test]
fn empty_report_says_what_is_missing() {
    let page = render(&Report::default(), &[], None);
    for needle in [
        "Closure could not be determined.",
        "Whether the criteria are met could not be determined.",
        "No criteria in the report.",
        "No findings.",
        "No per-leaflet values in the report.",
        "No leaflet pairs measured.",
        "No figures.",
        "UNKNOWN",
        "No timings in the report.",
        "No input files recorded.",
        "No parameters recorded.",
    ] {
        assert!(page.contains(needle), "missing {needle:?}");
    }
}

#[test]
fn a_not_assessable_verdict_leads_the_page_with_its_reasons() {
    let mut r = example();
    r["verdict"]["status"] = json!("not_assessable");
    r["verdict"]["assessable"] = json!(false);
    r["verdict"]["not_assessable_reasons"] =
        json!(["594 pairs of triangles of different leaflets cross each other"]);
    let page = render(&doc(&r), &[], None);
    assert!(page.contains("class=\"verdict na\""));
    let head = page.find("NOT ASSESSABLE").expect("headline");
    let reason = page.find("<li>594 pairs of triangles").expect("reason");
    let closes = page.find("The valve closes").unwrap();
    let criteria = page.find("<section id=\"criteria\"").unwrap();
    assert!(head < reason && reason < closes && closes < criteria);
    // Failed criteria are shown as what the computed state would fail,
    // never as a verdict of their own.
    assert!(page.contains(
        "As computed, these criteria would fail (2 of 9):</strong> Effective height, No billowing."
    ));
    assert!(!page.contains("Fails 2 of 9"));
}

#[test]
fn unmeasurable_criterion_and_derived_findings_are_spelled_out() {
    let mut r = example();
    r["criteria"][0]["value"] = json!(null);
    r["criteria"][0]["pass"] = json!(null);
    r["solver"]["converged"] = json!(false);
    r["solver"]["reason"] = json!("iteration limit");
    r["metrics"]["closed"] = json!(false);
    r["metrics"]["coaptation_area_mm2"]["max"] = json!(0.0);
    r["verdict"] = json!({"closed": false, "meets_all_criteria": true, "summary": ""});
    let page = render(&doc(&r), &[], None);
    assert!(page.contains("<td class=\"num\">not measured</td>"));
    assert!(page.contains("? NOT MEASURABLE"));
    assert!(page.contains("Not measurable: Central coaptation height."));
    assert!(page.contains("The valve does NOT close"));
    assert!(page.contains("class=\"verdict bad\""));
    assert!(page.contains("did not converge (iteration limit)"));
    assert!(page.contains("No contact at all"));
    assert!(page.contains("Inconsistent report"));
    // Errors first, then warnings, then info.
    let e = page.find("ERROR</span>").unwrap();
    let w = page.find("WARNING</span>").unwrap();
    let i = page.find("INFO</span>").unwrap();
    assert!(e < w && w < i);
    // A finding that already says it is not repeated.
    r["findings"] =
        json!([{"severity": "warning", "message": "Solver did not converge after 500 steps."}]);
    let page = render(&doc(&r), &[], None);
    assert_eq!(page.matches("converge").count(), 1);
}

#[test]
fn same_json_same_bytes_whatever_the_key_order() {
    let a = example();
    // Same content, every object's keys reversed.
    fn reversed(v: &Value) -> Value {
        match v {
            Value::Object(o) => Value::Object(
                o.iter()
                    .rev()
                    .map(|(k, x)| (k.clone(), reversed(x)))
                    .collect(),
            ),
            Value::Array(a) => Value::Array(a.iter().map(reversed).collect()),
            x => x.clone(),
        }
    }
    let b = reversed(&a);
    assert_ne!(
        serde_json::to_string(&a).unwrap(),
        serde_json::to_string(&b).unwrap()
    );
    let figs = [figure("a", 5, 5), figure("b", 6, 3)];
    let first_difference = |x: &str, y: &str| x.bytes().zip(y.bytes()).position(|(p, q)| p != q);
    let (pa, pa2, pb) = (
        render(&doc(&a), &figs, None),
        render(&doc(&a), &figs, None),
        render(&doc(&b), &figs, None),
    );
    assert!(
        pa == pa2,
        "differs at byte {:?}",
        first_difference(&pa, &pa2)
    );
    assert!(
        pa == pb,
        "differs at byte {:?}: {:?}",
        first_difference(&pa, &pb),
        first_difference(&pa, &pb).map(|i| &pa[i.saturating_sub(80)..i])
    );
}

/// With the interactive view: one script runs, the one the policy names
/// by hash; the view sits in the figures section, before Figure 1.
#[test]
fn the_view_is_the_one_script_the_policy_allows() {
    use crate::figures::test_valve::synthetic_valve;
    let (v, contact) = synthetic_valve(6);
    let scene = view3d::build(&v, &contact, None).unwrap();
    let figs = [figure("valve_top", 8, 4)];
    let page = render(&doc(&example()), &figs, Some(&scene));
    assert_whole(&page);
    assert_eq!(page, render(&doc(&example()), &figs, Some(&scene)));
    let csp = format!(
        "content=\"default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src {}\">",
        view3d::script_source()
    );
    assert!(page.contains(&csp), "{csp}");
    let runs: Vec<&str> = page
        .split("<script>")
        .skip(1)
        .map(|r| &r[..r.find("</script>").unwrap()])
        .collect();
    assert_eq!(runs, [view3d::SCRIPT]);
    assert_eq!(
        page.matches("<script").count(),
        2,
        "the viewer and its data"
    );
    let at = |s: &str| page.find(s).unwrap();
    assert!(at("<section id=\"figures\">") < at("<figure id=\"view3d\""));
    assert!(at("<figure id=\"view3d\"") < at("<figure id=\"fig-valve_top\">"));
    assert!(page.contains("@media print { .view3d { display: none; } }"));
    // Without a view the page has no script and the policy allows none.
    let plain = render(&doc(&example()), &figs, None);
    assert!(!plain.contains("<script") && !plain.contains("script-src"));
}

#[test]
fn numbers_are_formatted_without_negative_zero() {
    assert_eq!(fixed(Some(-0.0001), 2), "0.00");
    assert_eq!(fixed(Some(-0.0), 1), "0.0");
    assert_eq!(fixed(Some(-0.5), 1), "-0.5");
    assert_eq!(fixed(Some(2.345), 1), "2.3");
    assert_eq!(fixed(None, 1), DASH);
    assert_eq!(shortest(Some(4.0)), "4");
    assert_eq!(shortest(Some(9.5)), "9.5");
    assert_eq!(percent(Some(0.246)), "24.6 %");
    assert_eq!(mm(Some(f64::NAN)), NOT_MEASURED);
    assert_eq!(mm(None), NOT_MEASURED);
}
