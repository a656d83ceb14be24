//! The first screen: the verdict, the criteria table and the findings.

use std::fmt::Write as _;

use super::format::*;
use super::{DASH, NOT_MEASURED};
use coapt_io::report_json::{Comparison, Criterion, Quantity, Report, Severity, Status};

pub(super) fn verdict(h: &mut String, report: &Report) {
    let (v, criteria) = (&report.verdict, &report.criteria);
    let closed = v.closed.or(report.metrics.closed);
    let failed = criteria_names(criteria, Some(false));
    let unmeasured = criteria_names(criteria, None);
    let meets_all = v.meets_all_criteria.or_else(|| {
        (!criteria.is_empty() && failed.is_empty() && unmeasured.is_empty())
            .then_some(true)
            .or((!failed.is_empty()).then_some(false))
    });
    let status = v.status;
    let reasons = &v.not_assessable_reasons;
    let class = match (status, closed, meets_all) {
        (Some(Status::NotAssessable), _, _) => "na",
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
        (Some(Status::NotAssessable), _) => {
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
        for r in reasons {
            let _ = writeln!(h, "<li>{}</li>", esc(r));
        }
        h.push_str("</ul>\n");
    }
    if status == Some(Status::NotAssessable) {
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

pub(super) fn criteria_table(h: &mut String, criteria: &[Criterion]) {
    h.push_str("<section id=\"criteria\">\n<h2>Criteria</h2>\n");
    if criteria.is_empty() {
        h.push_str("<p>No criteria in the report.</p>\n</section>\n");
        return;
    }
    h.push_str("<table>\n<thead><tr><th>Criterion</th><th>Value</th><th>Required</th><th>Result</th><th>Note</th><th>Source</th></tr></thead>\n<tbody>\n");
    for c in criteria {
        let unit = match c.unit.as_str() {
            "mm2" => "mm²",
            u => u,
        };
        let value = match c.value {
            Some(Quantity::Bool(b)) => yes_no(b).to_string(),
            Some(Quantity::Number(x)) => with_unit(&fixed(Some(x), 2), unit),
            None => NOT_MEASURED.to_string(),
        };
        let threshold = match c.threshold {
            Some(Quantity::Bool(b)) => yes_no(b).to_string(),
            Some(Quantity::Number(x)) => with_unit(&shortest(Some(x)), unit),
            None => DASH.to_string(),
        };
        let required = match c.comparison {
            Some(Comparison::Above) => format!("&gt; {}", esc(&threshold)),
            Some(Comparison::AtMost) => format!("&le; {}", esc(&threshold)),
            Some(Comparison::Is) | None => esc(&threshold),
        };
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(criterion_name(c)),
            esc(&value),
            required,
            result_tag(c.pass),
            esc(&c.note),
            esc(&c.source),
        );
    }
    h.push_str("</tbody>\n</table>\n</section>\n");
}

pub(super) fn findings(h: &mut String, report: &Report) {
    h.push_str("<section id=\"findings\">\n<h2>Findings</h2>\n");
    // (severity, message), the report's findings first in their order.
    let mut items: Vec<(Severity, String)> = report
        .findings
        .iter()
        .map(|f| (f.severity, f.message.clone()))
        .collect();
    // What the page can see for itself, unless a finding already says it.
    let said = |words: &[&str], items: &[(Severity, String)]| {
        items.iter().any(|(_, m)| {
            let m = m.to_lowercase();
            words.iter().any(|w| m.contains(w))
        })
    };
    let solver = &report.solver;
    if solver.converged == Some(false) && !said(&["converge"], &items) {
        let reason = solver.reason.as_deref().unwrap_or("no reason given");
        items.push((Severity::Warning, format!("The mechanics solver did not converge ({reason}): the closed shape and every metric are uncertain.")));
    }
    let metrics = &report.metrics;
    let closed = metrics.closed;
    let max_area = metrics.coaptation_area_mm2.max;
    if max_area == Some(0.0) && !said(&["contact", "coapt"], &items) {
        items.push((
            Severity::Warning,
            "No contact at all: no leaflet touches another.".into(),
        ));
    } else if closed == Some(false) && !said(&["close", "contact", "coapt"], &items) {
        items.push((
            Severity::Warning,
            "The leaflets do not all meet: there is no central coaptation.".into(),
        ));
    }
    let failed = criteria_names(&report.criteria, Some(false));
    if report.verdict.meets_all_criteria == Some(true) && !failed.is_empty() {
        items.push((
            Severity::Error,
            format!(
                "Inconsistent report: the verdict says all criteria are met, but these fail: {}.",
                failed.join(", ")
            ),
        ));
    }
    items.sort_by_key(|(severity, _)| *severity); // stable: order within a severity kept
    if items.is_empty() {
        h.push_str("<p>No findings.</p>\n");
    } else {
        h.push_str("<ul class=\"findings\">\n");
        for (severity, msg) in &items {
            let (class, tag) = match severity {
                Severity::Error => ("sev-error", "ERROR"),
                Severity::Warning => ("sev-warning", "WARNING"),
                Severity::Info => ("sev-info", "INFO"),
            };
            let _ = writeln!(
                h,
                "<li><span class=\"tag {class}\">{tag}</span> {}</li>",
                esc(msg)
            );
        }
        h.push_str("</ul>\n");
    }
    h.push_str("</section>\n");
}

pub(super) fn criterion_name(c: &Criterion) -> &str {
    or(or(&c.name, &c.id), "(unnamed criterion)")
}

/// Names of the criteria whose `pass` is `want` (`None`: not judged).
pub(super) fn criteria_names(criteria: &[Criterion], want: Option<bool>) -> Vec<String> {
    criteria
        .iter()
        .filter(|c| c.pass == want)
        .map(|c| criterion_name(c).to_string())
        .collect()
}
