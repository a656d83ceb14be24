//! `report.json` (`coapt-report/2`, schema `schemas/report.schema.json`,
//! keys in docs/report.md): the typed document the report stage builds and
//! writes, and from which the page (`report.html`), the terminal's verdict,
//! `coapt design` and `coapt cohort summary` read.
//!
//! Every number is an `Option`: `null` in the file when it was not measured
//! or not finite, and "not measured" on the page. Every struct takes its
//! defaults for missing keys, so an older or partial report still reads; a
//! key of the wrong type is an error naming the file. Fields are declared in
//! the order the file lists them.
//!
//! Two parts are copies of other artifacts and stay JSON as those write
//! them: the stage parameters and close config (`parameters`, shown as
//! they are) and the material record of closure.json (`case.material`,
//! one shape per law).

use std::path::Path;

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value as Json};

use coapt_base::{Error, Result};

use crate::design_json::Design;

/// The `schema` field.
pub const SCHEMA: &str = "coapt-report/2";

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Report {
    pub schema: String,
    pub coapt_version: String,
    /// World frame of every point ("LPS").
    pub frame: String,
    pub verdict: Verdict,
    pub criteria: Vec<Criterion>,
    pub metrics: Metrics,
    pub leaflets: Vec<Leaflet>,
    pub conventions: Conventions,
    pub findings: Vec<Finding>,
    pub solver: Solver,
    /// Seconds per stage, from the run's manifest and this stage.
    pub timing_s: IndexMap<String, Option<f64>>,
    /// Every input file by its port name.
    pub inputs: IndexMap<String, InputFile>,
    /// The report stage's parameters (canonical text), the contact margin
    /// and the close config as closure.json records it.
    pub parameters: Map<String, Json>,
    pub case: Option<Case>,
    /// The leaflet-size sweep, when `coapt design` made this report.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub design: Option<Design>,
}

impl Report {
    /// Read `path`; an error names the file and the key of the wrong type.
    pub fn read(path: &Path) -> Result<Report> {
        let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
        let bad = |why: String| Error::bad_input(path, format!("not a coapt report.json: {why}"));
        let v: Json = serde_json::from_slice(&bytes)
            .map_err(|e| Error::bad_input(path, format!("not valid JSON: {e}")))?;
        if !v.is_object() {
            return Err(bad("the document is not a JSON object".into()));
        }
        serde_json::from_value(v).map_err(|e| bad(e.to_string()))
    }

    /// The file's text: pretty JSON and a final newline.
    pub fn to_text(&self) -> String {
        serde_json::to_string_pretty(self).expect("a report serialises") + "\n"
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    MeetsAllCriteria,
    FailsCriteria,
    NotAssessable,
}

impl Status {
    /// As the file writes it.
    pub fn name(self) -> &'static str {
        match self {
            Status::MeetsAllCriteria => "meets_all_criteria",
            Status::FailsCriteria => "fails_criteria",
            Status::NotAssessable => "not_assessable",
        }
    }
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Verdict {
    pub status: Option<Status>,
    pub closed: Option<bool>,
    pub assessable: Option<bool>,
    pub not_assessable_reasons: Vec<String>,
    pub meets_all_criteria: Option<bool>,
    /// Ids of the failed criteria.
    pub failed_criteria: Vec<String>,
    /// One or two sentences for the reader.
    pub summary: String,
}

/// A criterion's value or threshold: a length or area, or yes/no.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Quantity {
    Bool(bool),
    Number(f64),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Comparison {
    /// Strictly above the threshold.
    #[serde(rename = ">")]
    Above,
    /// At most the threshold.
    #[serde(rename = "<=")]
    AtMost,
    /// Equal to the threshold (true).
    #[serde(rename = "is")]
    Is,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Criterion {
    pub id: String,
    pub name: String,
    /// `None`: nothing to measure (with `pass` false) or not measurable
    /// (with `pass` null).
    pub value: Option<Quantity>,
    /// "mm", "mm2" or "" for yes/no.
    pub unit: String,
    pub comparison: Option<Comparison>,
    pub threshold: Option<Quantity>,
    /// `None`: could not be judged.
    pub pass: Option<bool>,
    pub note: String,
    /// Where the criterion and its threshold come from.
    pub source: String,
}

/// Coaptation area per leaflet and its spread.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AreaSpread {
    pub per_leaflet: Vec<Option<f64>>,
    pub max: Option<f64>,
    pub min: Option<f64>,
}

/// The valve's numbers (units in the names; heights above the annulus
/// plane along the valve axis).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Metrics {
    pub coaptation_height_mm: Option<f64>,
    pub central_coaptation_height_mm: Option<f64>,
    pub coaptation_area_mm2: AreaSpread,
    /// The one the criterion judges, at `effective_height_pressure_mmhg`.
    pub effective_height_mm: Option<f64>,
    pub effective_height_pressure_mmhg: Option<f64>,
    pub effective_height_closing_pressure_mm: Option<f64>,
    pub closing_pressure_mmhg: Option<f64>,
    pub effective_height_low_pressure_mm: Option<f64>,
    pub low_pressure_mmhg: Option<f64>,
    pub central_coaptation_top_above_annulus_mm: Option<f64>,
    pub lowest_commissure_above_annulus_mm: Option<f64>,
    pub highest_leaflet_above_annulus_mm: Option<f64>,
    pub stj_above_annulus_mm: Option<f64>,
    pub h_cc_mm: Option<f64>,
    pub h_avr_mm: Option<f64>,
    pub ncca: Option<f64>,
    pub regurgitant_orifice_area_mm2: Option<f64>,
    pub lumen_area_mm2: Option<f64>,
    pub regurgitant_orifice_pixel_mm: Option<f64>,
    pub coaptation_above_vaj: Option<bool>,
    pub closed: Option<bool>,
    pub free_edge_length_mm: Vec<Option<f64>>,
    pub leaflet_area_mm2: Vec<Option<f64>>,
    pub cusp_area_closed_mm2: Vec<Option<f64>>,
    pub billowing_mm: Vec<Option<f64>>,
    pub lowest_free_edge_above_annulus_mm: Option<f64>,
    pub lowest_coaptation_above_annulus_mm: Option<f64>,
    pub lowest_central_coaptation_above_annulus_mm: Option<f64>,
}

/// One leaflet's numbers.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Leaflet {
    /// 1-based.
    pub index: Option<u64>,
    pub coaptation_area_mm2: Option<f64>,
    pub free_edge_length_mm: Option<f64>,
    pub leaflet_area_mm2: Option<f64>,
    pub cusp_area_closed_mm2: Option<f64>,
    pub billowing_mm: Option<f64>,
    pub central_free_edge_height_mm: Option<f64>,
    pub lowest_free_edge_mm: Option<f64>,
    pub h_avr_mm: Option<f64>,
    pub ncca: Option<f64>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Conventions {
    pub seeds: SeedsConvention,
    pub slicerheart: SlicerHeartConvention,
}

/// The seeds' group's contact-margin measures.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SeedsConvention {
    pub description: String,
    pub margin_mm: Option<f64>,
    /// Times a partially touching triangle is refined.
    pub refinement: Option<u64>,
    pub pairs: Vec<SeedsPair>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SeedsPair {
    /// 1-based.
    pub leaflets: Vec<u64>,
    pub coaptation_height_mm: Option<f64>,
    pub h_cc_mm: Option<f64>,
    /// On the first leaflet touching the second, and the other way round.
    pub area_mm2: Vec<Option<f64>>,
}

/// SlicerHeart's base line to margin line measures.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SlicerHeartConvention {
    pub description: String,
    pub pairs: Vec<SlicerHeartPair>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SlicerHeartPair {
    /// 1-based.
    pub leaflets: Vec<u64>,
    pub area_mm2: Option<f64>,
    pub height_mm: Option<Stats>,
}

/// A distribution: extremes, mean and percentiles.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Stats {
    pub min: Option<f64>,
    pub mean: Option<f64>,
    pub max: Option<f64>,
    pub p10: Option<f64>,
    pub p25: Option<f64>,
    pub p50: Option<f64>,
    pub p75: Option<f64>,
    pub p90: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Severity {
    Error,
    Warning,
    Info,
}

/// Something the reader must know that is not a number.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Finding {
    pub severity: Severity,
    pub message: String,
}

/// The closure's solve, from closure.json.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Solver {
    pub converged: Option<bool>,
    pub iterations: Option<u64>,
    pub residual_n: Option<f64>,
    pub reason: Option<String>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct InputFile {
    pub path: String,
    pub blake3: String,
    pub bytes: Option<u64>,
}

/// Who and what: the case, the root the CT gave, the leaflets, the material
/// and the load.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Case {
    /// The run directory's name.
    pub name: Option<String>,
    /// When the closure ran (from the manifest).
    pub computed_utc: Option<String>,
    pub coapt_version: String,
    pub anatomy: Anatomy,
    pub landmarks: Option<Landmarks>,
    pub leaflets: Vec<CaseLeaflet>,
    pub mesh_h_mm: Option<f64>,
    /// closure.json's material record (`config.model`).
    pub material: Json,
    pub material_source: Option<String>,
    pub thickness_mm: Option<f64>,
    pub pressure_mmhg: Option<f64>,
    pub effective_height_pressure_mmhg: Option<f64>,
    /// "leaflets", "planes" or "none".
    pub contact: Option<String>,
    pub bending: Option<bool>,
    /// The stress-free state: "sutured", "placed" or "flat".
    pub reference: Option<String>,
    pub solver: Option<String>,
}

/// The root as the CT gave it (valve.json).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Anatomy {
    pub annulus_diameter_mm: Option<f64>,
    pub sinus_diameter_mm: Option<f64>,
    pub stj_diameter_mm: Option<f64>,
    /// C1–C2, C2–C3, C3–C1.
    pub intercommissural_mm: Vec<Option<f64>>,
    pub annulus_plane_tilt_deg: Option<f64>,
    pub diameter_definition: String,
}

/// Where the landmarks came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "source", rename_all = "snake_case")]
pub enum Landmarks {
    /// Found by the landmarks stage (landmarks.json), a user's points
    /// overriding some.
    Detected {
        #[serde(default)]
        points: Option<Vec<LandmarkPoint>>,
        #[serde(default)]
        findings: Vec<String>,
        /// landmarks.json's `sinuses`.
        #[serde(default)]
        sinuses: Vec<Sinus>,
        /// landmarks.json's `sinus_naming`.
        #[serde(default)]
        sinus_naming: Option<SinusNaming>,
        /// The sinus each leaflet is sewn in, leaflets 1–3.
        #[serde(default)]
        leaflet_sinuses: Vec<String>,
    },
    /// A user's file.
    Given { file: String },
}

/// A sinus of the root, by the nadir at its floor (landmarks.json).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Sinus {
    pub nadir: String,
    /// "right_coronary", "left_coronary" or "non_coronary".
    pub name: String,
    /// The coronary ostium seen in the CT, when one was.
    pub ostium: Option<Ostium>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Ostium {
    /// The patch's mean wall point, LPS mm.
    pub point_mm: [f64; 3],
    /// Above the annulus plane.
    pub height_mm: f64,
    /// About the root axis.
    pub angle_deg: f64,
    /// Of the patch on the wall.
    pub area_mm2: f64,
}

/// How the sinuses were named (landmarks.json).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SinusNaming {
    /// "coronary_ostia" (two ostia seen) or "position" (the sinus facing
    /// anterior is the right-coronary one).
    pub by: String,
    pub confidence: Option<f64>,
    pub agrees_with_position: Option<bool>,
    /// Whether a CT was searched for ostia.
    pub ct_searched: bool,
    pub lumen_hu: Option<f64>,
    pub threshold_hu: Option<f64>,
    /// Patches that did not count as an ostium.
    pub other_patches: Option<u64>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LandmarkPoint {
    pub label: Option<String>,
    pub confidence: Option<f64>,
    /// "detected" or "given".
    pub source: String,
    /// For a given point: how far from it coapt found the point.
    pub given_to_detected_mm: Option<f64>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CaseLeaflet {
    pub template: Option<String>,
    pub free_edge_mm: Option<f64>,
    pub attachment_mm: Option<f64>,
    /// "hanging" or "extruded, ω …°".
    pub placement: Option<String>,
}

/// `x` when finite: what the file can hold as a number.
pub fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> &'static str {
        include_str!("../../../schemas/report.example.json")
    }

    /// The committed example reads into the document and writes back the
    /// same JSON value: no key is dropped or renamed.
    #[test]
    fn the_example_reads_and_writes_back_unchanged() {
        let r: Report = serde_json::from_str(example()).unwrap();
        assert_eq!(r.schema, SCHEMA);
        assert!(r.case.is_some() && r.verdict.status.is_some());
        let back = serde_json::to_value(&r).unwrap();
        let want: Json = serde_json::from_str(example()).unwrap();
        assert_eq!(back, want);
    }

    #[test]
    fn status_names_are_what_the_file_holds() {
        for s in [
            Status::MeetsAllCriteria,
            Status::FailsCriteria,
            Status::NotAssessable,
        ] {
            assert_eq!(serde_json::to_value(s).unwrap(), Json::from(s.name()));
        }
    }

    /// Missing keys take their defaults; a key of the wrong type is an
    /// error that names it.
    #[test]
    fn missing_keys_default_and_wrong_types_are_named() {
        let r: Report = serde_json::from_str("{}").unwrap();
        assert_eq!(r, Report::default());
        let e = serde_json::from_str::<Report>(r#"{"metrics": {"closed": "yes"}}"#).unwrap_err();
        assert!(e.to_string().contains("invalid type"), "{e}");
    }

    #[test]
    fn a_missing_file_or_a_document_not_an_object_is_named() {
        let e = Report::read(Path::new("/nonexistent/report.json")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/report.json"), "{e}");
        let dir = std::env::temp_dir().join(format!("coapt-report-json-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("report.json");
        for (text, says) in [
            ("{ not json", "not valid JSON"),
            ("[]", "not a JSON object"),
            ("{\"solver\": 3}", "invalid type"),
        ] {
            std::fs::write(&p, text).unwrap();
            let e = Report::read(&p).unwrap_err().to_string();
            assert!(e.contains("report.json") && e.contains(says), "{e}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
