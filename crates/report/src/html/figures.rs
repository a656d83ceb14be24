//! The figures (embedded PNGs and the interactive view) and the sizing
//! sweep's table beside its charts.

use std::fmt::Write as _;

use crate::Figure;
use crate::view3d::{self, Scene};
use base64::{Engine as _, engine::general_purpose::STANDARD as BASE64};
use coapt_io::design_json::{Closure, ClosureStatus, Design};

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
fn closure_result(c: &Closure) -> String {
    match c.status {
        ClosureStatus::Measured => {
            if c.failures.is_empty() {
                result_tag(Some(true)).to_string()
            } else {
                let failures: Vec<String> = c.failures.iter().map(|f| esc(f)).collect();
                format!("{} {}", result_tag(Some(false)), failures.join("; "))
            }
        }
        ClosureStatus::Failed => format!(
            "<span class=\"tag na\">NOT COMPUTED</span> {}",
            esc(c.error.as_deref().unwrap_or("no reason recorded"))
        ),
    }
}

/// The leaflet-size sweep of `coapt design`, when the report has one: the
/// recommendation and its reason first, then every size, then the charts.
pub(super) fn sizing(h: &mut String, d: &Design, figures: &[Figure]) {
    h.push_str("<section id=\"sizing\">\n<h2>Leaflet sizing</h2>\n");
    let recommended = d.recommended_size;
    let _ = writeln!(
        h,
        "<div class=\"verdict {}\"><p><strong>{}</strong></p><p>{}</p></div>",
        if recommended.is_some() { "ok" } else { "bad" },
        match recommended {
            Some(s) => format!("Recommended: Ozaki size {s} for all three leaflets."),
            None => "No size of the sweep meets every criterion.".to_string(),
        },
        esc(&d.reason),
    );
    if let Some(s) = d.shown_size {
        let _ = writeln!(
            h,
            "<p>The rest of this report is the closure with size {s} leaflets; every size has its own report in <code>size-NN/report.html</code> beside this page.</p>"
        );
    }
    if let Some([a, b, c]) = d.intercommissural_distance_mm.as_deref() {
        let _ = writeln!(
            h,
            "<p>Intercommissural distances (what the sizer measures in the opened root): C1–C2 {}, C2–C3 {}, C3–C1 {}.</p>",
            esc(&mm(Some(*a))),
            esc(&mm(Some(*b))),
            esc(&mm(Some(*c)))
        );
    }
    if let Some(rule) = &d.ozaki_rule {
        let _ = writeln!(h, "<p>{}</p>", esc(rule));
    }
    if let Some(c) = &d.ozaki_rule_closure {
        let run = or(&c.run, "ozaki-rule");
        let said = match c.status {
            ClosureStatus::Measured => {
                let mm = |x: Option<f64>| x.map_or("none".to_string(), |v| format!("{v:.2} mm"));
                format!(
                    "central coaptation {}, effective height {}; {}",
                    mm(c.central_coaptation_height_mm),
                    mm(c.effective_height_mm),
                    closure_result(c)
                )
            }
            ClosureStatus::Failed => closure_result(c),
        };
        let _ = writeln!(
            h,
            "<p>Closed as Ozaki&#39;s rule cuts it (<a href=\"{0}/report.html\">{0}/report.html</a>): {said}.</p>",
            esc(run)
        );
    }
    h.push_str(
        "<table>\n<thead><tr><th>Size</th><th>Leaflet area (mm²)</th><th>Coaptation height (mm)</th>\
         <th>Central coaptation (mm)</th><th>Effective height (mm)</th><th>Criteria met</th><th>Result</th></tr></thead>\n<tbody>\n",
    );
    for s in &d.sizes {
        let mark = if s.size.is_some() && s.size == recommended {
            " class=\"recommended\""
        } else {
            ""
        };
        let met = match (s.criteria_passed, s.criteria_judged) {
            (Some(p), Some(j)) => format!("{p} / {j}"),
            _ => DASH.to_string(),
        };
        let _ = writeln!(
            h,
            "<tr{mark}><th scope=\"row\">{}</th><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td></tr>",
            s.size.map_or(DASH.to_string(), |s| s.to_string()),
            esc(&fixed(s.leaflet_area_mm2, 0)),
            esc(&fixed(s.coaptation_height_mm, 2)),
            esc(&fixed(s.central_coaptation_height_mm, 2)),
            esc(&fixed(s.effective_height_mm, 2)),
            esc(&met),
            closure_result(s),
        );
    }
    h.push_str("</tbody>\n</table>\n");
    let mut used = Vec::new();
    for (n, f) in figures.iter().enumerate() {
        figure(h, f, n + 1, &mut used);
    }
    h.push_str("</section>\n");
}
