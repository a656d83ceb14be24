//! The numbers: key metrics, per-leaflet values and the two measurement
//! conventions side by side.

use std::fmt::Write as _;

use super::format::*;
use super::header::pair_label;
use super::{DASH, NOT_MEASURED};
use coapt_io::report_json::{Conventions, Metrics, Report, Stats};

pub(super) fn key_metrics(h: &mut String, m: &Metrics) {
    h.push_str("<section id=\"metrics\">\n<h2>Key metrics</h2>\n");
    h.push_str("<table>\n<thead><tr><th>Quantity</th><th>Value</th><th>Definition</th></tr></thead>\n<tbody>\n");
    // "Valve closed" is a criterion, judged above; it is not repeated here.
    let rows: [(&str, String, &str); 18] = [
        (
            "Coaptation height",
            mm(m.coaptation_height_mm),
            "largest axial extent of the zone where two leaflets touch",
        ),
        (
            "Central coaptation height",
            mm(m.central_coaptation_height_mm),
            "axial extent of the zone where all three leaflets touch",
        ),
        (
            "Effective height (judged)",
            mm(m.effective_height_mm),
            "annulus plane to the central free-edge point, along the axis, at the pressure below: the seeds' 3 mmHg when that closure was run, else the closing pressure",
        ),
        (
            "… judged at (mmHg)",
            num_text(m.effective_height_pressure_mmhg),
            "pressure of the closure the judged effective height is read on",
        ),
        (
            "Effective height, closing pressure",
            mm(m.effective_height_closing_pressure_mm),
            "the same point on the closure at the closing (diastolic) pressure",
        ),
        (
            "Effective height, low pressure",
            mm(m.effective_height_low_pressure_mm),
            "the same point on the extra low-pressure closure (seeds 000/002: h<sub>E</sub> at 3 mmHg); not measured unless the close config sets effective_height_pressure",
        ),
        (
            "h<sub>C-C</sub>",
            mm(m.h_cc_mm),
            "axial extent of a pair's zone 5 mm from the axis (mean over the pairs)",
        ),
        (
            "h<sub>avr</sub>",
            mm(m.h_avr_mm),
            "coaptation area / free-edge length",
        ),
        (
            "NCCA",
            percent(m.ncca),
            "normalised coaptation area: coaptation area / cusp area",
        ),
        (
            "Coaptation area, largest leaflet",
            mm2(m.coaptation_area_mm2.max),
            "the largest of the three leaflets' coaptation areas (a leaflet's area in contact with another leaflet)",
        ),
        (
            "Coaptation area, smallest leaflet",
            mm2(m.coaptation_area_mm2.min),
            "the smallest of the three leaflets' coaptation areas",
        ),
        (
            "Regurgitant orifice area",
            mm2(m.regurgitant_orifice_area_mm2),
            "lumen cross-section not covered by the closed leaflets, seen along the axis",
        ),
        (
            "Coaptation above the VAJ",
            boolean(m.coaptation_above_vaj),
            "the central coaptation (all three leaflets touching) lies above the ventriculo-aortic junction",
        ),
        (
            "Lowest free edge above annulus",
            mm(m.lowest_free_edge_above_annulus_mm),
            "axial distance, annulus plane to the lowest free-edge point",
        ),
        (
            "Lowest coaptation above annulus",
            mm(m.lowest_coaptation_above_annulus_mm),
            "axial distance, annulus plane to the lowest point where two leaflets touch (next to the commissures too)",
        ),
        (
            "Lowest central coaptation above annulus",
            mm(m.lowest_central_coaptation_above_annulus_mm),
            "axial distance, annulus plane to the lowest point where all three leaflets touch",
        ),
        (
            "Lowest commissure tip above annulus",
            mm(m.lowest_commissure_above_annulus_mm),
            "axial distance, annulus plane to the lowest commissure (valve.json)",
        ),
        (
            "STJ above annulus",
            mm(m.stj_above_annulus_mm),
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

pub(super) fn leaflets(h: &mut String, report: &Report) {
    h.push_str("<section id=\"leaflets\">\n<h2>Per leaflet</h2>\n");
    let list = &report.leaflets;
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
        let index = l.index.unwrap_or(i as u64 + 1);
        // The closed cusp area by 1-based index, as the metrics list it.
        let cusp = index
            .checked_sub(1)
            .and_then(|k| report.metrics.cusp_area_closed_mm2.get(k as usize).copied())
            .flatten();
        let cells = [
            fixed(l.coaptation_area_mm2, 1),
            fixed(l.free_edge_length_mm, 1),
            fixed(l.leaflet_area_mm2, 1),
            fixed(cusp, 1),
            fixed(l.billowing_mm, 2),
            fixed(l.h_avr_mm, 2),
            percent(l.ncca),
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
pub(super) const LEAFLET_COLUMNS: [(&str, &str); 7] = [
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
pub(super) fn plain(html: &str) -> String {
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

pub(super) fn conventions(h: &mut String, c: &Conventions) {
    h.push_str("<section id=\"conventions\">\n<h2>The two measurement conventions</h2>\n<div class=\"conventions\">\n");
    // Seeds' group.
    let s = &c.seeds;
    h.push_str("<div id=\"convention-seeds\">\n<h3>Contact margin (the seeds' group)</h3>\n");
    description(h, &s.description);
    let _ = writeln!(
        h,
        "<p>Contact margin {}; partially touching triangles refined {} time(s).</p>",
        esc(&mm(s.margin_mm)),
        esc(&s.refinement.map_or(DASH.to_string(), |r| r.to_string())),
    );
    if s.pairs.is_empty() {
        h.push_str("<p>No leaflet pairs measured.</p>\n");
    } else {
        h.push_str("<table>\n<thead><tr><th>Pair</th><th>Coaptation height (mm)</th><th>Area on first (mm²)</th><th>Area on second (mm²)</th></tr></thead>\n<tbody>\n");
        for p in &s.pairs {
            let area = |k: usize| p.area_mm2.get(k).copied().flatten();
            let _ = writeln!(
                h,
                "<tr><th scope=\"row\">{}</th><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
                esc(&pair_label(&p.leaflets)),
                esc(&fixed(p.coaptation_height_mm, 2)),
                esc(&fixed(area(0), 1)),
                esc(&fixed(area(1), 1)),
            );
        }
        h.push_str("</tbody>\n</table>\n");
    }
    h.push_str("</div>\n");
    // SlicerHeart.
    let s = &c.slicerheart;
    h.push_str(
        "<div id=\"convention-slicerheart\">\n<h3>Base line to margin line (SlicerHeart)</h3>\n",
    );
    description(h, &s.description);
    if s.pairs.is_empty() {
        h.push_str("<p>No leaflet pairs measured.</p>\n");
    } else {
        h.push_str(
            "<table>\n<thead><tr><th>Pair</th><th>Area (mm²)</th><th>Height (mm): min · mean · max<br>\
             percentiles 10 · 25 · 50 · 75 · 90</th></tr></thead>\n<tbody>\n",
        );
        for p in &s.pairs {
            let heights = match &p.height_mm {
                Some(o) => {
                    let line = |values: &[Option<f64>]| {
                        values
                            .iter()
                            .map(|&x| esc(&fixed(x, 2)))
                            .collect::<Vec<_>>()
                            .join(" · ")
                    };
                    let Stats {
                        min,
                        mean,
                        max,
                        p10,
                        p25,
                        p50,
                        p75,
                        p90,
                    } = *o;
                    format!(
                        "{}<br>{}",
                        line(&[min, mean, max]),
                        line(&[p10, p25, p50, p75, p90])
                    )
                }
                None => NOT_MEASURED.to_string(),
            };
            let _ = writeln!(
                h,
                "<tr><th scope=\"row\">{}</th><td class=\"num\">{}</td><td>{heights}</td></tr>",
                esc(&pair_label(&p.leaflets)),
                esc(&fixed(p.area_mm2, 1)),
            );
        }
        h.push_str("</tbody>\n</table>\n");
    }
    h.push_str("</div>\n</div>\n</section>\n");
}

/// A convention's description as a paragraph, when it has one.
fn description(h: &mut String, text: &str) {
    if !text.is_empty() {
        let _ = writeln!(h, "<p>{}</p>", esc(text));
    }
}
