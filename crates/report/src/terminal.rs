//! The verdict as `coapt run` ends with it on the terminal: the summary
//! sentence, each criterion's value against its threshold, the page's
//! findings, and where the report is. Read from `report.json`, so the terminal and the page say the
//! same thing.

use std::fmt::Write;
use std::path::Path;

use coapt_io::report_json::{Comparison, Criterion, Quantity, Report, Severity};

/// Lines for a person reading the terminal after a run.
pub fn summary(doc: &Report, report_html: &Path) -> String {
    let mut out = String::new();
    let v = &doc.verdict;
    let sentence = if v.summary.is_empty() {
        "no verdict in report.json"
    } else {
        &v.summary
    };
    let _ = writeln!(out, "verdict: {sentence}");
    for r in &v.not_assessable_reasons {
        let _ = writeln!(out, "  not assessable: {r}");
    }
    let width = doc
        .criteria
        .iter()
        .map(|c| c.name.chars().count())
        .max()
        .unwrap_or(0);
    for c in &doc.criteria {
        let mark = match c.pass {
            Some(true) => "pass",
            Some(false) => "FAIL",
            None => "n/a ",
        };
        let name = if c.name.is_empty() { "?" } else { &c.name };
        let _ = writeln!(
            out,
            "  {mark}  {name:<width$}  {}",
            value_against_threshold(c)
        );
    }
    let m = &doc.metrics;
    if let Some(p) = m.effective_height_pressure_mmhg {
        let _ = writeln!(
            out,
            "  (effective height judged at {} mmHg; coaptation height {}, regurgitant orifice {})",
            trim(p),
            mm(m.coaptation_height_mm, "mm"),
            mm(m.regurgitant_orifice_area_mm2, "mm²"),
        );
    }
    // What the reader must know beyond the numbers (why it does not close,
    // crossings, suturing, what Ozaki's rule would cut): the page's findings.
    for f in &doc.findings {
        let tag = match f.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
            Severity::Info => "note",
        };
        let _ = writeln!(out, "  {tag}: {}", f.message);
    }
    let _ = writeln!(out, "report: {}", report_html.display());
    out
}

fn value_against_threshold(c: &Criterion) -> String {
    let unit = match c.unit.as_str() {
        "mm2" => "mm²",
        u => u,
    };
    let cmp = match c.comparison {
        Some(Comparison::Above) => ">",
        Some(Comparison::AtMost) => "<=",
        Some(Comparison::Is) => "is",
        None => "",
    };
    let need = |t: Option<Quantity>| match t {
        Some(Quantity::Number(t)) => Some(format!("(needs {cmp} {})", mm(Some(t), unit))),
        _ => None,
    };
    match c.value {
        Some(Quantity::Bool(v)) => (if v { "yes" } else { "no" }).to_string(),
        Some(Quantity::Number(v)) => match need(c.threshold) {
            Some(n) => format!("{} {n}", mm(Some(v), unit)),
            None => mm(Some(v), unit),
        },
        // Failed with no value: there was nothing to measure (no triple
        // zone for the central coaptation), which is not the same as a
        // criterion that could not be judged (pass null).
        None if c.pass == Some(false) => match need(c.threshold) {
            Some(n) => format!("none {n}"),
            None => "none".to_string(),
        },
        None => "not measurable".to_string(),
    }
}

/// Two decimals with the unit; "—" when absent.
fn mm(v: Option<f64>, unit: &str) -> String {
    match v {
        Some(v) if v.is_finite() => {
            let sep = if unit.is_empty() { "" } else { " " };
            format!("{v:.2}{sep}{unit}")
        }
        _ => "—".to_string(),
    }
}

/// A pressure as given: "3", "80", "2.5".
fn trim(v: f64) -> String {
    let s = format!("{v:.2}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn the_terminal_says_what_the_report_says() {
        let doc = json!({
            "verdict": {
                "summary": "Fails 1 of 3 criteria: Central coaptation height. The three leaflets meet.",
                "not_assessable_reasons": [],
            },
            "criteria": [
                {"name": "Central coaptation height", "value": 1.0497, "unit": "mm", "comparison": ">", "threshold": 4.0, "pass": false},
                {"name": "No residual regurgitation", "value": 0.5994, "unit": "mm2", "comparison": "<=", "threshold": 1.0, "pass": true},
                {"name": "Valve closed", "value": true, "unit": "", "comparison": "is", "threshold": true, "pass": true},
                {"name": "Leaflets below the STJ", "value": null, "unit": "mm", "comparison": ">", "threshold": 0.0, "pass": null},
                {"name": "Central coaptation height", "value": null, "unit": "mm", "comparison": ">", "threshold": 4.0, "pass": false},
            ],
            "metrics": {
                "effective_height_pressure_mmhg": 3.0,
                "coaptation_height_mm": 13.974,
                "regurgitant_orifice_area_mm2": 0.5994,
            },
            "findings": [
                {"severity": "info", "message": "Ozaki's rule cuts 21 / 25 / 25."},
                {"severity": "warning", "message": "The free edges are too short to meet."},
            ],
        });
        let text = summary(
            &serde_json::from_value(doc).unwrap(),
            Path::new("/runs/a/report.html"),
        );
        assert_eq!(
            text,
            "verdict: Fails 1 of 3 criteria: Central coaptation height. The three leaflets meet.\n\
             \x20 FAIL  Central coaptation height  1.05 mm (needs > 4.00 mm)\n\
             \x20 pass  No residual regurgitation  0.60 mm² (needs <= 1.00 mm²)\n\
             \x20 pass  Valve closed               yes\n\
             \x20 n/a   Leaflets below the STJ     not measurable\n\
             \x20 FAIL  Central coaptation height  none (needs > 4.00 mm)\n\
             \x20 (effective height judged at 3 mmHg; coaptation height 13.97 mm, regurgitant orifice 0.60 mm²)\n\
             \x20 note: Ozaki's rule cuts 21 / 25 / 25.\n\
             \x20 warning: The free edges are too short to meet.\n\
             report: /runs/a/report.html\n"
        );
    }

    #[test]
    fn reasons_a_closure_cannot_be_judged_come_first() {
        let doc = json!({
            "verdict": {
                "summary": "Not assessable.",
                "not_assessable_reasons": ["12 pairs of triangles of different leaflets cross"],
            },
            "criteria": [],
            "metrics": {},
        });
        let text = summary(&serde_json::from_value(doc).unwrap(), Path::new("r.html"));
        assert_eq!(
            text,
            "verdict: Not assessable.\n  not assessable: 12 pairs of triangles of different leaflets cross\nreport: r.html\n"
        );
    }
}
