//! `report.html`: one self-contained page a surgeon reads in a minute.
//!
//! Verdict and criteria first, then findings, key metrics, per-leaflet
//! values, the two measurement conventions side by side, figures, solver,
//! timings and provenance. The page is built from `report.json` (as a
//! `serde_json::Value`, so a missing key, a `null` or a wrong type shows as
//! "—" or "not measured" instead of failing) and the figures' PNG bytes,
//! embedded as `data:` URLs, and the interactive 3-D view when there is
//! one. No external URL; a Content Security Policy forbids any load but
//! inline styles, `data:` images and the one viewer script (by its hash).
//! Same input, same bytes: no clock, no hash-map order.

use std::fmt::Write as _;

use base64::{Engine as _, engine::general_purpose::STANDARD as BASE64};
use serde_json::{Map, Value};

use super::view3d::{self, Scene};
use super::{Figure, references};

/// The stages in pipeline order, for the timing table.
const STAGE_ORDER: [&str; 6] = ["segment", "surface", "valve", "leaflets", "close", "report"];

const DASH: &str = "—";
const NOT_MEASURED: &str = "not measured";

const CSS: &str = r#"
:root { --ok:#1b6e2e; --ok-bg:#dcf3e1; --bad:#a4161a; --bad-bg:#fbdada; --na:#6b5900; --na-bg:#f6efc8; --line:#c9ccd1; }
* { box-sizing: border-box; }
body { font-family: "Helvetica Neue", Arial, "Liberation Sans", sans-serif; font-size: 15px; line-height: 1.4; color: #16181b; background: #fff; max-width: 1100px; margin: 0 auto; padding: 16px 24px 40px; }
h1 { font-size: 1.6em; margin: 0.2em 0; }
h2 { font-size: 1.25em; margin: 1.4em 0 0.4em; border-bottom: 2px solid #16181b; padding-bottom: 2px; }
h3 { font-size: 1.05em; margin: 0.8em 0 0.3em; }
p.meta { color: #4a4f57; margin: 0 0 0.8em; }
nav { font-size: 0.9em; color: #4a4f57; }
nav a { color: #1d4f91; margin-right: 0.8em; }
table { border-collapse: collapse; margin: 0.3em 0 0.8em; width: 100%; }
table.narrow { width: auto; min-width: 50%; }
th, td { border: 1px solid var(--line); padding: 4px 8px; text-align: left; vertical-align: top; }
th { background: #eef0f3; font-weight: 600; }
th[scope="row"] { white-space: nowrap; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
td.mono, span.mono { font-family: "DejaVu Sans Mono", Menlo, Consolas, monospace; font-size: 0.85em; word-break: break-all; }
.verdict { border: 3px solid; border-radius: 6px; padding: 10px 16px; margin: 0.6em 0 1em; }
.verdict p { margin: 0.3em 0; }
.verdict .headline { font-size: 1.35em; font-weight: 700; }
.verdict.ok { border-color: var(--ok); background: var(--ok-bg); }
.verdict.bad { border-color: var(--bad); background: var(--bad-bg); }
.verdict.na { border-color: var(--na); background: var(--na-bg); }
.tag { display: inline-block; min-width: 7.5em; font-weight: 700; padding: 1px 6px; border-radius: 3px; border: 1px solid; text-align: center; }
.pass { color: var(--ok); background: var(--ok-bg); border-color: var(--ok); }
.fail { color: var(--bad); background: var(--bad-bg); border-color: var(--bad); }
.na { color: var(--na); background: var(--na-bg); border-color: var(--na); }
.sev-error { color: var(--bad); background: var(--bad-bg); border-color: var(--bad); }
.sev-warning { color: var(--na); background: var(--na-bg); border-color: var(--na); }
.sev-info { color: #1d4f91; background: #e3edf9; border-color: #1d4f91; }
ul.findings { list-style: none; padding: 0; margin: 0.3em 0; }
ul.findings li { margin: 0.3em 0; display: flex; gap: 0.6em; align-items: baseline; }
ul.findings .tag { flex: none; }
.conventions { display: grid; grid-template-columns: 1fr 1fr; gap: 18px; }
.conventions > div { border: 1px solid var(--line); border-radius: 4px; padding: 4px 12px; }
figure { margin: 0.8em 0 1.4em; break-inside: avoid; page-break-inside: avoid; }
figure img { display: block; max-width: 100%; height: auto; border: 1px solid var(--line); }
figcaption { margin-top: 0.3em; font-size: 0.92em; }
tr.recommended { background: var(--ok-bg); font-weight: 600; }
.missing { padding: 2em; border: 2px dashed var(--bad); color: var(--bad); }
dl.case { display: grid; grid-template-columns: max-content 1fr; gap: 2px 14px; margin: 0.4em 0 0.6em; font-size: 0.93em; }
dl.case dt { font-weight: 600; color: #4a4f57; }
dl.case dd { margin: 0; }
ol.references { padding-left: 0; list-style: none; font-size: 0.92em; }
ol.references li { margin: 0.25em 0; }
footer { margin-top: 2em; color: #4a4f57; font-size: 0.85em; }
@media (max-width: 760px) { .conventions { grid-template-columns: 1fr; } }
@media print {
  @page { margin: 14mm; }
  body { font-size: 10pt; max-width: none; padding: 0; }
  nav { display: none; }
  * { -webkit-print-color-adjust: exact; print-color-adjust: exact; }
  h2 { break-after: avoid; page-break-after: avoid; }
  table, .verdict, .conventions > div { break-inside: avoid; page-break-inside: avoid; }
  figure img { max-height: 120mm; width: auto; }
}
"#;

/// The HTML page for `report` (the content of `report.json`), `figures`
/// and, when given, the interactive view of `scene` before the figures.
/// Never panics: every value is looked up, and shown as "—" or "not
/// measured" when missing, `null` or of another type.
pub fn render(report: &Value, figures: &[Figure], scene: Option<&Scene>) -> String {
    let mut h = String::with_capacity(
        16 * 1024
            + figures
                .iter()
                .map(|f| f.png.len() * 4 / 3 + 512)
                .sum::<usize>(),
    );
    let version = text_or(report.get("coapt_version"), DASH);
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    h.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n");
    let script = match scene {
        Some(_) => format!("; script-src {}", view3d::script_source()),
        None => String::new(),
    };
    let _ = writeln!(
        h,
        "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; style-src 'unsafe-inline'{script}\">",
    );
    h.push_str("<link rel=\"icon\" href=\"data:,\">\n");
    h.push_str("<title>Aortic valve closure — coaptation report</title>\n<style>");
    h.push_str(CSS);
    if scene.is_some() {
        h.push_str(view3d::CSS);
    }
    h.push_str(
        "</style>\n</head>\n<body>\n<header>\n<h1>Aortic valve closure — coaptation report</h1>\n",
    );
    let _ = writeln!(
        h,
        "<p class=\"meta\">Predicted by coapt {} · coordinates {} (mm) · {}</p>",
        esc(&version),
        esc(&text_or(report.get("frame"), DASH)),
        esc(&text_or(report.get("schema"), "schema not stated")),
    );
    let _ = write!(
        h,
        "<nav><a href=\"#criteria\">Criteria</a><a href=\"#findings\">Findings</a>{}<a href=\"#metrics\">Metrics</a>\
         <a href=\"#leaflets\">Leaflets</a><a href=\"#conventions\">Conventions</a><a href=\"#figures\">Figures</a>\
         <a href=\"#solver\">Solver</a><a href=\"#timing\">Timing</a><a href=\"#provenance\">Provenance</a>\
         <a href=\"#references\">References</a></nav>\n</header>\n",
        if report.get("design").is_some() {
            "<a href=\"#sizing\">Sizing</a>"
        } else {
            ""
        }
    );
    let criteria = array(report.get("criteria"));
    case_header(&mut h, report.get("case"));
    verdict(&mut h, report, criteria);
    criteria_table(&mut h, criteria);
    findings(&mut h, report, criteria);
    if let Some(d) = report.get("design") {
        let sweep: Vec<Figure> = figures
            .iter()
            .filter(|f| f.id.starts_with("sizing"))
            .cloned()
            .collect();
        sizing(&mut h, d, &sweep);
    }
    key_metrics(&mut h, report.get("metrics"));
    leaflets(&mut h, report);
    conventions(&mut h, report.get("conventions"));
    // The sweep's charts sit with its table, numbered first.
    let (sweep, others): (Vec<Figure>, Vec<Figure>) = figures
        .iter()
        .cloned()
        .partition(|f| f.id.starts_with("sizing"));
    figures_section(&mut h, &others, sweep.len() + 1, scene);
    solver(&mut h, report.get("solver"));
    timing(&mut h, report.get("timing_s"));
    provenance(&mut h, report);
    references::section(&mut h);
    let _ = writeln!(
        h,
        "<footer>coapt {} — a model prediction from CT, to be read with the clinical picture; not a measurement on the patient.</footer>",
        esc(&version)
    );
    h.push_str("</body>\n</html>\n");
    h
}

// ---------------------------------------------------------------- sections

/// Who and what: the case, the root the CT gave, the leaflets, the material
/// and load, in a few lines above the verdict.
fn case_header(h: &mut String, c: Option<&Value>) {
    let Some(c) = c.filter(|c| c.is_object()) else {
        return;
    };
    h.push_str("<section id=\"case\">\n<dl class=\"case\">\n");
    let mut row = |k: &str, v: String| {
        if !v.is_empty() {
            let _ = writeln!(h, "<dt>{}</dt><dd>{}</dd>", esc(k), v);
        }
    };
    let mut first = vec![esc(&text_or(c.get("name"), "unnamed case"))];
    if let Some(t) = c.get("computed_utc").and_then(Value::as_str) {
        // "2026-11-27T19:29:54Z" → "2026-11-27 19:29 UTC"
        let shown = match (t.get(..10), t.get(11..16)) {
            (Some(d), Some(hm)) => format!("{d} {hm} UTC"),
            _ => t.to_string(),
        };
        first.push(format!("predicted {}", esc(&shown)));
    }
    first.push(format!(
        "coapt {}",
        esc(&text_or(c.get("coapt_version"), DASH))
    ));
    row("Case", first.join(" · "));

    let a = c.get("anatomy");
    let d = |k: &str| {
        num(a.and_then(|a| a.get(k))).map_or(NOT_MEASURED.to_string(), |x| {
            with_unit(&fixed(Some(x), 1), "mm")
        })
    };
    let ic: Vec<String> = array(a.and_then(|a| a.get("intercommissural_mm")))
        .iter()
        .map(|v| fixed(v.as_f64(), 1))
        .collect();
    let mut root = format!(
        "annulus {}, sinus {}, STJ {} (area-equivalent diameters)",
        d("annulus_diameter_mm"),
        d("sinus_diameter_mm"),
        d("stj_diameter_mm")
    );
    if ic.len() == 3 {
        let _ = write!(
            root,
            "; intercommissural distances C1–C2 / C2–C3 / C3–C1 {} mm",
            ic.join(" / ")
        );
    }
    if let Some(t) = num(a.and_then(|a| a.get("annulus_plane_tilt_deg"))) {
        let _ = write!(
            root,
            "; annulus plane tilted {}° to the commissures' axis",
            fixed(Some(t), 1)
        );
    }
    row("Root (from the CT)", root);

    let lm = c.get("landmarks");
    match lm.and_then(|l| l.get("source")).and_then(Value::as_str) {
        Some("detected") => {
            let points: Vec<String> = array(lm.and_then(|l| l.get("points")))
                .iter()
                .map(|p| {
                    let label = esc(&text_or(p.get("label"), "?"));
                    match p.get("source").and_then(Value::as_str) {
                        Some("given") => format!(
                            "{label} given ({} mm from where coapt found it)",
                            fixed(num(p.get("given_to_detected_mm")), 1)
                        ),
                        _ => format!("{label} {}", fixed(num(p.get("confidence")), 2)),
                    }
                })
                .collect();
            row(
                "Landmarks",
                format!(
                    "detected by coapt from the segmented root (not placed by hand: check them on the CT figure), except those given; confidence {}",
                    points.join(", ")
                ),
            );
            if let Some(text) = sinus_names(lm) {
                row("Sinuses", text);
            }
        }
        Some("given") => row(
            "Landmarks",
            format!(
                "given: {}",
                esc(&text_or(lm.and_then(|l| l.get("file")), DASH))
            ),
        ),
        _ => {}
    }

    let ls = array(c.get("leaflets"));
    if !ls.is_empty() {
        let names: Vec<String> = ls
            .iter()
            .map(|l| text_or(l.get("template"), DASH))
            .collect();
        let mut text = if names.iter().all(|n| *n == names[0]) {
            format!("{} (all three)", esc(&names[0]))
        } else {
            names
                .iter()
                .enumerate()
                .map(|(i, n)| format!("{}: {}", i + 1, esc(n)))
                .collect::<Vec<_>>()
                .join("; ")
        };
        let per = |k: &str| {
            ls.iter()
                .map(|l| fixed(num(l.get(k)), 1))
                .collect::<Vec<_>>()
                .join(" / ")
        };
        let _ = write!(
            text,
            "; free edge {} mm, sutured edge {} mm",
            per("free_edge_mm"),
            per("attachment_mm")
        );
        if let Some(p) = ls[0].get("placement").and_then(Value::as_str) {
            let _ = write!(text, "; placed {}", esc(p));
        }
        if let Some(hm) = num(c.get("mesh_h_mm")) {
            let _ = write!(text, "; mesh size {} mm", shortest(Some(hm)));
        }
        row("Leaflets", text);
    }

    if let Some(m) = c.get("material").and_then(super::case::material_text) {
        let mut text = esc(&m);
        if let Some(t) = num(c.get("thickness_mm")) {
            let _ = write!(text, "; thickness {} mm", shortest(Some(t)));
        }
        let source = c
            .get("material_source")
            .and_then(Value::as_str)
            .unwrap_or("not stated (close.toml: material_source)");
        let _ = write!(text, "; source: {}", esc(source));
        row("Material", text);
    }
    if let Some(p) = num(c.get("pressure_mmhg")) {
        let mut text = format!("{} mmHg", shortest(Some(p)));
        if let Some(lp) = num(c.get("effective_height_pressure_mmhg")) {
            let _ = write!(
                text,
                " (and {} mmHg for the effective height)",
                shortest(Some(lp))
            );
        }
        let contact = match c.get("contact").and_then(Value::as_str) {
            Some("leaflets") => "true contact between the leaflets",
            Some("planes") => "contact planes through the axis (seed 001)",
            Some("none") => "no contact",
            _ => "",
        };
        if !contact.is_empty() {
            let _ = write!(text, "; {contact}");
        }
        if let Some(b) = c.get("bending").and_then(Value::as_bool) {
            text.push_str(if b {
                "; bending stiffness on"
            } else {
                "; membrane (no bending)"
            });
        }
        if let Some(r) = c.get("reference").and_then(Value::as_str) {
            let _ = write!(text, "; stress-free state: {}", esc(r));
        }
        row("Load and model", text);
    }
    h.push_str("</dl>\n</section>\n");
}

fn verdict(h: &mut String, report: &Value, criteria: &[Value]) {
    let v = report.get("verdict");
    let closed = v
        .and_then(|v| v.get("closed"))
        .and_then(Value::as_bool)
        .or_else(|| {
            report
                .get("metrics")
                .and_then(|m| m.get("closed"))
                .and_then(Value::as_bool)
        });
    let failed = criteria_names(criteria, Some(false));
    let unmeasured = criteria_names(criteria, None);
    let meets_all = v
        .and_then(|v| v.get("meets_all_criteria"))
        .and_then(Value::as_bool)
        .or_else(|| {
            (!criteria.is_empty() && failed.is_empty() && unmeasured.is_empty())
                .then_some(true)
                .or((!failed.is_empty()).then_some(false))
        });
    let status = v.and_then(|v| v.get("status")).and_then(Value::as_str);
    let reasons: Vec<String> = array(v.and_then(|v| v.get("not_assessable_reasons")))
        .iter()
        .filter_map(|r| r.as_str().map(str::to_string))
        .collect();
    let class = match (status, closed, meets_all) {
        (Some("not_assessable"), _, _) => "na",
        (_, Some(true), Some(true)) => "ok",
        (_, Some(false), _) | (_, _, Some(false)) => "bad",
        _ => "na",
    };
    let _ = writeln!(h, "<section id=\"verdict\" class=\"verdict {class}\">");
    // The verdict on the criteria leads, in one line: whether the closure
    // can be judged at all comes first (a green headline above a broken
    // closure would be read and the rest skipped), then what it fails.
    let names = |list: &[String]| esc(&list.join(", "));
    let headline = match (status, meets_all) {
        (Some("not_assessable"), _) => {
            "NOT ASSESSABLE: this closure cannot be judged against the criteria.".to_string()
        }
        (_, Some(true)) => format!("Meets all {} criteria.", criteria.len()),
        (_, Some(false)) if failed.is_empty() => "Not all criteria are met.".to_string(),
        (_, Some(false)) => format!(
            "Fails {} of {} criteria: {}.",
            failed.len(),
            criteria.len(),
            names(&failed)
        ),
        (_, None) => "Whether the criteria are met could not be determined.".to_string(),
    };
    let _ = writeln!(h, "<p class=\"headline\">{headline}</p>");
    if !reasons.is_empty() {
        h.push_str("<ul class=\"reasons\">\n");
        for r in &reasons {
            let _ = writeln!(h, "<li>{}</li>", esc(r));
        }
        h.push_str("</ul>\n");
    }
    if status == Some("not_assessable") {
        let _ = writeln!(
            h,
            "<p>{}</p>",
            if failed.is_empty() {
                "<strong>No criterion is judged met while the closure is not assessable.</strong>"
                    .to_string()
            } else {
                format!(
                    "<strong>As computed, these criteria would fail ({} of {}):</strong> {}.",
                    failed.len(),
                    criteria.len(),
                    names(&failed)
                )
            }
        );
    }
    let closure = match closed {
        Some(true) => "The valve closes: the three leaflets meet in a central coaptation zone.",
        Some(false) => "The valve does NOT close: there is no zone where all three leaflets meet.",
        None => "Closure could not be determined.",
    };
    let _ = write!(h, "<p>{closure}");
    if !unmeasured.is_empty() {
        let _ = write!(h, " Not measurable: {}.", names(&unmeasured));
    }
    h.push_str("</p>\n");
    h.push_str("</section>\n");
}

fn criteria_table(h: &mut String, criteria: &[Value]) {
    h.push_str("<section id=\"criteria\">\n<h2>Criteria</h2>\n");
    if criteria.is_empty() {
        h.push_str("<p>No criteria in the report.</p>\n</section>\n");
        return;
    }
    h.push_str("<table>\n<thead><tr><th>Criterion</th><th>Value</th><th>Required</th><th>Result</th><th>Note</th><th>Source</th></tr></thead>\n<tbody>\n");
    for c in criteria {
        let name = criterion_name(c);
        let unit = match text_or(c.get("unit"), "").as_str() {
            "mm2" => "mm²".to_string(),
            u => u.to_string(),
        };
        let value = match c.get("value") {
            Some(Value::Bool(b)) => yes_no(*b).to_string(),
            Some(Value::Number(n)) => with_unit(&fixed(n.as_f64(), 2), &unit),
            _ => NOT_MEASURED.to_string(),
        };
        let threshold = match c.get("threshold") {
            Some(Value::Bool(b)) => yes_no(*b).to_string(),
            Some(Value::Number(n)) => with_unit(&shortest(n.as_f64()), &unit),
            _ => DASH.to_string(),
        };
        let required = match c.get("comparison").and_then(Value::as_str) {
            Some(">") => format!("&gt; {}", esc(&threshold)),
            Some(">=") => format!("&ge; {}", esc(&threshold)),
            Some("<") => format!("&lt; {}", esc(&threshold)),
            Some("<=") => format!("&le; {}", esc(&threshold)),
            Some("is") => esc(&threshold),
            Some(other) => format!("{} {}", esc(other), esc(&threshold)),
            None => esc(&threshold),
        };
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&name),
            esc(&value),
            required,
            result_tag(c.get("pass").and_then(Value::as_bool)),
            esc(&text_or(c.get("note"), "")),
            esc(&text_or(c.get("source"), "")),
        );
    }
    h.push_str("</tbody>\n</table>\n</section>\n");
}

fn findings(h: &mut String, report: &Value, criteria: &[Value]) {
    h.push_str("<section id=\"findings\">\n<h2>Findings</h2>\n");
    // (severity rank, severity, message), JSON findings first in their order.
    let mut items: Vec<(u8, String, String)> = Vec::new();
    for f in array(report.get("findings")) {
        let sev = text_or(f.get("severity"), "info");
        let msg = text_or(f.get("message"), DASH);
        items.push((severity_rank(&sev), sev, msg));
    }
    // What the page can see for itself, unless a finding already says it.
    let said = |words: &[&str], items: &[(u8, String, String)]| {
        items.iter().any(|(_, _, m)| {
            let m = m.to_lowercase();
            words.iter().any(|w| m.contains(w))
        })
    };
    let solver = report.get("solver");
    if solver
        .and_then(|s| s.get("converged"))
        .and_then(Value::as_bool)
        == Some(false)
        && !said(&["converge"], &items)
    {
        let reason = solver
            .and_then(|s| s.get("reason"))
            .and_then(Value::as_str)
            .unwrap_or("no reason given");
        items.push((1, "warning".into(), format!("The mechanics solver did not converge ({reason}): the closed shape and every metric are uncertain.")));
    }
    let metrics = report.get("metrics");
    let closed = metrics
        .and_then(|m| m.get("closed"))
        .and_then(Value::as_bool);
    let max_area = metrics
        .and_then(|m| m.get("coaptation_area_mm2"))
        .and_then(|a| a.get("max"))
        .and_then(Value::as_f64);
    if max_area == Some(0.0) && !said(&["contact", "coapt"], &items) {
        items.push((
            1,
            "warning".into(),
            "No contact at all: no leaflet touches another.".into(),
        ));
    } else if closed == Some(false) && !said(&["close", "contact", "coapt"], &items) {
        items.push((
            1,
            "warning".into(),
            "The leaflets do not all meet: there is no central coaptation.".into(),
        ));
    }
    let meets_all = report
        .get("verdict")
        .and_then(|v| v.get("meets_all_criteria"))
        .and_then(Value::as_bool);
    let failed = criteria_names(criteria, Some(false));
    if meets_all == Some(true) && !failed.is_empty() {
        items.push((
            0,
            "error".into(),
            format!(
                "Inconsistent report: the verdict says all criteria are met, but these fail: {}.",
                failed.join(", ")
            ),
        ));
    }
    items.sort_by_key(|(rank, _, _)| *rank); // stable: order within a severity kept
    if items.is_empty() {
        h.push_str("<p>No findings.</p>\n");
    } else {
        h.push_str("<ul class=\"findings\">\n");
        for (rank, sev, msg) in &items {
            let class = ["sev-error", "sev-warning", "sev-info", "sev-info"][*rank as usize];
            let _ = writeln!(
                h,
                "<li><span class=\"tag {class}\">{}</span> {}</li>",
                esc(&sev.to_uppercase()),
                esc(msg)
            );
        }
        h.push_str("</ul>\n");
    }
    h.push_str("</section>\n");
}

fn key_metrics(h: &mut String, m: Option<&Value>) {
    h.push_str("<section id=\"metrics\">\n<h2>Key metrics</h2>\n");
    h.push_str("<table>\n<thead><tr><th>Quantity</th><th>Value</th><th>Definition</th></tr></thead>\n<tbody>\n");
    let get = |k: &str| m.and_then(|m| m.get(k));
    let area = get("coaptation_area_mm2");
    // "Valve closed" is a criterion, judged above; it is not repeated here.
    let rows: [(&str, String, &str); 18] = [
        (
            "Coaptation height",
            mm(get("coaptation_height_mm")),
            "largest axial extent of the zone where two leaflets touch",
        ),
        (
            "Central coaptation height",
            mm(get("central_coaptation_height_mm")),
            "axial extent of the zone where all three leaflets touch",
        ),
        (
            "Effective height (judged)",
            mm(get("effective_height_mm")),
            "annulus plane to the central free-edge point, along the axis, at the pressure below: the seeds' 3 mmHg when that closure was run, else the closing pressure",
        ),
        (
            "… judged at (mmHg)",
            num_text(get("effective_height_pressure_mmhg")),
            "pressure of the closure the judged effective height is read on",
        ),
        (
            "Effective height, closing pressure",
            mm(get("effective_height_closing_pressure_mm")),
            "the same point on the closure at the closing (diastolic) pressure",
        ),
        (
            "Effective height, low pressure",
            mm(get("effective_height_low_pressure_mm")),
            "the same point on the extra low-pressure closure (seeds 000/002: h<sub>E</sub> at 3 mmHg); not measured unless the close config sets effective_height_pressure",
        ),
        (
            "h<sub>C-C</sub>",
            mm(get("h_cc_mm")),
            "axial extent of a pair's zone 5 mm from the axis (mean over the pairs)",
        ),
        (
            "h<sub>avr</sub>",
            mm(get("h_avr_mm")),
            "coaptation area / free-edge length",
        ),
        (
            "NCCA",
            percent(get("ncca")),
            "normalised coaptation area: coaptation area / cusp area",
        ),
        (
            "Coaptation area, largest leaflet",
            mm2(area.and_then(|a| a.get("max"))),
            "the largest of the three leaflets' coaptation areas (a leaflet's area in contact with another leaflet)",
        ),
        (
            "Coaptation area, smallest leaflet",
            mm2(area.and_then(|a| a.get("min"))),
            "the smallest of the three leaflets' coaptation areas",
        ),
        (
            "Regurgitant orifice area",
            mm2(get("regurgitant_orifice_area_mm2")),
            "lumen cross-section not covered by the closed leaflets, seen along the axis",
        ),
        (
            "Coaptation above the VAJ",
            boolean(get("coaptation_above_vaj")),
            "the central coaptation (all three leaflets touching) lies above the ventriculo-aortic junction",
        ),
        (
            "Lowest free edge above annulus",
            mm(get("lowest_free_edge_above_annulus_mm")),
            "axial distance, annulus plane to the lowest free-edge point",
        ),
        (
            "Lowest coaptation above annulus",
            mm(get("lowest_coaptation_above_annulus_mm")),
            "axial distance, annulus plane to the lowest point where two leaflets touch (next to the commissures too)",
        ),
        (
            "Lowest central coaptation above annulus",
            mm(get("lowest_central_coaptation_above_annulus_mm")),
            "axial distance, annulus plane to the lowest point where all three leaflets touch",
        ),
        (
            "Lowest commissure tip above annulus",
            mm(get("lowest_commissure_above_annulus_mm")),
            "axial distance, annulus plane to the lowest commissure (valve.json)",
        ),
        (
            "STJ above annulus",
            mm(get("stj_above_annulus_mm")),
            "axial distance, annulus plane to the sinotubular junction's section (valve.json)",
        ),
    ];
    for (name, value, def) in rows {
        // `name` and `def` are this file's constants (`name` may hold markup).
        let _ = writeln!(
            h,
            "<tr><th scope=\"row\">{name}</th><td class=\"num\">{}</td><td>{def}</td></tr>",
            esc(&value)
        );
    }
    h.push_str("</tbody>\n</table>\n</section>\n");
}

fn leaflets(h: &mut String, report: &Value) {
    h.push_str("<section id=\"leaflets\">\n<h2>Per leaflet</h2>\n");
    let list = array(report.get("leaflets"));
    let metrics = report.get("metrics");
    if list.is_empty() {
        h.push_str("<p>No per-leaflet values in the report.</p>\n</section>\n");
        return;
    }
    // Each column's definition is one hover away (title) and in the
    // footnote below the table.
    h.push_str("<table>\n<thead><tr><th>Leaflet</th>");
    for (head, _) in LEAFLET_COLUMNS {
        let _ = write!(h, "<th title=\"{}\">{}</th>", esc(&plain(head)), head);
    }
    h.push_str("</tr></thead>\n<tbody>\n");
    for (i, l) in list.iter().enumerate() {
        let index = l
            .get("index")
            .and_then(Value::as_u64)
            .unwrap_or(i as u64 + 1);
        // `cusp_area_closed_mm2` is only in the metrics block, by 1-based index.
        let cusp = metrics
            .and_then(|m| m.get("cusp_area_closed_mm2"))
            .and_then(|a| a.get(index.checked_sub(1)? as usize));
        let cells = [
            fixed(num(l.get("coaptation_area_mm2")), 1),
            fixed(num(l.get("free_edge_length_mm")), 1),
            fixed(num(l.get("leaflet_area_mm2")), 1),
            fixed(num(cusp), 1),
            fixed(num(l.get("billowing_mm")), 2),
            fixed(num(l.get("h_avr_mm")), 2),
            percent(l.get("ncca")),
        ];
        let _ = write!(h, "<tr><th scope=\"row\">{index}</th>");
        for c in cells {
            let _ = write!(h, "<td class=\"num\">{}</td>", esc(&c));
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</tbody>\n</table>\n<p class=\"meta\">");
    let notes: Vec<String> = LEAFLET_COLUMNS
        .iter()
        .map(|(head, def)| format!("<strong>{head}</strong>: {}", esc(def)))
        .collect();
    h.push_str(&notes.join("; "));
    h.push_str(".</p>\n</section>\n");
}

/// The per-leaflet table's columns (HTML heading, definition).
const LEAFLET_COLUMNS: [(&str, &str); 7] = [
    (
        "Coaptation area (mm²)",
        "area of the closed leaflet in contact with another leaflet (within the contact margin)",
    ),
    (
        "Free-edge length (mm)",
        "length of the closed leaflet's free edge",
    ),
    ("Leaflet area (mm²)", "area of the flat template, as cut"),
    (
        "Cusp area, closed (mm²)",
        "area of the whole leaflet in its closed state (less than the template's where placing gathered it, more where the load stretched it)",
    ),
    (
        "Billowing (mm)",
        "depth of the leaflet's lowest point below the plane through the three leaflets' lowest sutured points (the annular plane at the nadirs); 0 when it stays above",
    ),
    (
        "h<sub>avr</sub> (mm)",
        "coaptation area / free-edge length (seed 000)",
    ),
    (
        "NCCA",
        "normalised cusp coaptation area: coaptation area / closed cusp area (seed 000)",
    ),
];

/// Text of an HTML fragment without its tags, for a title attribute.
fn plain(html: &str) -> String {
    let mut out = String::with_capacity(html.len());
    let mut in_tag = false;
    for ch in html.chars() {
        match ch {
            '<' => in_tag = true,
            '>' => in_tag = false,
            c if !in_tag => out.push(c),
            _ => {}
        }
    }
    out
}

fn conventions(h: &mut String, c: Option<&Value>) {
    h.push_str("<section id=\"conventions\">\n<h2>The two measurement conventions</h2>\n<div class=\"conventions\">\n");
    // Seeds' group.
    let s = c.and_then(|c| c.get("seeds"));
    h.push_str("<div id=\"convention-seeds\">\n<h3>Contact margin (the seeds' group)</h3>\n");
    description(h, s);
    let _ = writeln!(
        h,
        "<p>Contact margin {}; partially touching triangles refined {} time(s).</p>",
        esc(&mm(s.and_then(|s| s.get("margin_mm")))),
        esc(&s
            .and_then(|s| s.get("refinement"))
            .and_then(Value::as_u64)
            .map_or(DASH.to_string(), |r| r.to_string())),
    );
    let pairs = array(s.and_then(|s| s.get("pairs")));
    if pairs.is_empty() {
        h.push_str("<p>No leaflet pairs measured.</p>\n");
    } else {
        h.push_str("<table>\n<thead><tr><th>Pair</th><th>Coaptation height (mm)</th><th>Area on first (mm²)</th><th>Area on second (mm²)</th></tr></thead>\n<tbody>\n");
        for p in pairs {
            let area = p.get("area_mm2");
            let _ = writeln!(
                h,
                "<tr><th scope=\"row\">{}</th><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
                esc(&pair_label(p.get("leaflets"))),
                esc(&fixed(num(p.get("coaptation_height_mm")), 2)),
                esc(&fixed(num(area.and_then(|a| a.get(0))), 1)),
                esc(&fixed(num(area.and_then(|a| a.get(1))), 1)),
            );
        }
        h.push_str("</tbody>\n</table>\n");
    }
    h.push_str("</div>\n");
    // SlicerHeart.
    let s = c.and_then(|c| c.get("slicerheart"));
    h.push_str(
        "<div id=\"convention-slicerheart\">\n<h3>Base line to margin line (SlicerHeart)</h3>\n",
    );
    description(h, s);
    let pairs = array(s.and_then(|s| s.get("pairs")));
    if pairs.is_empty() {
        h.push_str("<p>No leaflet pairs measured.</p>\n");
    } else {
        h.push_str(
            "<table>\n<thead><tr><th>Pair</th><th>Area (mm²)</th><th>Height (mm): min · mean · max<br>\
             percentiles 10 · 25 · 50 · 75 · 90</th></tr></thead>\n<tbody>\n",
        );
        for p in pairs {
            let heights = match p.get("height_mm") {
                Some(Value::Object(o)) => {
                    let line = |keys: &[&str]| {
                        keys.iter()
                            .map(|k| esc(&fixed(num(o.get(*k)), 2)))
                            .collect::<Vec<_>>()
                            .join(" · ")
                    };
                    format!(
                        "{}<br>{}",
                        line(&["min", "mean", "max"]),
                        line(&["p10", "p25", "p50", "p75", "p90"])
                    )
                }
                _ => NOT_MEASURED.to_string(),
            };
            let _ = writeln!(
                h,
                "<tr><th scope=\"row\">{}</th><td class=\"num\">{}</td><td>{heights}</td></tr>",
                esc(&pair_label(p.get("leaflets"))),
                esc(&fixed(num(p.get("area_mm2")), 1)),
            );
        }
        h.push_str("</tbody>\n</table>\n");
    }
    h.push_str("</div>\n</div>\n</section>\n");
}

fn figures_section(h: &mut String, figures: &[Figure], first_number: usize, scene: Option<&Scene>) {
    h.push_str("<section id=\"figures\">\n<h2>Figures</h2>\n");
    if let Some(s) = scene {
        h.push_str(&view3d::markup(s));
    }
    if figures.is_empty() && scene.is_none() {
        h.push_str("<p>No figures.</p>\n");
    }
    let mut used: Vec<String> = Vec::new();
    for (n, f) in figures.iter().enumerate() {
        figure(h, f, first_number + n, &mut used);
    }
    h.push_str("</section>\n");
}

/// One figure with a page-unique id and its number.
fn figure(h: &mut String, f: &Figure, number: usize, used: &mut Vec<String>) {
    let base = format!("fig-{}", anchor(&f.id));
    let mut id = base.clone();
    let mut k = 1;
    while used.contains(&id) {
        k += 1;
        id = format!("{base}-{k}");
    }
    used.push(id.clone());
    let _ = writeln!(h, "<figure id=\"{id}\">");
    if f.png.starts_with(b"\x89PNG\r\n\x1a\n") {
        let _ = write!(
            h,
            "<img src=\"data:image/png;base64,{}\" alt=\"{}\"",
            BASE64.encode(&f.png),
            esc(&f.title)
        );
        if f.width > 0 && f.height > 0 {
            let _ = write!(h, " width=\"{}\" height=\"{}\"", f.width, f.height);
        }
        h.push_str(">\n");
    } else {
        h.push_str("<div class=\"missing\">Image missing: the figure's data is not a PNG.</div>\n");
    }
    let _ = writeln!(
        h,
        "<figcaption><strong>Figure {}. {}</strong> {}</figcaption>\n</figure>",
        number,
        esc(&f.title),
        esc(&f.caption)
    );
}

/// The leaflet-size sweep of `coapt design`, when the report has one: the
/// recommendation and its reason first, then every size, then the charts.
fn sizing(h: &mut String, d: &Value, figures: &[Figure]) {
    h.push_str("<section id=\"sizing\">\n<h2>Leaflet sizing</h2>\n");
    let recommended = d.get("recommended_size").and_then(Value::as_u64);
    let shown = d.get("shown_size").and_then(Value::as_u64);
    let _ = writeln!(
        h,
        "<div class=\"verdict {}\"><p><strong>{}</strong></p><p>{}</p></div>",
        if recommended.is_some() { "ok" } else { "bad" },
        match recommended {
            Some(s) => format!("Recommended: Ozaki size {s} for all three leaflets."),
            None => "No size of the sweep meets every criterion.".to_string(),
        },
        esc(&text_or(d.get("reason"), "")),
    );
    if let Some(s) = shown {
        let _ = writeln!(
            h,
            "<p>The rest of this report is the closure with size {s} leaflets; every size has its own report in <code>size-NN/report.html</code> beside this page.</p>"
        );
    }
    let ic = array(d.get("intercommissural_distance_mm"));
    if ic.len() == 3 {
        let _ = writeln!(
            h,
            "<p>Intercommissural distances (what the sizer measures in the opened root): C1–C2 {}, C2–C3 {}, C3–C1 {}.</p>",
            esc(&mm(ic.first())),
            esc(&mm(ic.get(1))),
            esc(&mm(ic.get(2)))
        );
    }
    h.push_str(
        "<table>\n<thead><tr><th>Size</th><th>Leaflet area (mm²)</th><th>Coaptation height (mm)</th>\
         <th>Central coaptation (mm)</th><th>Effective height (mm)</th><th>Criteria met</th><th>Result</th></tr></thead>\n<tbody>\n",
    );
    for s in array(d.get("sizes")) {
        let size = s.get("size").and_then(Value::as_u64);
        let mark = if size.is_some() && size == recommended {
            " class=\"recommended\""
        } else {
            ""
        };
        let result = match s.get("status").and_then(Value::as_str) {
            Some("measured") => {
                let failures: Vec<String> = array(s.get("failures"))
                    .iter()
                    .filter_map(|f| f.as_str().map(esc))
                    .collect();
                if failures.is_empty() {
                    result_tag(Some(true)).to_string()
                } else {
                    format!("{} {}", result_tag(Some(false)), failures.join("; "))
                }
            }
            _ => format!(
                "<span class=\"tag na\">NOT COMPUTED</span> {}",
                esc(&text_or(s.get("error"), "no reason recorded"))
            ),
        };
        let met = match (
            s.get("criteria_passed").and_then(Value::as_u64),
            s.get("criteria_judged").and_then(Value::as_u64),
        ) {
            (Some(p), Some(j)) => format!("{p} / {j}"),
            _ => DASH.to_string(),
        };
        let _ = writeln!(
            h,
            "<tr{mark}><th scope=\"row\">{}</th><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td></tr>",
            size.map_or(DASH.to_string(), |s| s.to_string()),
            esc(&fixed(num(s.get("leaflet_area_mm2")), 0)),
            esc(&fixed(num(s.get("coaptation_height_mm")), 2)),
            esc(&fixed(num(s.get("central_coaptation_height_mm")), 2)),
            esc(&fixed(num(s.get("effective_height_mm")), 2)),
            esc(&met),
            result,
        );
    }
    h.push_str("</tbody>\n</table>\n");
    let mut used = Vec::new();
    for (n, f) in figures.iter().enumerate() {
        figure(h, f, n + 1, &mut used);
    }
    h.push_str("</section>\n");
}

fn solver(h: &mut String, s: Option<&Value>) {
    h.push_str("<section id=\"solver\">\n<h2>Solver</h2>\n<table class=\"narrow\">\n<tbody>\n");
    let get = |k: &str| s.and_then(|s| s.get(k));
    let converged = match get("converged").and_then(Value::as_bool) {
        Some(true) => "<span class=\"tag pass\">CONVERGED</span>",
        Some(false) => "<span class=\"tag fail\">NOT CONVERGED</span>",
        None => "<span class=\"tag na\">UNKNOWN</span>",
    };
    let _ = writeln!(
        h,
        "<tr><th scope=\"row\">Converged</th><td>{converged}</td></tr>"
    );
    let iterations = get("iterations")
        .and_then(Value::as_u64)
        .map_or(DASH.to_string(), |i| i.to_string());
    let _ = writeln!(
        h,
        "<tr><th scope=\"row\">Iterations</th><td>{}</td></tr>",
        esc(&iterations)
    );
    let residual = num(get("residual_n")).map_or(DASH.to_string(), |r| format!("{r:.3e} N"));
    let _ = writeln!(
        h,
        "<tr><th scope=\"row\">Final residual ‖R‖₂ (all free-node forces)</th><td>{}</td></tr>",
        esc(&residual)
    );
    let _ = writeln!(
        h,
        "<tr><th scope=\"row\">Stop reason</th><td>{}</td></tr>",
        esc(&text_or(get("reason"), DASH))
    );
    h.push_str("</tbody>\n</table>\n</section>\n");
}

fn timing(h: &mut String, t: Option<&Value>) {
    h.push_str("<section id=\"timing\">\n<h2>Time per stage</h2>\n");
    let Some(Value::Object(map)) = t else {
        h.push_str("<p>No timings in the report.</p>\n</section>\n");
        return;
    };
    let mut keys: Vec<&String> = map.keys().collect();
    keys.sort_by_key(|k| {
        (
            STAGE_ORDER
                .iter()
                .position(|s| s == k)
                .unwrap_or(STAGE_ORDER.len()),
            k.as_str(),
        )
    });
    h.push_str("<table class=\"narrow\">\n<thead><tr><th>Stage</th><th>Seconds</th></tr></thead>\n<tbody>\n");
    let mut total = 0.0;
    for k in keys {
        let s = num(map.get(k));
        total += s.unwrap_or(0.0);
        let _ = writeln!(
            h,
            "<tr><th scope=\"row\">{}</th><td class=\"num\">{}</td></tr>",
            esc(k),
            esc(&fixed(s, 2))
        );
    }
    let _ = writeln!(
        h,
        "<tr><th scope=\"row\">Total</th><td class=\"num\"><strong>{}</strong></td></tr>",
        esc(&fixed(Some(total), 2))
    );
    h.push_str("</tbody>\n</table>\n</section>\n");
}

fn provenance(h: &mut String, report: &Value) {
    h.push_str("<section id=\"provenance\">\n<h2>Provenance</h2>\n");
    let _ = writeln!(
        h,
        "<p>coapt version {} · report schema {} · frame {}</p>",
        esc(&text_or(report.get("coapt_version"), DASH)),
        esc(&text_or(report.get("schema"), DASH)),
        esc(&text_or(report.get("frame"), DASH)),
    );
    h.push_str("<h3>Input files</h3>\n");
    match report.get("inputs") {
        Some(Value::Object(map)) if !map.is_empty() => {
            h.push_str("<table>\n<thead><tr><th>Input</th><th>Path</th><th>Bytes</th><th>blake3</th></tr></thead>\n<tbody>\n");
            for (k, v) in sorted(map) {
                let bytes = v
                    .get("bytes")
                    .and_then(Value::as_u64)
                    .map_or(DASH.to_string(), |b| b.to_string());
                let _ = writeln!(
                    h,
                    "<tr><th scope=\"row\">{}</th><td class=\"mono\">{}</td><td class=\"num\">{}</td><td class=\"mono\">{}</td></tr>",
                    esc(k),
                    esc(&text_or(v.get("path"), DASH)),
                    esc(&bytes),
                    esc(&text_or(v.get("blake3"), DASH)),
                );
            }
            h.push_str("</tbody>\n</table>\n");
        }
        _ => h.push_str("<p>No input files recorded.</p>\n"),
    }
    h.push_str("<h3>Parameters</h3>\n");
    match report.get("parameters") {
        Some(Value::Object(map)) if !map.is_empty() => {
            h.push_str(
                "<table>\n<thead><tr><th>Parameter</th><th>Value</th></tr></thead>\n<tbody>\n",
            );
            let mut rows = Vec::new();
            flatten("", &Value::Object(map.clone()), &mut rows);
            for (k, shown) in rows {
                let _ = writeln!(
                    h,
                    "<tr><th scope=\"row\">{}</th><td class=\"mono\">{}</td></tr>",
                    esc(&k),
                    esc(&shown)
                );
            }
            h.push_str("</tbody>\n</table>\n");
        }
        _ => h.push_str("<p>No parameters recorded.</p>\n"),
    }
    h.push_str("</section>\n");
}

// ---------------------------------------------------------------- helpers

/// Parameters as rows "closure.model.mu: 900 kPa": nested objects by dotted
/// key, the unit a key ends in (`_mm`, `_kpa`, …) moved to its value, and
/// parameters left unset (their value is derived and shown under its own
/// key, e.g. margin → margin 0.9 mm) left out.
fn flatten(prefix: &str, v: &Value, out: &mut Vec<(String, String)>) {
    const UNITS: [(&str, &str); 9] = [
        ("_n_per_mm", "N/mm"),
        ("_mmhg", "mmHg"),
        ("_mm2", "mm²"),
        ("_mm", "mm"),
        ("_kpa", "kPa"),
        ("_mpa", "MPa"),
        ("_deg", "°"),
        ("_s", "s"),
        ("_n", "N"),
    ];
    match v {
        Value::Object(map) => {
            for (k, v) in sorted(map) {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, v, out);
            }
        }
        Value::String(s) if s == "unset" => {}
        Value::String(s) => out.push((prefix.to_string(), s.clone())),
        Value::Number(n) => {
            let unit = UNITS.iter().find(|(suffix, _)| prefix.ends_with(suffix));
            match unit {
                Some((suffix, unit)) => out.push((
                    prefix[..prefix.len() - suffix.len()].to_string(),
                    with_unit(&shortest(n.as_f64()), unit),
                )),
                None => out.push((prefix.to_string(), shortest(n.as_f64()))),
            }
        }
        other => out.push((prefix.to_string(), canonical(other))),
    }
}

/// Escape text for HTML element content and quoted attribute values; C0
/// control characters other than tab and newlines become U+FFFD.
pub fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 8);
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            '\t' | '\n' | '\r' => out.push(ch),
            c if c.is_control() => out.push('\u{FFFD}'),
            c => out.push(c),
        }
    }
    out
}

/// A string value, or `default` when missing or not a string.
fn text_or(v: Option<&Value>, default: &str) -> String {
    v.and_then(Value::as_str).unwrap_or(default).to_string()
}

fn num_text(v: Option<&Value>) -> String {
    match v.and_then(Value::as_f64) {
        Some(x) => shortest(Some(x)),
        None => NOT_MEASURED.to_string(),
    }
}

fn array(v: Option<&Value>) -> &[Value] {
    v.and_then(Value::as_array).map_or(&[], Vec::as_slice)
}

fn num(v: Option<&Value>) -> Option<f64> {
    v.and_then(Value::as_f64).filter(|x| x.is_finite())
}

/// `x` with `decimals` digits, "—" when absent; never "-0.00".
fn fixed(x: Option<f64>, decimals: usize) -> String {
    match x {
        Some(x) if x.is_finite() => {
            let s = format!("{x:.decimals$}");
            if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
                s[1..].to_string()
            } else {
                s
            }
        }
        _ => DASH.to_string(),
    }
}

/// The shortest decimal that reads back as `x` (thresholds: "4", "9.5").
fn shortest(x: Option<f64>) -> String {
    x.filter(|x| x.is_finite())
        .map_or(DASH.to_string(), |x| format!("{x}"))
}

fn with_unit(value: &str, unit: &str) -> String {
    if unit.is_empty() || value == DASH {
        value.to_string()
    } else {
        format!("{value} {unit}")
    }
}

fn mm(v: Option<&Value>) -> String {
    num(v).map_or(NOT_MEASURED.to_string(), |x| {
        with_unit(&fixed(Some(x), 2), "mm")
    })
}

fn mm2(v: Option<&Value>) -> String {
    num(v).map_or(NOT_MEASURED.to_string(), |x| {
        with_unit(&fixed(Some(x), 1), "mm²")
    })
}

/// A fraction shown as a percentage.
fn percent(v: Option<&Value>) -> String {
    num(v).map_or(NOT_MEASURED.to_string(), |x| {
        format!("{} %", fixed(Some(100.0 * x), 1))
    })
}

fn boolean(v: Option<&Value>) -> String {
    v.and_then(Value::as_bool)
        .map_or(NOT_MEASURED.to_string(), |b| yes_no(b).to_string())
}

fn yes_no(b: bool) -> &'static str {
    if b { "yes" } else { "no" }
}

fn result_tag(pass: Option<bool>) -> &'static str {
    match pass {
        Some(true) => "<span class=\"tag pass\">&#10004; PASS</span>",
        Some(false) => "<span class=\"tag fail\">&#10008; FAIL</span>",
        None => "<span class=\"tag na\">? NOT MEASURABLE</span>",
    }
}

fn criterion_name(c: &Value) -> String {
    c.get("name")
        .and_then(Value::as_str)
        .or_else(|| c.get("id").and_then(Value::as_str))
        .unwrap_or("(unnamed criterion)")
        .to_string()
}

/// Names of the criteria whose `pass` is `want` (`None`: null or missing).
fn criteria_names(criteria: &[Value], want: Option<bool>) -> Vec<String> {
    criteria
        .iter()
        .filter(|c| c.get("pass").and_then(Value::as_bool) == want)
        .map(criterion_name)
        .collect()
}

fn severity_rank(s: &str) -> u8 {
    match s {
        "error" => 0,
        "warning" => 1,
        "info" => 2,
        _ => 3,
    }
}

fn description(h: &mut String, v: Option<&Value>) {
    if let Some(d) = v.and_then(|v| v.get("description")).and_then(Value::as_str) {
        let _ = writeln!(h, "<p>{}</p>", esc(d));
    }
}

fn pair_label(v: Option<&Value>) -> String {
    let l = array(v);
    let idx = |i: usize| {
        l.get(i)
            .and_then(Value::as_u64)
            .map_or("?".to_string(), |x| x.to_string())
    };
    format!("{}–{}", idx(0), idx(1))
}

/// An HTML id made of `[A-Za-z0-9_-]` from a figure id.
fn anchor(id: &str) -> String {
    let s: String = id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '-'
            }
        })
        .collect();
    if s.is_empty() {
        "figure".to_string()
    } else {
        s
    }
}

/// Compact JSON text with object keys sorted, so equal values print alike
/// whatever order their keys were inserted in.
fn canonical(v: &Value) -> String {
    match v {
        Value::Object(o) => {
            let items: Vec<String> = sorted(o)
                .into_iter()
                .map(|(k, x)| format!("{}:{}", Value::String(k.clone()), canonical(x)))
                .collect();
            format!("{{{}}}", items.join(","))
        }
        Value::Array(a) => format!(
            "[{}]",
            a.iter().map(canonical).collect::<Vec<_>>().join(",")
        ),
        other => other.to_string(),
    }
}

fn sorted(map: &Map<String, Value>) -> Vec<(&String, &Value)> {
    let mut v: Vec<_> = map.iter().collect();
    v.sort_by(|a, b| a.0.cmp(b.0));
    v
}

/// "N1 right coronary (ostium 20.7 mm above the annulus), …; named by the
/// coronary ostia in the CT" from the landmarks stage's sinuses.
fn sinus_names(lm: Option<&Value>) -> Option<String> {
    let sinuses = array(lm.and_then(|l| l.get("sinuses")));
    if sinuses.is_empty() {
        return None;
    }
    let each: Vec<String> = sinuses
        .iter()
        .map(|s| {
            let name = text_or(s.get("name"), DASH).replace('_', "-");
            let mut t = format!("{} {}", esc(&text_or(s.get("nadir"), "?")), esc(&name));
            if let Some(h) = num(s.get("ostium").and_then(|o| o.get("height_mm"))) {
                let _ = write!(t, " (ostium {} mm above the annulus)", fixed(Some(h), 1));
            }
            t
        })
        .collect();
    let naming = lm.and_then(|l| l.get("sinus_naming"));
    let how = match naming.and_then(|n| n.get("by")).and_then(Value::as_str) {
        Some("coronary_ostia") => "named by the coronary ostia seen in the CT",
        _ if naming
            .and_then(|n| n.get("ct_searched"))
            .and_then(Value::as_bool)
            == Some(true) =>
        {
            "named by position (the CT did not show two coronary ostia): the sinus facing anterior taken for the right-coronary one"
        }
        _ => {
            "named by position (no CT searched for the coronary ostia): the sinus facing anterior taken for the right-coronary one"
        }
    };
    let leaflets: Vec<String> = array(lm.and_then(|l| l.get("leaflet_sinuses")))
        .iter()
        .map(|n| esc(&text_or(Some(n), DASH).replace('_', "-")))
        .collect();
    let sewn = if leaflets.len() == 3 {
        format!(
            "; leaflets 1 / 2 / 3 sewn in the {} sinuses",
            leaflets.join(" / ")
        )
    } else {
        String::new()
    };
    Some(format!("{}; {how}{sewn}", each.join(", ")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::png::{Rgb, encode};
    use serde_json::json;

    fn example() -> Value {
        serde_json::from_str(include_str!("../../schemas/report.example.json")).unwrap()
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
        let page = render(&example(), &[figure("top_view", 40, 30)], None);
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
        let page = render(&r, &[], None);
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
        let page = render(&example(), &[f.clone(), f.clone(), bad], None);
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
        assert!(render(&example(), &[], None).contains("<p>No figures.</p>"));
    }

    /// Replace every string value by `s` (keys are kept).
    fn poison(v: &Value, s: &str) -> Value {
        match v {
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
        r["criteria"][0]["comparison"] = json!(evil);
        let mut f = figure(evil, 4, 4);
        f.title = evil.into();
        f.caption = evil.into();
        let page = render(&r, &[f], None);
        assert_whole(&page);
        assert!(!page.contains("<script"), "raw markup from the JSON");
        assert!(!page.contains('\u{7}'));
        assert!(
            page.contains("&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;&amp;&quot;\u{FFFD}")
        );
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

    /// Any key missing, null, or of any other type: the page is still whole
    /// and shows no raw markup.
    #[test]
    fn survives_every_missing_key_and_wrong_type() {
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
        let mut n = 0;
        for p in &all {
            for w in std::iter::once(None).chain(replacements.iter().map(Some)) {
                let page = render(&mutate(&ex, p, w), &[], None);
                assert_whole(&page);
                assert!(!page.contains("<i>"), "{p:?} {w:?}");
                n += 1;
            }
        }
        assert!(n > 2000);
        for v in [
            json!(null),
            json!([]),
            json!("x"),
            json!(3),
            json!({}),
            json!({"metrics": [], "criteria": {}}),
        ] {
            let page = render(&v, &[], None);
            assert_whole(&page);
            assert!(page.contains("Closure could not be determined."));
            assert!(page.contains("not measured"));
        }
    }

    #[test]
    fn empty_report_says_what_is_missing() {
        let page = render(&json!({}), &[], None);
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
        let page = render(&r, &[], None);
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
        let page = render(&r, &[], None);
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
        let page = render(&r, &[], None);
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
        let first_difference =
            |x: &str, y: &str| x.bytes().zip(y.bytes()).position(|(p, q)| p != q);
        let (pa, pa2, pb) = (
            render(&a, &figs, None),
            render(&a, &figs, None),
            render(&b, &figs, None),
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
        use crate::report::figures::test_valve::synthetic_valve;
        let (v, contact) = synthetic_valve(6);
        let scene = view3d::build(&v, &contact, None).unwrap();
        let figs = [figure("valve_top", 8, 4)];
        let page = render(&example(), &figs, Some(&scene));
        assert_whole(&page);
        assert_eq!(page, render(&example(), &figs, Some(&scene)));
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
        let plain = render(&example(), &figs, None);
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
        assert_eq!(percent(Some(&json!(0.246))), "24.6 %");
        assert_eq!(mm(Some(&json!("5"))), NOT_MEASURED);
    }
}
