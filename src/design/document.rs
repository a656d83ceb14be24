//! `design.json` (`coapt-design/1`): every size tried, what its closure
//! gave, and the recommendation with its reason. No timings, so the same
//! inputs give the same bytes.

use std::collections::BTreeMap;

use serde_json::{Value as Json, json};

use super::RuleOutcome;
use super::ozaki_rule::OzakiRule;
use super::recommend::{Measured, Outcome, Recommendation};
use crate::pipeline::params::Value;

pub use crate::io::design_json::SCHEMA;

fn opt(x: Option<f64>) -> Json {
    x.filter(|v| v.is_finite()).map_or(Json::Null, |v| json!(v))
}

/// One closure of the sweep as `design.json` holds it: a size's, or the
/// closure of Ozaki's rule.
fn closure(run: &str, leaflet_sizes: &[Option<u32>], result: &Result<Measured, String>) -> Json {
    match result {
        Ok(m) => json!({
            "run": run,
            "leaflet_sizes": leaflet_sizes,
            "status": "measured",
            "error": null,
            "closed": m.closed,
            "meets_all_criteria": m.meets_all,
            "criteria_passed": m.passed,
            "criteria_judged": m.judged,
            "failures": m.failures,
            "criteria_shortfall_mm": m.shortfall_mm,
            "coaptation_height_mm": opt(m.coaptation_height_mm),
            "central_coaptation_height_mm": opt(m.central_coaptation_height_mm),
            "effective_height_mm": opt(m.effective_height_mm),
            "coaptation_area_mm2": opt(m.coaptation_area_mm2),
            "leaflet_area_mm2": opt(m.leaflet_area_mm2),
            "free_edge_length_mm": opt(m.free_edge_length_mm),
        }),
        Err(e) => json!({
            "run": run,
            "leaflet_sizes": leaflet_sizes,
            "status": "failed",
            "error": e,
            "closed": null,
            "meets_all_criteria": false,
            "criteria_passed": null,
            "criteria_judged": null,
            "failures": [],
            "criteria_shortfall_mm": null,
            "coaptation_height_mm": null,
            "central_coaptation_height_mm": null,
            "effective_height_mm": null,
            "coaptation_area_mm2": null,
            "leaflet_area_mm2": null,
            "free_edge_length_mm": null,
        }),
    }
}

pub fn build(
    outcomes: &[Outcome],
    rec: &Recommendation,
    rule: Option<&OzakiRule>,
    rule_outcome: Option<&RuleOutcome>,
    sections: &BTreeMap<String, BTreeMap<String, Value>>,
) -> Json {
    let sizes: Vec<Json> = outcomes
        .iter()
        .map(|o| {
            let mut c = closure(
                &super::sweep::size_dir(o.size),
                &[Some(o.size); 3],
                &o.result,
            );
            c["size"] = json!(o.size);
            c
        })
        .collect();
    let rule_closure = match (rule, rule_outcome) {
        (Some(r), Some(o)) => closure(&o.run, &r.sizes, &o.result),
        _ => Json::Null,
    };
    let parameters: serde_json::Map<String, Json> = super::sweep::STAGES
        .iter()
        .filter_map(|s| {
            let values = sections.get(*s)?;
            Some((
                s.to_string(),
                Json::Object(
                    values
                        .iter()
                        .map(|(k, v)| (k.clone(), json!(v.canonical())))
                        .collect(),
                ),
            ))
        })
        .collect();
    json!({
        "schema": SCHEMA,
        "coapt_version": env!("CARGO_PKG_VERSION"),
        "template_family": "ozaki_size",
        "recommended_size": rec.size,
        "shown_size": rec.shown,
        "reason": rec.reason,
        "intercommissural_distance_mm": rule.map(|r| r.distances_mm.to_vec()),
        "ozaki_rule_sizes": rule.map(|r| r.sizes.to_vec()),
        "ozaki_rule": rule.map(|r| r.sentence(rec.size)),
        "ozaki_rule_closure": rule_closure,
        "sizes": sizes,
        "parameters": parameters,
    })
}
