//! `report.json` built as the typed document of `io::report_json` (schema
//! `schemas/report.schema.json`, keys in docs/report.md, "report.json"):
//! verdict, criteria, metrics with units in the key names, both
//! measurement conventions, findings, solver, timings and provenance.

use indexmap::IndexMap;
use serde_json::{Map, Value as Json};

use super::coaptation::Options as ZoneOptions;
use super::criteria::{self, Anatomy, Comparison, Criterion, Pressures, Value};
use super::metrics::{Metrics, Stats};
use super::verdict::{self, Verdict};
use coapt_io::report_json::{self as doc, Quantity, Report, finite};

pub use coapt_io::report_json::{Finding, SCHEMA, Severity};

/// Everything around the metrics that goes into the document.
pub struct Context {
    pub zone: ZoneOptions,
    pub pressures: Pressures,
    pub anatomy: Anatomy,
    pub solver: doc::Solver,
    pub timing_s: IndexMap<String, Option<f64>>,
    pub inputs: IndexMap<String, doc::InputFile>,
    pub parameters: Map<String, Json>,
}

fn opt(x: Option<f64>) -> Option<f64> {
    x.and_then(finite)
}

fn stats(s: &Option<Stats>) -> Option<doc::Stats> {
    s.as_ref().map(|s| doc::Stats {
        min: finite(s.min),
        mean: finite(s.mean),
        max: finite(s.max),
        p10: finite(s.p10),
        p25: finite(s.p25),
        p50: finite(s.p50),
        p75: finite(s.p75),
        p90: finite(s.p90),
    })
}

fn criterion(c: &Criterion) -> doc::Criterion {
    let (value, unit) = match c.value {
        Value::Mm(v) => (opt(v).map(Quantity::Number), "mm"),
        Value::Mm2(v) => (opt(v).map(Quantity::Number), "mm2"),
        Value::Bool(b) => (b.map(Quantity::Bool), ""),
    };
    let (comparison, threshold) = match c.comparison {
        Comparison::Above(t) => (doc::Comparison::Above, finite(t).map(Quantity::Number)),
        Comparison::AtMost(t) => (doc::Comparison::AtMost, finite(t).map(Quantity::Number)),
        Comparison::IsTrue => (doc::Comparison::Is, Some(Quantity::Bool(true))),
    };
    doc::Criterion {
        id: c.id.into(),
        name: c.name.into(),
        value,
        unit: unit.into(),
        comparison: Some(comparison),
        threshold,
        pass: c.pass,
        note: c.note.clone(),
        source: c.source.into(),
    }
}

const SEEDS_CONVENTION: &str = "Seeds' group: a point of leaflet i coapts with leaflet j when its distance to j is below the margin; triangles that may be partly in contact are refined and cut at the margin by interpolated distance. Coaptation height per pair = the largest axial extent of the pair's zone over radial columns; h_C-C = the extent in the column 5 mm from the axis; areas on the closed leaflets.";

const SLICERHEART_CONVENTION: &str = "SlicerHeart: the coaptation surface is the strip between the base line (where the leaflets start to touch) and the margin line (the free edge where it touches); height = distance from each base-line point to the closest margin-line point, weighted by base-line length; area = mean of the two sides' strip areas.";

/// The document of `m` judged by `criteria` into `v`; `case` and `design`
/// are the stage's to add.
pub fn build(
    m: &Metrics,
    criteria: &[Criterion],
    v: &Verdict,
    findings: &[Finding],
    ctx: &Context,
) -> Report {
    let per: Vec<f64> = m.leaflets.iter().map(|l| l.coaptation_area_mm2).collect();
    let fold = |f: fn(f64, f64) -> f64, init: f64| finite(per.iter().copied().fold(init, f));
    let leaflets = m
        .leaflets
        .iter()
        .enumerate()
        .map(|(i, l)| doc::Leaflet {
            index: Some(i as u64 + 1),
            coaptation_area_mm2: finite(l.coaptation_area_mm2),
            free_edge_length_mm: finite(l.free_edge_length_mm),
            leaflet_area_mm2: finite(l.leaflet_area_mm2),
            cusp_area_closed_mm2: finite(l.cusp_area_closed_mm2),
            billowing_mm: finite(l.billowing_mm),
            central_free_edge_height_mm: opt(l.central_free_edge_height_mm),
            lowest_free_edge_mm: finite(l.lowest_free_edge_mm),
            h_avr_mm: (l.free_edge_length_mm > 0.0)
                .then(|| l.coaptation_area_mm2 / l.free_edge_length_mm)
                .and_then(finite),
            ncca: (l.cusp_area_closed_mm2 > 0.0)
                .then(|| l.coaptation_area_mm2 / l.cusp_area_closed_mm2)
                .and_then(finite),
        })
        .collect();
    let pair_of = |p: [usize; 2]| vec![p[0] as u64 + 1, p[1] as u64 + 1];
    let seeds_pairs = m
        .pairs
        .iter()
        .map(|p| doc::SeedsPair {
            leaflets: pair_of(p.leaflets),
            coaptation_height_mm: opt(p.height_mm),
            h_cc_mm: opt(p.h_cc_mm),
            area_mm2: p.area_mm2.iter().map(|&a| finite(a)).collect(),
        })
        .collect();
    let slicer_pairs = m
        .pairs
        .iter()
        .map(|p| doc::SlicerHeartPair {
            leaflets: pair_of(p.leaflets),
            area_mm2: finite(0.5 * (p.area_mm2[0] + p.area_mm2[1])),
            height_mm: stats(&p.base_to_margin_mm),
        })
        .collect();
    let each = |f: fn(&super::metrics::Leaflet) -> f64| -> Vec<Option<f64>> {
        m.leaflets.iter().map(|l| finite(f(l))).collect()
    };
    let (eff, eff_p, _) = criteria::judged_effective_height(m, &ctx.pressures);
    Report {
        schema: SCHEMA.into(),
        coapt_version: env!("CARGO_PKG_VERSION").into(),
        frame: "LPS".into(),
        verdict: verdict::to_document(v, m.closed, criteria),
        criteria: criteria.iter().map(criterion).collect(),
        metrics: doc::Metrics {
            coaptation_height_mm: opt(m.coaptation_height_mm),
            central_coaptation_height_mm: opt(m.central_coaptation_height_mm),
            coaptation_area_mm2: doc::AreaSpread {
                per_leaflet: per.iter().map(|&a| finite(a)).collect(),
                max: fold(f64::max, f64::NEG_INFINITY),
                min: fold(f64::min, f64::INFINITY),
            },
            effective_height_mm: opt(eff),
            effective_height_pressure_mmhg: opt(eff_p),
            effective_height_closing_pressure_mm: opt(m.effective_height_mm),
            closing_pressure_mmhg: opt(ctx.pressures.closing_mmhg),
            effective_height_low_pressure_mm: opt(m.effective_height_low_pressure_mm),
            low_pressure_mmhg: opt(ctx.pressures.low_mmhg),
            central_coaptation_top_above_annulus_mm: opt(m.central_coaptation_top_mm),
            lowest_commissure_above_annulus_mm: finite(ctx.anatomy.lowest_commissure_mm),
            highest_leaflet_above_annulus_mm: finite(m.highest_leaflet_mm),
            stj_above_annulus_mm: opt(ctx.anatomy.stj_mm.as_ref().ok().copied()),
            h_cc_mm: opt(m.h_cc_mm),
            h_avr_mm: opt(m.h_avr_mm),
            ncca: opt(m.ncca),
            regurgitant_orifice_area_mm2: opt(m.regurgitant_orifice_area_mm2),
            lumen_area_mm2: opt(m.lumen_area_mm2),
            regurgitant_orifice_pixel_mm: opt(m.orifice_pixel_mm),
            coaptation_above_vaj: m.coaptation_above_vaj,
            closed: Some(m.closed),
            free_edge_length_mm: each(|l| l.free_edge_length_mm),
            leaflet_area_mm2: each(|l| l.leaflet_area_mm2),
            cusp_area_closed_mm2: each(|l| l.cusp_area_closed_mm2),
            billowing_mm: each(|l| l.billowing_mm),
            lowest_free_edge_above_annulus_mm: finite(m.lowest_free_edge_mm),
            lowest_coaptation_above_annulus_mm: opt(m.lowest_coaptation_mm),
            lowest_central_coaptation_above_annulus_mm: opt(m.lowest_central_coaptation_mm),
        },
        leaflets,
        conventions: doc::Conventions {
            seeds: doc::SeedsConvention {
                description: SEEDS_CONVENTION.into(),
                margin_mm: finite(ctx.zone.margin_mm),
                refinement: Some(ctx.zone.refine as u64),
                pairs: seeds_pairs,
            },
            slicerheart: doc::SlicerHeartConvention {
                description: SLICERHEART_CONVENTION.into(),
                pairs: slicer_pairs,
            },
        },
        findings: findings.to_vec(),
        solver: ctx.solver.clone(),
        timing_s: ctx.timing_s.clone(),
        inputs: ctx.inputs.clone(),
        parameters: ctx.parameters.clone(),
        case: None,
        design: None,
    }
}
