//! Can the three free edges meet at all, and what would Ozaki's rule cut
//! for this root? A valve that does not close most often has free edges
//! too short for its root; saying so (with the numbers) tells a surgeon
//! what to change, where "no central coaptation" alone does not.
//!
//! The geometry is `geom::free_edge_reach`: the length each free edge
//! needs to reach the point where the three can meet with the least
//! stretch.

use serde_json::Value as Json;

use super::document::{Finding, Severity};
use coapt_geom::ValveFrame;
use coapt_geom::free_edge_reach::{MAX_SHORTFALL, needed_free_edges};
use coapt_template::sizer_size_for;

/// One leaflet's free edge against its root.
#[derive(Debug, Clone, PartialEq)]
pub struct Reach {
    /// 0-based; the leaflet between commissures k and k + 1.
    pub leaflet: usize,
    /// The template as leaflets.json names it.
    pub template: String,
    /// Template free edge, corner to corner (mm).
    pub free_edge_mm: f64,
    /// Its way from commissure to the best meeting point and on to the next
    /// commissure (mm).
    pub centre_path_mm: f64,
    /// Distance between its commissures (mm).
    pub intercommissural_mm: f64,
    /// Ozaki's rule: the sizer size nearest that distance, when in the
    /// sizer's range.
    pub rule_size: Option<u32>,
}

impl Reach {
    /// How much the free edge must stretch to reach the centre (0 when it
    /// is long enough).
    pub fn shortfall(&self) -> f64 {
        (self.centre_path_mm / self.free_edge_mm - 1.0).max(0.0)
    }
}

/// The three leaflets against their root; empty unless leaflets.json lists
/// three free edges.
pub fn reach(frame: &ValveFrame, placement: &Json) -> Vec<Reach> {
    let Some(ls) = placement["leaflets"].as_array().filter(|l| l.len() == 3) else {
        return Vec::new();
    };
    let free: Vec<f64> = ls
        .iter()
        .filter_map(|l| l["free_edge_mm"].as_f64().filter(|f| *f > 0.0))
        .collect();
    let Ok(free) = <[f64; 3]>::try_from(free) else {
        return Vec::new();
    };
    let c = &frame.commissures_mm;
    let need = needed_free_edges(c, &free);
    (0..3)
        .map(|k| {
            let (a, b) = (c[k], c[(k + 1) % 3]);
            let gap = (a - b).norm();
            Reach {
                leaflet: k,
                template: ls[k]["template"].as_str().unwrap_or("unnamed").to_string(),
                free_edge_mm: free[k],
                centre_path_mm: need[k],
                intercommissural_mm: gap,
                rule_size: sizer_size_for(gap).ok(),
            }
        })
        .collect()
}

/// Short free edges, always; Ozaki's rule for the root when a free edge is
/// short or the valve does not close.
pub fn findings(reach: &[Reach], closed: bool) -> Vec<Finding> {
    let mut f = Vec::new();
    let name = |k: usize| format!("C{}", k + 1);
    let short: Vec<&Reach> = reach.iter().filter(|r| r.shortfall() > 0.0).collect();
    if !short.is_empty() {
        f.push(Finding {
            severity: Severity::Warning,
            message: format!(
                "The free edges are too short to meet: {}. Each is the way from the leaflet's commissure to the point where the three can meet with the least stretch and on to its other commissure, so whatever the mechanics the valve closes only if they stretch that much.",
                list(&short)
            ),
        });
    }
    if !reach.is_empty() && (!short.is_empty() || !closed) {
        let sizes: Vec<String> = reach
            .iter()
            .map(|r| r.rule_size.map_or("none".into(), |s| s.to_string()))
            .collect();
        let gaps: Vec<String> = reach
            .iter()
            .map(|r| {
                format!(
                    "{}–{} {:.1} mm",
                    name(r.leaflet),
                    name((r.leaflet + 1) % 3),
                    r.intercommissural_mm
                )
            })
            .collect();
        let mut given: Vec<&str> = reach.iter().map(|r| r.template.as_str()).collect();
        given.dedup();
        f.push(Finding {
            severity: Severity::Info,
            message: format!(
                "Ozaki's rule (the sizer size nearest each intercommissural distance) cuts {} for this root ({}); the leaflets given: {}. `coapt design` closes each sizer size on these suture paths.",
                sizes.join(" / "),
                gaps.join(", "),
                given.join("; ")
            ),
        });
    }
    f
}

/// A closed valve whose free edges are too short to meet unstretched met
/// only because its placement stretched them, and the sutured state counts
/// as stress-free (seed 001): that closure is not a prediction. Below
/// [`MAX_SHORTFALL`] a shortfall is within the placement's and the mesh's
/// error.
pub fn gates(reach: &[Reach], closed: bool) -> Vec<String> {
    if !closed {
        return Vec::new();
    }
    let short: Vec<&Reach> = reach
        .iter()
        .filter(|r| r.shortfall() > MAX_SHORTFALL)
        .collect();
    if short.is_empty() {
        return Vec::new();
    }
    vec![format!(
        "the free edges are too short to meet ({}): the leaflets meet only because their placement stretched them, and the sutured state counts as stress-free",
        list(&short)
    )]
}

/// "leaflet 1: 24.3 mm against 27.7 mm needed (14.0 % short), …"
fn list(short: &[&Reach]) -> String {
    short
        .iter()
        .map(|r| {
            format!(
                "leaflet {}: {:.1} mm against {:.1} mm needed ({:.1} % short)",
                r.leaflet + 1,
                r.free_edge_mm,
                r.centre_path_mm,
                100.0 * r.shortfall()
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use coapt_geom::{Point3, Vector3};
    use serde_json::json;

    /// Commissures `r` off the axis at 120° (C2 at `a2` degrees), C2 `dh`
    /// higher than the others.
    fn frame(r: f64, a2: f64, dh: f64) -> ValveFrame {
        let at = |deg: f64, h: f64| {
            let a = deg.to_radians();
            Point3::new(r * a.cos(), r * a.sin(), 15.0 + h)
        };
        ValveFrame::new(
            Point3::origin(),
            Vector3::z(),
            [at(0.0, 0.0), at(a2, dh), at(240.0, 0.0)],
            None,
        )
        .unwrap()
    }

    fn placement(free: [f64; 3]) -> Json {
        json!({"leaflets": free.iter().map(|f| json!({"template": "ozaki D=19", "free_edge_mm": f})).collect::<Vec<_>>()})
    }

    #[test]
    fn a_symmetric_root_meets_on_its_axis() {
        let f = frame(13.9, 120.0, 0.0);
        let r = reach(&f, &placement([24.3; 3]));
        assert_eq!(r.len(), 3);
        for x in &r {
            assert!((x.centre_path_mm - 27.8).abs() < 1e-5, "{x:?}");
            assert!((x.shortfall() - (27.8 / 24.3 - 1.0)).abs() < 1e-6);
            // The gap is the chord, 2 r sin 60°; the sizer's nearest is 25.
            assert!((x.intercommissural_mm - 2.0 * 13.9 * 60f64.to_radians().sin()).abs() < 1e-9);
            assert_eq!(x.rule_size, Some(25));
        }
    }

    #[test]
    fn short_free_edges_are_named_and_the_rule_is_given_when_it_matters() {
        let f = frame(13.9, 120.0, 0.0);
        let fs = findings(&reach(&f, &placement([24.3; 3])), true);
        let warn: Vec<_> = fs
            .iter()
            .filter(|x| x.severity == Severity::Warning)
            .collect();
        assert_eq!(warn.len(), 1);
        let w = &warn[0].message;
        assert!(w.starts_with("The free edges are too short to meet: leaflet 1: 24.3 mm against 27.8 mm needed (14.4 % short), leaflet 2: "), "{w}");
        assert!(w.contains("leaflet 3: 24.3 mm"), "{w}");
        let rule = fs.iter().find(|x| x.severity == Severity::Info).unwrap();
        assert!(
            rule.message.contains("cuts 25 / 25 / 25"),
            "{}",
            rule.message
        );
        assert!(rule.message.contains("C3–C1 24.1 mm"), "{}", rule.message);
        // Long enough and closed: nothing to say.
        assert!(findings(&reach(&f, &placement([30.0; 3])), true).is_empty());
        // Long enough but open: the rule alone.
        let open = findings(&reach(&f, &placement([30.0; 3])), false);
        assert_eq!(open.len(), 1);
        assert_eq!(open[0].severity, Severity::Info);
        // Without three free edges there is nothing to compare.
        assert!(reach(&f, &json!({})).is_empty());
        assert!(reach(&f, &json!({"leaflets": [{"free_edge_mm": 30.0}]})).is_empty());
    }

    #[test]
    fn a_closure_with_free_edges_too_short_is_not_a_prediction() {
        let f = frame(13.9, 120.0, 0.0);
        // One short leaflet alone is helped by the others' slack: the
        // meeting point moves towards its chord.
        assert!(gates(&reach(&f, &placement([26.0, 32.0, 32.0])), true).is_empty());
        let short = reach(&f, &placement([24.3; 3]));
        let g = gates(&short, true);
        assert_eq!(g.len(), 1);
        assert!(g[0].starts_with("the free edges are too short to meet (leaflet 1: 24.3 mm against 27.8 mm needed (14.4 % short), "), "{}", g[0]);
        // Open valves fail on their own; 1 % short is within the error.
        assert!(gates(&short, false).is_empty());
        let within = reach(&f, &placement([27.8 / 1.01; 3]));
        assert!(gates(&within, true).is_empty());
    }
}
