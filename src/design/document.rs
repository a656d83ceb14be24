//! `design.json` (`coapt-design/1`): every size tried, what its closure
//! gave, and the recommendation with its reason. No timings, so the same
//! inputs give the same bytes.

use std::collections::BTreeMap;

use super::RuleOutcome;
use super::ozaki_rule::OzakiRule;
use super::recommend::{Measured, Outcome, Recommendation};
use crate::io::design_json::{Closure, ClosureStatus, Design};
use crate::pipeline::params::Value;

pub use crate::io::design_json::SCHEMA;

fn opt(x: Option<f64>) -> Option<f64> {
    x.filter(|v| v.is_finite())
}

/// One closure of the sweep as `design.json` holds it: a size's, or the
/// closure of Ozaki's rule.
fn closure(run: &str, leaflet_sizes: &[Option<u32>], result: &Result<Measured, String>) -> Closure {
    let failed = Closure::unmeasured(run, leaflet_sizes);
    match result {
        Ok(m) => Closure {
            status: ClosureStatus::Measured,
            closed: Some(m.closed),
            meets_all_criteria: m.meets_all,
            criteria_passed: Some(m.passed as u64),
            criteria_judged: Some(m.judged as u64),
            failures: m.failures.clone(),
            criteria_shortfall_mm: opt(Some(m.shortfall_mm)),
            coaptation_height_mm: opt(m.coaptation_height_mm),
            central_coaptation_height_mm: opt(m.central_coaptation_height_mm),
            effective_height_mm: opt(m.effective_height_mm),
            coaptation_area_mm2: opt(m.coaptation_area_mm2),
            leaflet_area_mm2: opt(m.leaflet_area_mm2),
            free_edge_length_mm: opt(m.free_edge_length_mm),
            ..failed
        },
        Err(e) => Closure {
            error: Some(e.clone()),
            ..failed
        },
    }
}

pub fn build(
    outcomes: &[Outcome],
    rec: &Recommendation,
    rule: Option<&OzakiRule>,
    rule_outcome: Option<&RuleOutcome>,
    sections: &BTreeMap<String, BTreeMap<String, Value>>,
) -> Design {
    let sizes = outcomes
        .iter()
        .map(|o| Closure {
            size: Some(o.size),
            ..closure(
                &super::sweep::size_dir(o.size),
                &[Some(o.size); 3],
                &o.result,
            )
        })
        .collect();
    let rule_closure = match (rule, rule_outcome) {
        (Some(r), Some(o)) => Some(closure(&o.run, &r.sizes, &o.result)),
        _ => None,
    };
    let parameters = super::sweep::STAGES
        .iter()
        .filter_map(|s| {
            let values = sections.get(*s)?;
            Some((
                s.to_string(),
                values
                    .iter()
                    .map(|(k, v)| (k.clone(), v.canonical()))
                    .collect(),
            ))
        })
        .collect();
    Design {
        schema: SCHEMA.into(),
        coapt_version: env!("CARGO_PKG_VERSION").into(),
        template_family: "ozaki_size".into(),
        recommended_size: rec.size,
        shown_size: rec.shown,
        reason: rec.reason.clone(),
        intercommissural_distance_mm: rule.map(|r| r.distances_mm.to_vec()),
        ozaki_rule_sizes: rule.map(|r| r.sizes.to_vec()),
        ozaki_rule: rule.map(|r| r.sentence(rec.size)),
        ozaki_rule_closure: rule_closure,
        sizes,
        parameters,
    }
}
