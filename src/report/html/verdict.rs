//! The first screen: the verdict, the criteria table and the findings.

use std::fmt::Write as _;

use serde_json::Value;

use super::format::*;
use super::{DASH, NOT_MEASURED};

pub(super) fn verdict(h: &mut String, report: &Value, criteria: &[Value]) {
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

pub(super) fn criteria_table(h: &mut String, criteria: &[Value]) {
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

pub(super) fn findings(h: &mut String, report: &Value, criteria: &[Value]) {
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

pub(super) fn criterion_name(c: &Value) -> String {
    c.get("name")
        .and_then(Value::as_str)
        .or_else(|| c.get("id").and_then(Value::as_str))
        .unwrap_or("(unnamed criterion)")
        .to_string()
}

/// Names of the criteria whose `pass` is `want` (`None`: null or missing).
pub(super) fn criteria_names(criteria: &[Value], want: Option<bool>) -> Vec<String> {
    criteria
        .iter()
        .filter(|c| c.get("pass").and_then(Value::as_bool) == want)
        .map(criterion_name)
        .collect()
}

pub(super) fn severity_rank(s: &str) -> u8 {
    match s {
        "error" => 0,
        "warning" => 1,
        "info" => 2,
        _ => 3,
    }
}
