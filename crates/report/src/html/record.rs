//! How the answer was computed: the solver's account, the stages' timings
//! and the provenance of every input and parameter.

use std::fmt::Write as _;

use indexmap::IndexMap;
use serde_json::Value;

use super::format::*;
use super::{DASH, STAGE_ORDER};
use coapt_io::report_json::{Report, Solver};

pub(super) fn solver(h: &mut String, s: &Solver) {
    h.push_str("<section id=\"solver\">\n<h2>Solver</h2>\n<table class=\"narrow\">\n<tbody>\n");
    let converged = match s.converged {
        Some(true) => "<span class=\"tag pass\">CONVERGED</span>",
        Some(false) => "<span class=\"tag fail\">NOT CONVERGED</span>",
        None => "<span class=\"tag na\">UNKNOWN</span>",
    };
    let _ = writeln!(
        h,
        "<tr><th scope=\"row\">Converged</th><td>{converged}</td></tr>"
    );
    let iterations = s.iterations.map_or(DASH.to_string(), |i| i.to_string());
    let _ = writeln!(
        h,
        "<tr><th scope=\"row\">Iterations</th><td>{}</td></tr>",
        esc(&iterations)
    );
    let residual = s
        .residual_n
        .filter(|r| r.is_finite())
        .map_or(DASH.to_string(), |r| format!("{r:.3e} N"));
    let _ = writeln!(
        h,
        "<tr><th scope=\"row\">Final residual ‖R‖₂ (all free-node forces)</th><td>{}</td></tr>",
        esc(&residual)
    );
    let _ = writeln!(
        h,
        "<tr><th scope=\"row\">Stop reason</th><td>{}</td></tr>",
        esc(s.reason.as_deref().unwrap_or(DASH))
    );
    h.push_str("</tbody>\n</table>\n</section>\n");
}

pub(super) fn timing(h: &mut String, t: &IndexMap<String, Option<f64>>) {
    h.push_str("<section id=\"timing\">\n<h2>Time per stage</h2>\n");
    if t.is_empty() {
        h.push_str("<p>No timings in the report.</p>\n</section>\n");
        return;
    }
    let mut keys: Vec<&String> = t.keys().collect();
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
        let s = t[k].filter(|s| s.is_finite());
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

pub(super) fn provenance(h: &mut String, report: &Report) {
    h.push_str("<section id=\"provenance\">\n<h2>Provenance</h2>\n");
    let _ = writeln!(
        h,
        "<p>coapt version {} · report schema {} · frame {}</p>",
        esc(or(&report.coapt_version, DASH)),
        esc(or(&report.schema, DASH)),
        esc(or(&report.frame, DASH)),
    );
    h.push_str("<h3>Input files</h3>\n");
    if report.inputs.is_empty() {
        h.push_str("<p>No input files recorded.</p>\n");
    } else {
        h.push_str("<table>\n<thead><tr><th>Input</th><th>Path</th><th>Bytes</th><th>blake3</th></tr></thead>\n<tbody>\n");
        let mut inputs: Vec<_> = report.inputs.iter().collect();
        inputs.sort_by(|a, b| a.0.cmp(b.0));
        for (k, v) in inputs {
            let _ = writeln!(
                h,
                "<tr><th scope=\"row\">{}</th><td class=\"mono\">{}</td><td class=\"num\">{}</td><td class=\"mono\">{}</td></tr>",
                esc(k),
                esc(or(&v.path, DASH)),
                esc(&v.bytes.map_or(DASH.to_string(), |b| b.to_string())),
                esc(or(&v.blake3, DASH)),
            );
        }
        h.push_str("</tbody>\n</table>\n");
    }
    h.push_str("<h3>Parameters</h3>\n");
    if report.parameters.is_empty() {
        h.push_str("<p>No parameters recorded.</p>\n");
    } else {
        h.push_str("<table>\n<thead><tr><th>Parameter</th><th>Value</th></tr></thead>\n<tbody>\n");
        let mut rows = Vec::new();
        flatten("", &Value::Object(report.parameters.clone()), &mut rows);
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
    h.push_str("</section>\n");
}

/// Parameters as rows "closure.model.mu: 900 kPa": nested objects by dotted
/// key, the unit a key ends in (`_mm`, `_kpa`, …) moved to its value, and
/// parameters left unset (their value is derived and shown under its own
/// key, e.g. margin → margin 0.9 mm) left out.
pub(super) fn flatten(prefix: &str, v: &Value, out: &mut Vec<(String, String)>) {
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
