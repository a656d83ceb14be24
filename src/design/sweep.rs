//! One closure per size: a small run config in `design/size-NN/` that takes
//! the patient's segmentation, surface, valve frame and suture paths as
//! inputs and runs leaflets → close → report with an Ozaki sizer template.
//! Each size is an ordinary run directory, so `coapt run
//! design/size-21/run.toml` re-runs (or skips) it alone.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::recommend::Measured;
use crate::io::atomic::write_atomic;
use crate::io::report_json::{Comparison, Quantity, Report, Status};
use crate::pipeline::execute::Invocation;
use crate::pipeline::params::Value;
use crate::pipeline::runner::{self, RunOptions};
use crate::pipeline::spec::StageSpec;
use crate::{Error, Result};

/// The stages a size runs; everything they take that they do not make
/// comes from the patient's run.
pub const STAGES: [&str; 3] = ["leaflets", "close", "report"];

pub use crate::io::design_json::size_dir;

/// Where the closure of Ozaki's own rule lives, relative to the design
/// directory.
pub const RULE_DIR: &str = "ozaki-rule";

/// What one closure of the sweep cuts: one sizer size for all three
/// leaflets, or each leaflet by Ozaki's rule (the sizer size nearest its
/// intercommissural distance).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cut {
    Size(u32),
    Rule,
}

impl Cut {
    pub fn dir(self) -> String {
        match self {
            Cut::Size(s) => size_dir(s),
            Cut::Rule => RULE_DIR.to_string(),
        }
    }

    /// In words, for the log and the run config's header.
    pub fn name(self) -> String {
        match self {
            Cut::Size(s) => format!("size {s}"),
            Cut::Rule => "Ozaki's rule".to_string(),
        }
    }

    pub fn template(self) -> String {
        match self {
            Cut::Size(s) => template(s),
            Cut::Rule => "# Each leaflet at the Ozaki sizer size nearest its intercommissural distance (written by `coapt design`).\n\
                 [template]\nkind = \"ozaki_size\"\nsize = \"measured\"\n"
                .to_string(),
        }
    }
}

fn toml_string(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

/// The run config of one cut: every upstream artifact by absolute path,
/// the sizer template beside it, and the patient config's sections of the
/// stages it runs (canonical text, so it reads back to the same values).
pub fn config(
    cut: Cut,
    inputs: &BTreeMap<String, PathBuf>,
    sections: &BTreeMap<String, BTreeMap<String, Value>>,
) -> String {
    let what = match cut {
        Cut::Size(s) => format!("Ozaki size {s}"),
        Cut::Rule => "Ozaki's rule".to_string(),
    };
    let mut t = format!(
        "# {what}, written by `coapt design`; run alone with `coapt run` on this file.\n\
         [run]\ndir = \".\"\n\n[inputs]\ntemplate = \"template.toml\"\n"
    );
    for (name, path) in inputs {
        t.push_str(&format!(
            "{name} = {}\n",
            toml_string(&path.to_string_lossy())
        ));
    }
    for stage in STAGES {
        if let Some(values) = sections.get(stage) {
            t.push_str(&format!("\n[{stage}]\n"));
            for (k, v) in values {
                t.push_str(&format!("{k} = {}\n", toml_string(&v.canonical())));
            }
        }
    }
    t
}

pub fn template(size: u32) -> String {
    format!(
        "# Ozaki sizer size {size} for all three leaflets (written by `coapt design`).\n\
         [template]\nkind = \"ozaki_size\"\nsize = {size}\n"
    )
}

/// Run one cut in its directory and measure it: `Err` only when the sweep
/// itself cannot go on (its files cannot be written); a failure of the
/// cut's own chain is the inner `Err`.
pub fn run_cut(
    cut: Cut,
    design_dir: &Path,
    config_text: &str,
    registry: &[&'static StageSpec],
    inv: &Invocation,
    force: bool,
) -> Result<std::result::Result<Measured, String>> {
    let dir = design_dir.join(cut.dir());
    std::fs::create_dir_all(&dir).map_err(|e| Error::write(&dir, e))?;
    let config = dir.join("run.toml");
    for (path, text) in [
        (dir.join("template.toml"), cut.template()),
        (config.clone(), config_text.to_string()),
    ] {
        // Rewriting an unchanged file would be harmless, but leaving it
        // keeps its time stamp for people watching the directory.
        if std::fs::read_to_string(&path).ok().as_deref() != Some(text.as_str()) {
            write_atomic(&path, |w| std::io::Write::write_all(w, text.as_bytes()))?;
        }
    }
    let opts = RunOptions {
        config,
        out: None,
        from: None,
        until: None,
        force,
    };
    Ok(match runner::run(&opts, registry, inv) {
        Ok(_) => Ok(measured(&Report::read(&dir.join("report.json"))?)),
        Err(e) => Err(e.to_string()),
    })
}

/// The mean of per-leaflet values, when every one was measured.
fn mean(v: &[Option<f64>]) -> Option<f64> {
    let x: Vec<f64> = v.iter().copied().flatten().collect();
    (!x.is_empty() && x.len() == v.len()).then(|| x.iter().sum::<f64>() / x.len() as f64)
}

/// A criterion's number of the report as its JSON text ("4.0", "true").
fn as_written(q: Option<Quantity>) -> String {
    serde_json::to_string(&q).expect("a quantity serialises")
}

/// The numbers a size is judged and plotted by, from its `report.json`.
pub fn measured(doc: &Report) -> Measured {
    let criteria = &doc.criteria;
    let number = |q: Option<Quantity>| match q {
        Some(Quantity::Number(x)) => Some(x),
        _ => None,
    };
    let failures: Vec<String> = criteria
        .iter()
        .filter(|c| c.pass != Some(true))
        .map(|c| {
            let name = if c.name.is_empty() {
                "a criterion"
            } else {
                &c.name
            };
            let u = &c.unit;
            let cmp = match c.comparison {
                Some(Comparison::AtMost) => "<=",
                Some(Comparison::Is) => "is",
                Some(Comparison::Above) | None => ">",
            };
            match (c.pass, number(c.value)) {
                (None, _) => format!("{name} not measurable"),
                (_, Some(v)) if !u.is_empty() => format!(
                    "{name} {v:.2} {u} (needs {cmp} {} {u})",
                    as_written(c.threshold)
                ),
                // A length with no value failed because there is nothing to
                // measure: no triple zone for the central coaptation.
                (_, None) if !u.is_empty() && c.value.is_none() => {
                    format!("{name}: none (needs {cmp} {} {u})", as_written(c.threshold))
                }
                _ => format!("{name}: no"),
            }
        })
        .collect();
    let shortfall_mm = criteria
        .iter()
        .filter(|c| c.pass == Some(false) && c.unit == "mm")
        .filter_map(|c| Some((number(c.value)? - number(c.threshold)?).abs()))
        .sum();
    let m = &doc.metrics;
    let passed = criteria.len() - failures.len();
    let not_assessable = doc.verdict.status == Some(Status::NotAssessable);
    // A closure that cannot be judged (crossing leaflets, no convergence)
    // says so before any criterion: its passes are not passes.
    let mut failures = failures;
    if not_assessable {
        let gates: Vec<String> = doc
            .verdict
            .not_assessable_reasons
            .iter()
            .filter(|r| !r.contains(" is not measurable ("))
            .map(|r| format!("not assessable: {r}"))
            .collect();
        failures.splice(0..0, gates);
    }
    Measured {
        closed: m.closed.unwrap_or(false),
        meets_all: doc.verdict.meets_all_criteria == Some(true),
        assessable: !not_assessable,
        passed,
        judged: criteria.len(),
        failures,
        shortfall_mm,
        coaptation_height_mm: m.coaptation_height_mm,
        central_coaptation_height_mm: m.central_coaptation_height_mm,
        effective_height_mm: m.effective_height_mm,
        coaptation_area_mm2: m.coaptation_area_mm2.max,
        leaflet_area_mm2: mean(&m.leaflet_area_mm2),
        free_edge_length_mm: mean(&m.free_edge_length_mm),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::config::RunConfig;

    #[test]
    fn a_cuts_config_reads_back_with_the_same_values() {
        let registry = crate::stages::registry();
        let mut sections = BTreeMap::new();
        let mut leaflets = BTreeMap::new();
        leaflets.insert(
            "h".to_string(),
            Value::Quantity(0.7, crate::units::Kind::Length),
        );
        sections.insert("leaflets".to_string(), leaflets);
        let mut report = BTreeMap::new();
        report.insert("refine".to_string(), Value::Int(3));
        sections.insert("report".to_string(), report);
        // A section of an upstream stage is not the size's business.
        sections.insert("segment".to_string(), BTreeMap::new());
        let mut inputs = BTreeMap::new();
        inputs.insert(
            "valve".to_string(),
            PathBuf::from("/runs/p \"1\"/valve.json"),
        );
        let text = config(Cut::Size(21), &inputs, &sections);
        let cfg = RunConfig::parse(Path::new("/d/size-21/run.toml"), &text, registry).unwrap();
        assert_eq!(cfg.inputs["valve"], Path::new("/runs/p \"1\"/valve.json"));
        assert_eq!(
            cfg.inputs["template"],
            Path::new("/d/size-21/template.toml")
        );
        assert_eq!(cfg.sections["leaflets"], sections["leaflets"]);
        assert_eq!(cfg.sections["report"], sections["report"]);
        assert!(!cfg.has_section("segment"));
        let t = crate::template::parse_templates(&template(21), None).unwrap();
        assert!(t.iter().all(|t| t.name() == "ozaki_size 21"));
    }

    #[test]
    fn measured_reads_failures_in_words() {
        let doc = serde_json::json!({
            "verdict": {"meets_all_criteria": false},
            "criteria": [
                {"name": "Central coaptation height", "value": 3.2, "unit": "mm", "comparison": ">", "threshold": 4.0, "pass": false},
                {"name": "Effective height", "value": 9.5, "unit": "mm", "comparison": ">", "threshold": 9.0, "pass": true},
                {"name": "Valve closed", "value": false, "unit": "", "comparison": "is", "threshold": true, "pass": false},
                {"name": "No prolapse", "value": null, "unit": "", "comparison": "is", "threshold": true, "pass": null},
                {"name": "Central coaptation height", "value": null, "unit": "mm", "comparison": ">", "threshold": 4.0, "pass": false}
            ],
            "metrics": {"closed": false, "coaptation_height_mm": 5.0, "central_coaptation_height_mm": null,
                        "effective_height_mm": 9.5, "coaptation_area_mm2": {"max": 40.0},
                        "leaflet_area_mm2": [300.0, 310.0, 320.0], "free_edge_length_mm": [30.0, null, 30.0]}
        });
        let m = measured(&serde_json::from_value(doc).unwrap());
        assert_eq!((m.passed, m.judged, m.meets_all), (1, 5, false));
        assert_eq!(
            m.failures,
            [
                "Central coaptation height 3.20 mm (needs > 4.0 mm)",
                "Valve closed: no",
                "No prolapse not measurable",
                "Central coaptation height: none (needs > 4.0 mm)"
            ]
        );
        // Only the failed millimetre criterion counts: 4.0 − 3.2.
        assert!((m.shortfall_mm - 0.8).abs() < 1e-12, "{}", m.shortfall_mm);
        assert_eq!(m.leaflet_area_mm2, Some(310.0));
        assert_eq!(m.free_edge_length_mm, None);
        assert_eq!(m.central_coaptation_height_mm, None);
    }
}
