//! `report.json` (schema `schemas/report.schema.json`, keys in
//! docs/report.md, "report.json"):
//! verdict, criteria, metrics with units in the key names, both
//! measurement conventions, findings, solver, timings and provenance.

use serde_json::{Value as Json, json};

use super::coaptation::Options as ZoneOptions;
use super::criteria::{self, Anatomy, Comparison, Criterion, Pressures, Value};
use super::metrics::{Metrics, Stats};
use super::verdict::{self, Verdict};

pub const SCHEMA: &str = "coapt-report/2";

/// Something the reader must know that is not a number.
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    pub severity: Severity,
    pub message: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    Info,
    Warning,
    Error,
}

impl Severity {
    fn name(self) -> &'static str {
        match self {
            Severity::Info => "info",
            Severity::Warning => "warning",
            Severity::Error => "error",
        }
    }
}

/// Everything around the metrics that goes into the document.
pub struct Context {
    pub zone: ZoneOptions,
    pub pressures: Pressures,
    pub anatomy: Anatomy,
    pub solver: Json,
    pub timing_s: Json,
    pub inputs: Json,
    pub parameters: Json,
}

fn stats(s: &Option<Stats>) -> Json {
    match s {
        None => Json::Null,
        Some(s) => json!({
            "min": s.min, "mean": s.mean, "max": s.max,
            "p10": s.p10, "p25": s.p25, "p50": s.p50, "p75": s.p75, "p90": s.p90,
        }),
    }
}

fn criterion(c: &Criterion) -> Json {
    let (value, unit) = match c.value {
        Value::Mm(v) => (json!(v), "mm"),
        Value::Mm2(v) => (json!(v), "mm2"),
        Value::Bool(b) => (json!(b), ""),
    };
    let (comparison, threshold) = match c.comparison {
        Comparison::Above(t) => (">", json!(t)),
        Comparison::AtMost(t) => ("<=", json!(t)),
        Comparison::IsTrue => ("is", json!(true)),
    };
    json!({
        "id": c.id,
        "name": c.name,
        "value": value,
        "unit": unit,
        "comparison": comparison,
        "threshold": threshold,
        "pass": c.pass,
        "note": c.note,
        "source": c.source,
    })
}

pub fn build(
    m: &Metrics,
    criteria: &[Criterion],
    v: &Verdict,
    findings: &[Finding],
    ctx: &Context,
) -> Json {
    let per: Vec<f64> = m.leaflets.iter().map(|l| l.coaptation_area_mm2).collect();
    let fold = |f: fn(f64, f64) -> f64, init: f64| per.iter().copied().fold(init, f);
    let leaflets: Vec<Json> = m
        .leaflets
        .iter()
        .enumerate()
        .map(|(i, l)| {
            json!({
                "index": i + 1,
                "coaptation_area_mm2": l.coaptation_area_mm2,
                "free_edge_length_mm": l.free_edge_length_mm,
                "leaflet_area_mm2": l.leaflet_area_mm2,
                "cusp_area_closed_mm2": l.cusp_area_closed_mm2,
                "billowing_mm": l.billowing_mm,
                "central_free_edge_height_mm": l.central_free_edge_height_mm,
                "lowest_free_edge_mm": l.lowest_free_edge_mm,
                "h_avr_mm": (l.free_edge_length_mm > 0.0).then(|| l.coaptation_area_mm2 / l.free_edge_length_mm),
                "ncca": (l.cusp_area_closed_mm2 > 0.0).then(|| l.coaptation_area_mm2 / l.cusp_area_closed_mm2),
            })
        })
        .collect();
    let seeds_pairs: Vec<Json> = m
        .pairs
        .iter()
        .map(|p| {
            json!({
                "leaflets": [p.leaflets[0] + 1, p.leaflets[1] + 1],
                "coaptation_height_mm": p.height_mm,
                "h_cc_mm": p.h_cc_mm,
                "area_mm2": p.area_mm2,
            })
        })
        .collect();
    let slicer_pairs: Vec<Json> = m
        .pairs
        .iter()
        .map(|p| {
            json!({
                "leaflets": [p.leaflets[0] + 1, p.leaflets[1] + 1],
                "area_mm2": 0.5 * (p.area_mm2[0] + p.area_mm2[1]),
                "height_mm": stats(&p.base_to_margin_mm),
            })
        })
        .collect();
    let (eff, eff_p, _) = criteria::judged_effective_height(m, &ctx.pressures);
    json!({
        "schema": SCHEMA,
        "coapt_version": env!("CARGO_PKG_VERSION"),
        "frame": "LPS",
        "verdict": verdict::to_json(v, m.closed, criteria),
        "criteria": criteria.iter().map(criterion).collect::<Vec<_>>(),
        "metrics": {
            "coaptation_height_mm": m.coaptation_height_mm,
            "central_coaptation_height_mm": m.central_coaptation_height_mm,
            "coaptation_area_mm2": {
                "per_leaflet": per,
                "max": fold(f64::max, f64::NEG_INFINITY),
                "min": fold(f64::min, f64::INFINITY),
            },
            "effective_height_mm": eff,
            "effective_height_pressure_mmhg": eff_p,
            "effective_height_closing_pressure_mm": m.effective_height_mm,
            "closing_pressure_mmhg": ctx.pressures.closing_mmhg,
            "effective_height_low_pressure_mm": m.effective_height_low_pressure_mm,
            "low_pressure_mmhg": ctx.pressures.low_mmhg,
            "central_coaptation_top_above_annulus_mm": m.central_coaptation_top_mm,
            "lowest_commissure_above_annulus_mm": ctx.anatomy.lowest_commissure_mm,
            "highest_leaflet_above_annulus_mm": m.highest_leaflet_mm,
            "stj_above_annulus_mm": ctx.anatomy.stj_mm.as_ref().ok(),
            "h_cc_mm": m.h_cc_mm,
            "h_avr_mm": m.h_avr_mm,
            "ncca": m.ncca,
            "regurgitant_orifice_area_mm2": m.regurgitant_orifice_area_mm2,
            "lumen_area_mm2": m.lumen_area_mm2,
            "regurgitant_orifice_pixel_mm": m.orifice_pixel_mm,
            "coaptation_above_vaj": m.coaptation_above_vaj,
            "closed": m.closed,
            "free_edge_length_mm": m.leaflets.iter().map(|l| l.free_edge_length_mm).collect::<Vec<_>>(),
            "leaflet_area_mm2": m.leaflets.iter().map(|l| l.leaflet_area_mm2).collect::<Vec<_>>(),
            "cusp_area_closed_mm2": m.leaflets.iter().map(|l| l.cusp_area_closed_mm2).collect::<Vec<_>>(),
            "billowing_mm": m.leaflets.iter().map(|l| l.billowing_mm).collect::<Vec<_>>(),
            "lowest_free_edge_above_annulus_mm": m.lowest_free_edge_mm,
            "lowest_coaptation_above_annulus_mm": m.lowest_coaptation_mm,
            "lowest_central_coaptation_above_annulus_mm": m.lowest_central_coaptation_mm,
        },
        "leaflets": leaflets,
        "conventions": {
            "seeds": {
                "description": "Seeds' group: a point of leaflet i coapts with leaflet j when its distance to j is below the margin; triangles that may be partly in contact are refined and cut at the margin by interpolated distance. Coaptation height per pair = the largest axial extent of the pair's zone over radial columns; h_C-C = the extent in the column 5 mm from the axis; areas on the closed leaflets.",
                "margin_mm": ctx.zone.margin_mm,
                "refinement": ctx.zone.refine,
                "pairs": seeds_pairs,
            },
            "slicerheart": {
                "description": "SlicerHeart: the coaptation surface is the strip between the base line (where the leaflets start to touch) and the margin line (the free edge where it touches); height = distance from each base-line point to the closest margin-line point, weighted by base-line length; area = mean of the two sides' strip areas.",
                "pairs": slicer_pairs,
            },
        },
        "findings": findings.iter().map(|f| json!({"severity": f.severity.name(), "message": f.message})).collect::<Vec<_>>(),
        "solver": ctx.solver,
        "timing_s": ctx.timing_s,
        "inputs": ctx.inputs,
        "parameters": ctx.parameters,
    })
}
