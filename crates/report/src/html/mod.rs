//! `report.html`: one self-contained page a surgeon reads in a minute.
//!
//! Verdict and criteria first, then findings, key metrics, per-leaflet
//! values, the two measurement conventions side by side, figures, solver,
//! timings and provenance. The page is built from the typed report document
//! (`io::report_json::Report`, what report.json holds: a value it lacks
//! shows as "—" or "not measured") and the figures' PNG bytes,
//! embedded as `data:` URLs, and the interactive 3-D view when there is
//! one. No external URL; a Content Security Policy forbids any load but
//! inline styles, `data:` images and the one viewer script (by its hash).
//! Same input, same bytes: no clock, no hash-map order.

use std::fmt::Write as _;

use super::view3d::{self, Scene};
use super::{Figure, references};
use coapt_io::report_json::Report;

mod figures;
mod format;
mod header;
mod metrics;
mod record;
#[cfg(test)]
mod tests;
mod verdict;

pub use format::esc;

use figures::*;
use format::*;
use header::*;
use metrics::*;
use record::*;
use verdict::*;

/// The stages in pipeline order, for the timing table.
const STAGE_ORDER: [&str; 6] = ["segment", "surface", "valve", "leaflets", "close", "report"];

const DASH: &str = "—";

const NOT_MEASURED: &str = "not measured";

/// The page's style sheet (print rules included).
const CSS: &str = include_str!("style.css");

/// The HTML page for `report` (the content of `report.json`), `figures`
/// and, when given, the interactive view of `scene` before the figures.
/// A value the report lacks is shown as "—" or "not measured".
pub fn render(report: &Report, figures: &[Figure], scene: Option<&Scene>) -> String {
    let mut h = String::with_capacity(
        16 * 1024
            + figures
                .iter()
                .map(|f| f.png.len() * 4 / 3 + 512)
                .sum::<usize>(),
    );
    let version = or(&report.coapt_version, DASH);
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    h.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n");
    let script = match scene {
        Some(_) => format!("; script-src {}", view3d::script_source()),
        None => String::new(),
    };
    let _ = writeln!(
        h,
        "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; style-src 'unsafe-inline'{script}\">",
    );
    h.push_str("<link rel=\"icon\" href=\"data:,\">\n");
    h.push_str("<title>Aortic valve closure — coaptation report</title>\n<style>");
    h.push_str(CSS);
    if scene.is_some() {
        h.push_str(view3d::CSS);
    }
    h.push_str(
        "</style>\n</head>\n<body>\n<header>\n<h1>Aortic valve closure — coaptation report</h1>\n",
    );
    let _ = writeln!(
        h,
        "<p class=\"meta\">Predicted by coapt {} · coordinates {} (mm) · {}</p>",
        esc(version),
        esc(or(&report.frame, DASH)),
        esc(or(&report.schema, "schema not stated")),
    );
    let _ = write!(
        h,
        "<nav><a href=\"#criteria\">Criteria</a><a href=\"#findings\">Findings</a>{}<a href=\"#metrics\">Metrics</a>\
         <a href=\"#leaflets\">Leaflets</a><a href=\"#conventions\">Conventions</a><a href=\"#figures\">Figures</a>\
         <a href=\"#solver\">Solver</a><a href=\"#timing\">Timing</a><a href=\"#provenance\">Provenance</a>\
         <a href=\"#references\">References</a></nav>\n</header>\n",
        if report.design.is_some() {
            "<a href=\"#sizing\">Sizing</a>"
        } else {
            ""
        }
    );
    case_header(&mut h, report.case.as_ref());
    verdict(&mut h, report);
    criteria_table(&mut h, &report.criteria);
    findings(&mut h, report);
    if let Some(d) = &report.design {
        let sweep: Vec<Figure> = figures
            .iter()
            .filter(|f| f.id.starts_with("sizing"))
            .cloned()
            .collect();
        sizing(&mut h, d, &sweep);
    }
    key_metrics(&mut h, &report.metrics);
    leaflets(&mut h, report);
    conventions(&mut h, &report.conventions);
    // The sweep's charts sit with its table, numbered first.
    let (sweep, others): (Vec<Figure>, Vec<Figure>) = figures
        .iter()
        .cloned()
        .partition(|f| f.id.starts_with("sizing"));
    figures_section(&mut h, &others, sweep.len() + 1, scene);
    solver(&mut h, &report.solver);
    timing(&mut h, &report.timing_s);
    provenance(&mut h, report);
    references::section(&mut h);
    let _ = writeln!(
        h,
        "<footer>coapt {} — a model prediction from CT, to be read with the clinical picture; not a measurement on the patient.</footer>",
        esc(version)
    );
    h.push_str("</body>\n</html>\n");
    h
}
