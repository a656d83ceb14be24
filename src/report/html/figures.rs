//! The figures (embedded PNGs and the interactive view) and the sizing
//! sweep's table beside its charts.

use std::fmt::Write as _;

use base64::{Engine as _, engine::general_purpose::STANDARD as BASE64};
use serde_json::Value;

use crate::report::Figure;
use crate::report::view3d::{self, Scene};

use super::DASH;
use super::format::*;

pub(super) fn figures_section(
    h: &mut String,
    figures: &[Figure],
    first_number: usize,
    scene: Option<&Scene>,
) {
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
pub(super) fn figure(h: &mut String, f: &Figure, number: usize, used: &mut Vec<String>) {
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

/// One closure of the sweep (a size, or Ozaki's rule) judged: its tag and
/// failed criteria, or why it could not be computed.
fn closure_result(c: &Value) -> String {
    match c.get("status").and_then(Value::as_str) {
        Some("measured") => {
            let failures: Vec<String> = array(c.get("failures"))
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
            esc(&text_or(c.get("error"), "no reason recorded"))
        ),
    }
}

/// The leaflet-size sweep of `coapt design`, when the report has one: the
/// recommendation and its reason first, then every size, then the charts.
pub(super) fn sizing(h: &mut String, d: &Value, figures: &[Figure]) {
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
    if let Some(rule) = d.get("ozaki_rule").and_then(Value::as_str) {
        let _ = writeln!(h, "<p>{}</p>", esc(rule));
    }
    if let Some(c) = d.get("ozaki_rule_closure").filter(|c| c.is_object()) {
        let run = text_or(c.get("run"), "ozaki-rule");
        let said = match c.get("status").and_then(Value::as_str) {
            Some("measured") => {
                let mm = |k: &str| {
                    c.get(k)
                        .and_then(Value::as_f64)
                        .map_or("none".to_string(), |v| format!("{v:.2} mm"))
                };
                format!(
                    "central coaptation {}, effective height {}; {}",
                    mm("central_coaptation_height_mm"),
                    mm("effective_height_mm"),
                    closure_result(c)
                )
            }
            _ => closure_result(c),
        };
        let _ = writeln!(
            h,
            "<p>Closed as Ozaki&#39;s rule cuts it (<a href=\"{0}/report.html\">{0}/report.html</a>): {said}.</p>",
            esc(&run)
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
        let result = closure_result(s);
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
