//! The answer on the first screen: the valve meets every criterion, fails
//! some (named), or cannot be assessed (and why). A closed state that is
//! not a physical closure (leaflets passing through each other, a solve
//! that did not converge, or no record of either) is never judged green:
//! its heights and orifice would be numbers about a shape that cannot be.

use serde_json::Value as Json;

use coapt_io::report_json;
pub use coapt_io::report_json::Status;

use super::criteria::Criterion;

#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    pub status: Status,
    /// No gate closed and every criterion measured.
    pub assessable: bool,
    /// The closed state's defects first, then the criteria not measurable.
    pub not_assessable_reasons: Vec<String>,
    /// Ids of the failed criteria.
    pub failed: Vec<&'static str>,
    pub meets_all_criteria: bool,
}

/// Why the closure in `log` (closure.json; `None`: not given) cannot be
/// judged; empty when it can.
pub fn gates(log: Option<&Json>) -> Vec<String> {
    let Some(log) = log else {
        return vec!["no closure.json: whether the closure converged and whether leaflets cross each other is unknown".into()];
    };
    let mut out = Vec::new();
    let reason = |s: &Json| {
        s["reason"]
            .as_str()
            .unwrap_or("no reason recorded")
            .to_string()
    };
    match log["solver"]["converged"].as_bool() {
        Some(true) => {}
        Some(false) => out.push(format!(
            "the closure did not converge ({})",
            reason(&log["solver"])
        )),
        None => out.push("closure.json does not record whether the closure converged".into()),
    }
    let low = &log["low_pressure"];
    if low.is_object() && low["converged"].as_bool() != Some(true) {
        out.push(format!(
            "the low-pressure closure ({} mmHg) did not converge ({})",
            low["pressure_mmhg"],
            reason(low)
        ));
    }
    match log["intersecting_triangle_pairs"].as_u64() {
        Some(0) => {}
        Some(n) => out.push(format!(
            "{n} pairs of triangles of different leaflets cross each other in the closed state (closure.json): the leaflets pass through one another, so the contact zones, heights and orifice are not those of a physical closure"
        )),
        None => out.push(
            "closure.json does not record whether leaflets cross each other (intersecting_triangle_pairs)".into(),
        ),
    }
    out
}

/// The verdict on `criteria` given the closed state's `gates`.
pub fn decide(criteria: &[Criterion], gates: Vec<String>) -> Verdict {
    let failed: Vec<&'static str> = criteria
        .iter()
        .filter(|c| c.pass == Some(false))
        .map(|c| c.id)
        .collect();
    let broken = !gates.is_empty();
    let mut reasons = gates;
    reasons.extend(
        criteria
            .iter()
            .filter(|c| c.pass.is_none())
            .map(|c| format!("{} is not measurable ({})", c.name, c.note)),
    );
    let status = if broken {
        Status::NotAssessable
    } else if !failed.is_empty() {
        Status::FailsCriteria
    } else if !reasons.is_empty() {
        Status::NotAssessable
    } else {
        Status::MeetsAllCriteria
    };
    Verdict {
        status,
        assessable: reasons.is_empty(),
        meets_all_criteria: status == Status::MeetsAllCriteria,
        not_assessable_reasons: reasons,
        failed,
    }
}

/// One or two sentences for the reader.
pub fn summary(v: &Verdict, closed: bool, criteria: &[Criterion]) -> String {
    let name = |id: &str| {
        criteria
            .iter()
            .find(|c| c.id == id)
            .map_or(id.to_string(), |c| c.name.to_string())
    };
    let mut s = match v.status {
        Status::NotAssessable => {
            format!("Not assessable: {}.", v.not_assessable_reasons.join("; "))
        }
        Status::FailsCriteria => format!(
            "Fails {} of {} criteria: {}.",
            v.failed.len(),
            criteria.len(),
            v.failed
                .iter()
                .map(|id| name(id))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        Status::MeetsAllCriteria => format!("Meets all {} criteria.", criteria.len()),
    };
    if v.status == Status::NotAssessable && !v.failed.is_empty() {
        s += &format!(
            " As computed it would fail: {}.",
            v.failed
                .iter()
                .map(|id| name(id))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    if v.status == Status::FailsCriteria && !v.assessable {
        s += &format!(" {}.", v.not_assessable_reasons.join("; "));
    }
    s += if closed {
        " The three leaflets meet."
    } else {
        " There is no zone where all three leaflets meet: the valve does not close."
    };
    s
}

pub fn to_document(v: &Verdict, closed: bool, criteria: &[Criterion]) -> report_json::Verdict {
    report_json::Verdict {
        status: Some(v.status),
        closed: Some(closed),
        assessable: Some(v.assessable),
        not_assessable_reasons: v.not_assessable_reasons.clone(),
        meets_all_criteria: Some(v.meets_all_criteria),
        failed_criteria: v.failed.iter().map(|id| id.to_string()).collect(),
        summary: summary(v, closed, criteria),
    }
}
