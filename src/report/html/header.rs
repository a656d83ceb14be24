//! The case header above the verdict: who and what, the root the CT gave,
//! the leaflets, the material and load.

use std::fmt::Write as _;

use serde_json::Value;

use super::format::*;
use super::{DASH, NOT_MEASURED};

/// Who and what: the case, the root the CT gave, the leaflets, the material
/// and load, in a few lines above the verdict.
pub(super) fn case_header(h: &mut String, c: Option<&Value>) {
    let Some(c) = c.filter(|c| c.is_object()) else {
        return;
    };
    h.push_str("<section id=\"case\">\n<dl class=\"case\">\n");
    let mut row = |k: &str, v: String| {
        if !v.is_empty() {
            let _ = writeln!(h, "<dt>{}</dt><dd>{}</dd>", esc(k), v);
        }
    };
    let mut first = vec![esc(&text_or(c.get("name"), "unnamed case"))];
    if let Some(t) = c.get("computed_utc").and_then(Value::as_str) {
        // "2026-11-27T19:29:54Z" → "2026-11-27 19:29 UTC"
        let shown = match (t.get(..10), t.get(11..16)) {
            (Some(d), Some(hm)) => format!("{d} {hm} UTC"),
            _ => t.to_string(),
        };
        first.push(format!("predicted {}", esc(&shown)));
    }
    first.push(format!(
        "coapt {}",
        esc(&text_or(c.get("coapt_version"), DASH))
    ));
    row("Case", first.join(" · "));

    let a = c.get("anatomy");
    let d = |k: &str| {
        num(a.and_then(|a| a.get(k))).map_or(NOT_MEASURED.to_string(), |x| {
            with_unit(&fixed(Some(x), 1), "mm")
        })
    };
    let ic: Vec<String> = array(a.and_then(|a| a.get("intercommissural_mm")))
        .iter()
        .map(|v| fixed(v.as_f64(), 1))
        .collect();
    let mut root = format!(
        "annulus {}, sinus {}, STJ {} (area-equivalent diameters)",
        d("annulus_diameter_mm"),
        d("sinus_diameter_mm"),
        d("stj_diameter_mm")
    );
    if ic.len() == 3 {
        let _ = write!(
            root,
            "; intercommissural distances C1–C2 / C2–C3 / C3–C1 {} mm",
            ic.join(" / ")
        );
    }
    if let Some(t) = num(a.and_then(|a| a.get("annulus_plane_tilt_deg"))) {
        let _ = write!(
            root,
            "; annulus plane tilted {}° to the commissures' axis",
            fixed(Some(t), 1)
        );
    }
    row("Root (from the CT)", root);

    let lm = c.get("landmarks");
    match lm.and_then(|l| l.get("source")).and_then(Value::as_str) {
        Some("detected") => {
            let points: Vec<String> = array(lm.and_then(|l| l.get("points")))
                .iter()
                .map(|p| {
                    let label = esc(&text_or(p.get("label"), "?"));
                    match p.get("source").and_then(Value::as_str) {
                        Some("given") => format!(
                            "{label} given ({} mm from where coapt found it)",
                            fixed(num(p.get("given_to_detected_mm")), 1)
                        ),
                        _ => format!("{label} {}", fixed(num(p.get("confidence")), 2)),
                    }
                })
                .collect();
            row(
                "Landmarks",
                format!(
                    "detected by coapt from the segmented root (not placed by hand: check them on the CT figure), except those given; confidence {}",
                    points.join(", ")
                ),
            );
            if let Some(text) = sinus_names(lm) {
                row("Sinuses", text);
            }
        }
        Some("given") => row(
            "Landmarks",
            format!(
                "given: {}",
                esc(&text_or(lm.and_then(|l| l.get("file")), DASH))
            ),
        ),
        _ => {}
    }

    let ls = array(c.get("leaflets"));
    if !ls.is_empty() {
        let names: Vec<String> = ls
            .iter()
            .map(|l| text_or(l.get("template"), DASH))
            .collect();
        let mut text = if names.iter().all(|n| *n == names[0]) {
            format!("{} (all three)", esc(&names[0]))
        } else {
            names
                .iter()
                .enumerate()
                .map(|(i, n)| format!("{}: {}", i + 1, esc(n)))
                .collect::<Vec<_>>()
                .join("; ")
        };
        let per = |k: &str| {
            ls.iter()
                .map(|l| fixed(num(l.get(k)), 1))
                .collect::<Vec<_>>()
                .join(" / ")
        };
        let _ = write!(
            text,
            "; free edge {} mm, sutured edge {} mm",
            per("free_edge_mm"),
            per("attachment_mm")
        );
        if let Some(p) = ls[0].get("placement").and_then(Value::as_str) {
            let _ = write!(text, "; placed {}", esc(p));
        }
        if let Some(hm) = num(c.get("mesh_h_mm")) {
            let _ = write!(text, "; mesh size {} mm", shortest(Some(hm)));
        }
        row("Leaflets", text);
    }

    if let Some(m) = c
        .get("material")
        .and_then(crate::report::case::material_text)
    {
        let mut text = esc(&m);
        if let Some(t) = num(c.get("thickness_mm")) {
            let _ = write!(text, "; thickness {} mm", shortest(Some(t)));
        }
        let source = c
            .get("material_source")
            .and_then(Value::as_str)
            .unwrap_or("not stated (close.toml: material_source)");
        let _ = write!(text, "; source: {}", esc(source));
        row("Material", text);
    }
    if let Some(p) = num(c.get("pressure_mmhg")) {
        let mut text = format!("{} mmHg", shortest(Some(p)));
        if let Some(lp) = num(c.get("effective_height_pressure_mmhg")) {
            let _ = write!(
                text,
                " (and {} mmHg for the effective height)",
                shortest(Some(lp))
            );
        }
        let contact = match c.get("contact").and_then(Value::as_str) {
            Some("leaflets") => "true contact between the leaflets",
            Some("planes") => "contact planes through the axis (seed 001)",
            Some("none") => "no contact",
            _ => "",
        };
        if !contact.is_empty() {
            let _ = write!(text, "; {contact}");
        }
        if let Some(b) = c.get("bending").and_then(Value::as_bool) {
            text.push_str(if b {
                "; bending stiffness on"
            } else {
                "; membrane (no bending)"
            });
        }
        if let Some(r) = c.get("reference").and_then(Value::as_str) {
            let _ = write!(text, "; stress-free state: {}", esc(r));
        }
        row("Load and model", text);
    }
    h.push_str("</dl>\n</section>\n");
}

pub(super) fn description(h: &mut String, v: Option<&Value>) {
    if let Some(d) = v.and_then(|v| v.get("description")).and_then(Value::as_str) {
        let _ = writeln!(h, "<p>{}</p>", esc(d));
    }
}

pub(super) fn pair_label(v: Option<&Value>) -> String {
    let l = array(v);
    let idx = |i: usize| {
        l.get(i)
            .and_then(Value::as_u64)
            .map_or("?".to_string(), |x| x.to_string())
    };
    format!("{}–{}", idx(0), idx(1))
}

/// "N1 right coronary (ostium 20.7 mm above the annulus), …; named by the
/// coronary ostia in the CT" from the landmarks stage's sinuses.
pub(super) fn sinus_names(lm: Option<&Value>) -> Option<String> {
    let sinuses = array(lm.and_then(|l| l.get("sinuses")));
    if sinuses.is_empty() {
        return None;
    }
    let each: Vec<String> = sinuses
        .iter()
        .map(|s| {
            let name = text_or(s.get("name"), DASH).replace('_', "-");
            let mut t = format!("{} {}", esc(&text_or(s.get("nadir"), "?")), esc(&name));
            if let Some(h) = num(s.get("ostium").and_then(|o| o.get("height_mm"))) {
                let _ = write!(t, " (ostium {} mm above the annulus)", fixed(Some(h), 1));
            }
            t
        })
        .collect();
    let naming = lm.and_then(|l| l.get("sinus_naming"));
    let how = match naming.and_then(|n| n.get("by")).and_then(Value::as_str) {
        Some("coronary_ostia") => "named by the coronary ostia seen in the CT",
        _ if naming
            .and_then(|n| n.get("ct_searched"))
            .and_then(Value::as_bool)
            == Some(true) =>
        {
            "named by position (the CT did not show two coronary ostia): the sinus facing anterior taken for the right-coronary one"
        }
        _ => {
            "named by position (no CT searched for the coronary ostia): the sinus facing anterior taken for the right-coronary one"
        }
    };
    let leaflets: Vec<String> = array(lm.and_then(|l| l.get("leaflet_sinuses")))
        .iter()
        .map(|n| esc(&text_or(Some(n), DASH).replace('_', "-")))
        .collect();
    let sewn = if leaflets.len() == 3 {
        format!(
            "; leaflets 1 / 2 / 3 sewn in the {} sinuses",
            leaflets.join(" / ")
        )
    } else {
        String::new()
    };
    Some(format!("{}; {how}{sewn}", each.join(", ")))
}
