//! `design.json` (`coapt-design/1`), written by `coapt design` and read by
//! the report stage and `coapt cohort summary`: the typed document, its
//! schema name and where each size's run lives, so that neither reader
//! needs the design module. No timings, so the same inputs give the same
//! bytes.

use std::path::Path;

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use coapt_base::{Error, Result};

/// The `schema` field of design.json.
pub const SCHEMA: &str = "coapt-design/1";

/// Where one size's run lives, relative to the design directory.
pub fn size_dir(size: u32) -> String {
    format!("size-{size}")
}

/// Every size tried, what its closure gave, and the recommendation with its
/// reason.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Design {
    pub schema: String,
    pub coapt_version: String,
    /// "ozaki_size": the sizes are Ozaki sizer numbers.
    pub template_family: String,
    pub recommended_size: Option<u32>,
    /// The size whose closure the design's own report shows.
    pub shown_size: Option<u32>,
    pub reason: String,
    /// C1–C2, C2–C3, C3–C1.
    pub intercommissural_distance_mm: Option<Vec<f64>>,
    pub ozaki_rule_sizes: Option<Vec<Option<u32>>>,
    /// Ozaki's rule and its gap to the recommendation, in words.
    pub ozaki_rule: Option<String>,
    pub ozaki_rule_closure: Option<Closure>,
    pub sizes: Vec<Closure>,
    /// The canonical parameters of each stage the sweep re-ran.
    pub parameters: IndexMap<String, IndexMap<String, String>>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ClosureStatus {
    /// Closed and judged.
    Measured,
    /// The chain stopped; `error` says why.
    Failed,
}

/// One closure of the sweep: a size's, or the closure of Ozaki's rule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Closure {
    /// Its run directory, relative to the design directory.
    pub run: String,
    /// Per leaflet.
    pub leaflet_sizes: Vec<Option<u32>>,
    pub status: ClosureStatus,
    #[serde(default)]
    pub error: Option<String>,
    #[serde(default)]
    pub closed: Option<bool>,
    #[serde(default)]
    pub meets_all_criteria: bool,
    #[serde(default)]
    pub criteria_passed: Option<u64>,
    #[serde(default)]
    pub criteria_judged: Option<u64>,
    /// The failed criteria, each with its value and threshold.
    #[serde(default)]
    pub failures: Vec<String>,
    /// Sum of the failed length criteria's distances to their thresholds.
    #[serde(default)]
    pub criteria_shortfall_mm: Option<f64>,
    #[serde(default)]
    pub coaptation_height_mm: Option<f64>,
    #[serde(default)]
    pub central_coaptation_height_mm: Option<f64>,
    #[serde(default)]
    pub effective_height_mm: Option<f64>,
    #[serde(default)]
    pub coaptation_area_mm2: Option<f64>,
    #[serde(default)]
    pub leaflet_area_mm2: Option<f64>,
    #[serde(default)]
    pub free_edge_length_mm: Option<f64>,
    /// The sizer size, for a size of the sweep (not for Ozaki's rule).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<u32>,
}

impl Closure {
    /// A closure of `run` that measured nothing (status failed, no error
    /// named yet): the record a result fills in.
    pub fn unmeasured(run: &str, leaflet_sizes: &[Option<u32>]) -> Closure {
        Closure {
            run: run.into(),
            leaflet_sizes: leaflet_sizes.to_vec(),
            status: ClosureStatus::Failed,
            error: None,
            closed: None,
            meets_all_criteria: false,
            criteria_passed: None,
            criteria_judged: None,
            failures: Vec::new(),
            criteria_shortfall_mm: None,
            coaptation_height_mm: None,
            central_coaptation_height_mm: None,
            effective_height_mm: None,
            coaptation_area_mm2: None,
            leaflet_area_mm2: None,
            free_edge_length_mm: None,
            size: None,
        }
    }
}

impl Design {
    /// Read `path`, which must be a sweep of this schema.
    pub fn read(path: &Path) -> Result<Design> {
        let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
        let refuse = |why: String| {
            Error::bad_input(
                path,
                format!(
                    "not a design sweep (expected schema \"{SCHEMA}\" with a sizes list, as `coapt design` writes): {why}"
                ),
            )
        };
        let d: Design = serde_json::from_slice(&bytes).map_err(|e| refuse(e.to_string()))?;
        if d.schema != SCHEMA {
            return Err(refuse(format!("its schema is \"{}\"", d.schema)));
        }
        Ok(d)
    }

    /// The file's text: pretty JSON and a final newline.
    pub fn to_text(&self) -> String {
        serde_json::to_string_pretty(self).expect("a design serialises") + "\n"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What `to_text` writes reads back equal; another schema, or a file
    /// that is not a sweep, is refused with the file named.
    #[test]
    fn a_sweep_reads_back_and_another_schema_is_refused() {
        let d = Design {
            schema: SCHEMA.into(),
            recommended_size: Some(21),
            sizes: vec![Closure {
                error: Some("the closure did not converge".into()),
                size: Some(21),
                ..Closure::unmeasured(&size_dir(21), &[Some(21); 3])
            }],
            ..Design::default()
        };
        let dir = std::env::temp_dir().join(format!("coapt-design-json-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("design.json");
        std::fs::write(&p, d.to_text()).unwrap();
        assert_eq!(Design::read(&p).unwrap(), d);
        for (text, says) in [
            (
                "{\"schema\": \"coapt-report/2\"}",
                "its schema is \"coapt-report/2\"",
            ),
            (
                "{\"schema\": \"coapt-design/1\", \"sizes\": 3}",
                "invalid type",
            ),
            ("not json", "expected"),
        ] {
            std::fs::write(&p, text).unwrap();
            let e = Design::read(&p).unwrap_err().to_string();
            assert!(
                e.contains("design.json") && e.contains("not a design sweep") && e.contains(says),
                "{e}"
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
