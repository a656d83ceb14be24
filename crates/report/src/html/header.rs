//! The case header above the verdict: who and what, the root the CT gave,
//! the leaflets, the material and load.

use std::fmt::Write as _;

use super::format::*;
use super::{DASH, NOT_MEASURED};
use coapt_io::report_json::{Case, CaseLeaflet, Landmarks, Sinus, SinusNaming};

/// Who and what: the case, the root the CT gave, the leaflets, the material
/// and load, in a few lines above the verdict.
pub(super) fn case_header(h: &mut String, c: Option<&Case>) {
    let Some(c) = c else {
        return;
    };
    let mut rows = vec![("Case", case_line(c)), ("Root (from the CT)", root_line(c))];
    rows.extend(landmark_rows(c.landmarks.as_ref()));
    for (k, v) in [
        ("Leaflets", leaflets_line(c)),
        ("Material", material_line(c)),
        ("Load and model", load_line(c)),
    ] {
        rows.extend(v.map(|v| (k, v)));
    }
    h.push_str("<section id=\"case\">\n<dl class=\"case\">\n");
    for (k, v) in rows {
        if !v.is_empty() {
            let _ = writeln!(h, "<dt>{}</dt><dd>{}</dd>", esc(k), v);
        }
    }
    h.push_str("</dl>\n</section>\n");
}

/// The case's name, when it was predicted, and by which coapt.
fn case_line(c: &Case) -> String {
    let mut first = vec![esc(c.name.as_deref().unwrap_or("unnamed case"))];
    if let Some(t) = &c.computed_utc {
        // "2026-11-27T19:29:54Z" → "2026-11-27 19:29 UTC"
        let shown = match (t.get(..10), t.get(11..16)) {
            (Some(d), Some(hm)) => format!("{d} {hm} UTC"),
            _ => t.to_string(),
        };
        first.push(format!("predicted {}", esc(&shown)));
    }
    first.push(format!("coapt {}", esc(or(&c.coapt_version, DASH))));
    first.join(" · ")
}

/// The root's diameters, intercommissural distances and annulus tilt.
fn root_line(c: &Case) -> String {
    let a = &c.anatomy;
    let d = |x: Option<f64>| {
        x.filter(|x| x.is_finite())
            .map_or(NOT_MEASURED.to_string(), |x| {
                with_unit(&fixed(Some(x), 1), "mm")
            })
    };
    let ic: Vec<String> = a.intercommissural_mm.iter().map(|&x| fixed(x, 1)).collect();
    let mut root = format!(
        "annulus {}, sinus {}, STJ {} (area-equivalent diameters)",
        d(a.annulus_diameter_mm),
        d(a.sinus_diameter_mm),
        d(a.stj_diameter_mm)
    );
    if ic.len() == 3 {
        let _ = write!(
            root,
            "; intercommissural distances C1–C2 / C2–C3 / C3–C1 {} mm",
            ic.join(" / ")
        );
    }
    if let Some(t) = a.annulus_plane_tilt_deg.filter(|t| t.is_finite()) {
        let _ = write!(
            root,
            "; annulus plane tilted {}° to the commissures' axis",
            fixed(Some(t), 1)
        );
    }
    root
}

/// Where the landmarks came from and, when coapt found them, how sure it
/// is of each and how it named the sinuses.
fn landmark_rows(lm: Option<&Landmarks>) -> Vec<(&'static str, String)> {
    match lm {
        Some(Landmarks::Detected {
            points,
            sinuses,
            sinus_naming,
            leaflet_sinuses,
            ..
        }) => {
            let points: Vec<String> = points
                .iter()
                .flatten()
                .map(|p| {
                    let label = esc(p.label.as_deref().unwrap_or("?"));
                    match p.source.as_str() {
                        "given" => format!(
                            "{label} given ({} mm from where coapt found it)",
                            fixed(p.given_to_detected_mm, 1)
                        ),
                        _ => format!("{label} {}", fixed(p.confidence, 2)),
                    }
                })
                .collect();
            let mut rows = vec![(
                "Landmarks",
                format!(
                    "detected by coapt from the segmented root (not placed by hand: check them on the CT figure), except those given; confidence {}",
                    points.join(", ")
                ),
            )];
            if let Some(text) = sinus_names(sinuses, sinus_naming.as_ref(), leaflet_sinuses) {
                rows.push(("Sinuses", text));
            }
            rows
        }
        Some(Landmarks::Given { file }) => {
            vec![("Landmarks", format!("given: {}", esc(or(file, DASH))))]
        }
        None => Vec::new(),
    }
}

/// The templates, their edges, the placement and the mesh size.
fn leaflets_line(c: &Case) -> Option<String> {
    let ls = &c.leaflets;
    let first = ls.first()?;
    let names: Vec<&str> = ls
        .iter()
        .map(|l| l.template.as_deref().unwrap_or(DASH))
        .collect();
    let mut text = if names.iter().all(|n| *n == names[0]) {
        format!("{} (all three)", esc(names[0]))
    } else {
        names
            .iter()
            .enumerate()
            .map(|(i, n)| format!("{}: {}", i + 1, esc(n)))
            .collect::<Vec<_>>()
            .join("; ")
    };
    let per = |x: fn(&CaseLeaflet) -> Option<f64>| {
        ls.iter()
            .map(|l| fixed(x(l), 1))
            .collect::<Vec<_>>()
            .join(" / ")
    };
    let _ = write!(
        text,
        "; free edge {} mm, sutured edge {} mm",
        per(|l| l.free_edge_mm),
        per(|l| l.attachment_mm)
    );
    if let Some(p) = &first.placement {
        let _ = write!(text, "; placed {}", esc(p));
    }
    if let Some(hm) = c.mesh_h_mm {
        let _ = write!(text, "; mesh size {} mm", shortest(Some(hm)));
    }
    Some(text)
}

/// The material law with its units, the thickness and where the law's
/// parameters come from.
fn material_line(c: &Case) -> Option<String> {
    let m = crate::case::material_text(&c.material)?;
    let mut text = esc(&m);
    if let Some(t) = c.thickness_mm {
        let _ = write!(text, "; thickness {} mm", shortest(Some(t)));
    }
    let source = c
        .material_source
        .as_deref()
        .unwrap_or("not stated (close.toml: material_source)");
    let _ = write!(text, "; source: {}", esc(source));
    Some(text)
}

/// The pressures, the contact, bending and the stress-free state.
fn load_line(c: &Case) -> Option<String> {
    let p = c.pressure_mmhg?;
    let mut text = format!("{} mmHg", shortest(Some(p)));
    if let Some(lp) = c.effective_height_pressure_mmhg {
        let _ = write!(
            text,
            " (and {} mmHg for the effective height)",
            shortest(Some(lp))
        );
    }
    let contact = match c.contact.as_deref() {
        Some("leaflets") => "true contact between the leaflets",
        Some("planes") => "contact planes through the axis (seed 001)",
        Some("none") => "no contact",
        _ => "",
    };
    if !contact.is_empty() {
        let _ = write!(text, "; {contact}");
    }
    if let Some(b) = c.bending {
        text.push_str(if b {
            "; bending stiffness on"
        } else {
            "; membrane (no bending)"
        });
    }
    if let Some(r) = &c.reference {
        let _ = write!(text, "; stress-free state: {}", esc(r));
    }
    Some(text)
}

/// "1–3" from a pair's 1-based leaflets.
pub(super) fn pair_label(l: &[u64]) -> String {
    let idx = |i: usize| l.get(i).map_or("?".to_string(), |x| x.to_string());
    format!("{}–{}", idx(0), idx(1))
}

/// "N1 right coronary (ostium 20.7 mm above the annulus), …; named by the
/// coronary ostia in the CT" from the landmarks stage's sinuses.
pub(super) fn sinus_names(
    sinuses: &[Sinus],
    naming: Option<&SinusNaming>,
    leaflet_sinuses: &[String],
) -> Option<String> {
    if sinuses.is_empty() {
        return None;
    }
    let each: Vec<String> = sinuses
        .iter()
        .map(|s| {
            let name = or(&s.name, DASH).replace('_', "-");
            let mut t = format!("{} {}", esc(or(&s.nadir, "?")), esc(&name));
            if let Some(o) = &s.ostium {
                let _ = write!(
                    t,
                    " (ostium {} mm above the annulus)",
                    fixed(Some(o.height_mm), 1)
                );
            }
            t
        })
        .collect();
    let how = match naming {
        Some(n) if n.by == "coronary_ostia" => "named by the coronary ostia seen in the CT",
        Some(n) if n.ct_searched => {
            "named by position (the CT did not show two coronary ostia): the sinus facing anterior taken for the right-coronary one"
        }
        _ => {
            "named by position (no CT searched for the coronary ostia): the sinus facing anterior taken for the right-coronary one"
        }
    };
    let leaflets: Vec<String> = leaflet_sinuses
        .iter()
        .map(|n| esc(&n.replace('_', "-")))
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
