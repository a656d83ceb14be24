//! The case header: which patient, which leaflets, which material and load.
//! A surgeon reads it before the verdict, and a researcher needs it to
//! repeat the prediction; every value comes from the run's own artifacts
//! (valve.json, leaflets.json, closure.json, manifest.json), none is typed
//! twice.

use std::path::Path;

use serde_json::Value as Json;

use coapt_geom::ValveFrame;
use coapt_io::report_json::{Anatomy, Case, CaseLeaflet, LandmarkPoint, Landmarks, finite};
use coapt_pipeline::manifest::Manifest;

/// What the header is gathered from; every source but the valve is optional.
pub struct Sources<'a> {
    /// The run directory (its name names the case; its manifest dates it).
    pub run_dir: Option<&'a Path>,
    /// valve.json as read.
    pub valve: &'a Json,
    pub frame: &'a ValveFrame,
    /// leaflets.json (templates, mesh size, placement).
    pub placement: Option<&'a Json>,
    /// closure.json (material, load, contact).
    pub log: Option<&'a Json>,
    /// The landmarks file the valve frame came from.
    pub landmarks: Option<&'a Path>,
    /// landmarks.json of the landmarks stage, when coapt detected them.
    pub detection: Option<&'a Json>,
}

/// The `case` object of report.json.
pub fn build(s: &Sources) -> Case {
    let name = s
        .run_dir
        .and_then(|d| d.canonicalize().ok().or_else(|| Some(d.to_path_buf())))
        .and_then(|d| d.file_name().map(|n| n.to_string_lossy().into_owned()));
    let manifest = s.run_dir.and_then(|d| Manifest::load(d).ok());
    // The date of the prediction is when its closure ran; a report re-made
    // later from the same run keeps it, so the same run gives the same page.
    let computed = manifest.as_ref().and_then(|m| {
        m.stages
            .iter()
            .rev()
            .find(|r| r.stage == "close")
            .map(|r| r.started.clone())
    });
    let section = |key: &str| s.valve["sections"][key]["equivalent_diameter_mm"].as_f64();
    let anatomy = Anatomy {
        annulus_diameter_mm: section("annulus"),
        sinus_diameter_mm: section("sinus"),
        stj_diameter_mm: section("stj"),
        intercommissural_mm: s
            .frame
            .intercommissural_mm()
            .iter()
            .map(|&d| finite(d))
            .collect(),
        annulus_plane_tilt_deg: s.valve["annulus_plane_tilt_deg"].as_f64(),
        diameter_definition: "area-equivalent diameter of the lumen section (valve.json sections)"
            .into(),
    };
    let leaflets = s
        .placement
        .and_then(|p| p["leaflets"].as_array())
        .map(|ls| {
            ls.iter()
                .map(|l| CaseLeaflet {
                    template: l["template"].as_str().map(str::to_string),
                    free_edge_mm: l["free_edge_mm"].as_f64(),
                    attachment_mm: l["attachment_mm"].as_f64(),
                    placement: placement_of(l),
                })
                .collect()
        })
        .unwrap_or_default();
    let text = |v: &Json| v.as_str().map(str::to_string);
    let landmarks = match (s.detection, s.landmarks) {
        (Some(d), _) => Some(Landmarks::Detected {
            points: d["points"].as_array().map(|ps| {
                ps.iter()
                    .map(|p| LandmarkPoint {
                        label: text(&p["label"]),
                        confidence: p["confidence"].as_f64(),
                        source: p["source"].as_str().unwrap_or("detected").to_string(),
                        given_to_detected_mm: p["given_to_detected_mm"].as_f64(),
                    })
                    .collect()
            }),
            findings: strings(&d["findings"]),
            sinuses: serde_json::from_value(d["sinuses"].clone()).unwrap_or_default(),
            sinus_naming: serde_json::from_value(d["sinus_naming"].clone()).unwrap_or_default(),
            leaflet_sinuses: strings(&d["leaflet_sinuses"]),
        }),
        (None, Some(p)) => Some(Landmarks::Given {
            file: p.display().to_string(),
        }),
        (None, None) => None,
    };
    let cfg = s.log.map(|l| &l["config"]);
    let field = |k: &str| cfg.map_or(Json::Null, |c| c[k].clone());
    Case {
        name,
        computed_utc: computed,
        coapt_version: env!("CARGO_PKG_VERSION").into(),
        anatomy,
        landmarks,
        leaflets,
        mesh_h_mm: s.placement.and_then(|p| p["h_mm"].as_f64()),
        material: field("model"),
        material_source: text(&field("material_source")),
        thickness_mm: field("thickness_mm").as_f64(),
        pressure_mmhg: field("pressure_mmhg").as_f64(),
        effective_height_pressure_mmhg: field("effective_height_pressure_mmhg").as_f64(),
        contact: text(&field("contact")),
        bending: field("bending").as_bool(),
        reference: text(&field("reference")),
        solver: text(&field("solver")),
    }
}

/// The strings of a JSON list (none when it is not one).
fn strings(v: &Json) -> Vec<String> {
    v.as_array()
        .into_iter()
        .flatten()
        .filter_map(|x| x.as_str().map(str::to_string))
        .collect()
}

fn placement_of(l: &Json) -> Option<String> {
    if l["hanging"].is_object() {
        Some("hanging".into())
    } else {
        l["omega_used_deg"]
            .as_f64()
            .map(|w| format!("extruded, ω {w:.0}°"))
    }
}

/// The material in words with its units: "GOH: μ 900 kPa, k₁ 1100 kPa,
/// k₂ 1000, κ 0.29".
pub fn material_text(m: &Json) -> Option<String> {
    let kpa = |k: &str| m[k].as_f64().map(|v| format!("{} kPa", trim(v)));
    let num = |k: &str| m[k].as_f64().map(trim);
    let list = |k: &str| {
        m[k].as_array().map(|a| {
            a.iter()
                .filter_map(Json::as_f64)
                .map(trim)
                .collect::<Vec<_>>()
                .join(" / ")
        })
    };
    let parts: Vec<(&str, Option<String>)> = match m["law"].as_str()? {
        "goh" => vec![
            ("μ", kpa("mu_kpa")),
            ("k₁", kpa("k1_kpa")),
            ("k₂", num("k2")),
            ("κ", num("kappa")),
        ],
        "neo-hookean" => vec![("μ", kpa("mu_kpa"))],
        "gent" => vec![("μ", kpa("mu_kpa")), ("J_m", num("jm"))],
        "svk" => vec![("E", kpa("young_kpa")), ("ν", num("poisson"))],
        "msm" => vec![
            ("E", kpa("young_kpa")),
            (
                "tangent moduli",
                list("tangent_moduli_kpa").map(|s| format!("{s} kPa")),
            ),
            (
                "fibre moduli",
                list("fibre_tangent_moduli_kpa").map(|s| format!("{s} kPa")),
            ),
            (
                "cross-fibre moduli",
                list("cross_tangent_moduli_kpa").map(|s| format!("{s} kPa")),
            ),
            ("breakpoint strains", list("breakpoint_strains")),
        ],
        other => return Some(other.to_string()),
    };
    let law = match m["law"].as_str()? {
        "goh" => "GOH (Gasser–Ogden–Holzapfel)",
        "neo-hookean" => "neo-Hookean",
        "gent" => "Gent",
        "svk" => "St. Venant–Kirchhoff",
        _ => "mass-spring (MSM)",
    };
    let params: Vec<String> = parts
        .into_iter()
        .filter_map(|(k, v)| v.map(|v| format!("{k} {v}")))
        .collect();
    Some(if params.is_empty() {
        law.to_string()
    } else {
        format!("{law}: {}", params.join(", "))
    })
}

/// Shortest decimal that reads back as the same number, without a
/// trailing ".0" on whole numbers.
fn trim(v: f64) -> String {
    let s = format!("{v}");
    s.strip_suffix(".0").map(str::to_string).unwrap_or(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn material_reads_with_units_and_no_debug_syntax() {
        let m =
            json!({"law": "goh", "mu_kpa": 900.0, "k1_kpa": 1100.0, "k2": 1000.0, "kappa": 0.29});
        assert_eq!(
            material_text(&m).unwrap(),
            "GOH (Gasser–Ogden–Holzapfel): μ 900 kPa, k₁ 1100 kPa, k₂ 1000, κ 0.29"
        );
        let msm = json!({"law": "msm", "tangent_moduli_kpa": [106.0, 569.0, 1200.0], "breakpoint_strains": [0.175, 0.3]});
        assert_eq!(
            material_text(&msm).unwrap(),
            "mass-spring (MSM): tangent moduli 106 / 569 / 1200 kPa, breakpoint strains 0.175 / 0.3"
        );
        assert_eq!(material_text(&json!(null)), None);
    }

    #[test]
    fn every_close_config_model_has_words() {
        // The record the close stage writes, for every law it accepts.
        for text in [
            "model = \"goh\"\nmu = \"900 kPa\"\nk1 = \"1100 kPa\"\nk2 = 1000\nkappa = 0.29\n",
            "model = \"neo-hookean\"\nmu = \"300 kPa\"\n",
            "model = \"gent\"\nmu = \"300 kPa\"\n",
            "model = \"svk\"\nyoung = \"1 MPa\"\npoisson = 0.45\n",
            "model = \"msm\"\n",
            "model = \"msm\"\nmsm_law = \"linear\"\nyoung = \"1 MPa\"\n",
            "model = \"msm\"\nmsm_law = \"seed000-anisotropic\"\n",
        ] {
            let cfg = coapt_mech::config::parse(&format!(
                "{text}thickness = \"0.5 mm\"\npressure = \"80 mmHg\"\n"
            ))
            .unwrap();
            let words = material_text(&cfg.model.to_json()).unwrap();
            assert!(!words.contains('{') && !words.contains("Some("), "{words}");
            assert!(words.contains("kPa"), "{words}: a modulus without its unit");
        }
    }
}
