//! Can the three free edges meet at all, and what would Ozaki's rule cut
//! for this root? A valve that does not close most often has free edges
//! too short for its root; saying so (with the numbers) tells a surgeon
//! what to change, where "no central coaptation" alone does not.
//!
//! To meet, the three free edges must pass through one point P, each from
//! its commissure C_k to P and on to C_k+1, so free edge k must be at least
//! |C_k P| + |P C_k+1|. P may as well lie in the commissures' plane
//! (projecting it there shortens every leg), and the best P is the one
//! that asks the least stretch of the worst leaflet: min over P of
//! max_k (|C_k P| + |P C_k+1|) / L_k, a convex function of P, found on a
//! grid refined twice. When it exceeds 1 the leaflets can meet only
//! stretched, whatever the mechanics.

use serde_json::Value as Json;

use super::document::{Finding, Severity};
use crate::geom::{Point3, ValveFrame};
use crate::leaflet::template::sizer_size_for;

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
    let p = meeting_point(c, &free);
    (0..3)
        .map(|k| {
            let (a, b) = (c[k], c[(k + 1) % 3]);
            let gap = (a - b).norm();
            Reach {
                leaflet: k,
                template: ls[k]["template"].as_str().unwrap_or("unnamed").to_string(),
                free_edge_mm: free[k],
                centre_path_mm: (a - p).norm() + (p - b).norm(),
                intercommissural_mm: gap,
                rule_size: sizer_size_for(gap).ok(),
            }
        })
        .collect()
}

/// The point of the commissures' plane that asks the least stretch of the
/// worst free edge (see the module note).
fn meeting_point(c: &[Point3; 3], free: &[f64; 3]) -> Point3 {
    let g = Point3::from((c[0].coords + c[1].coords + c[2].coords) / 3.0);
    let u = (c[1] - c[0]).normalize();
    let n = (c[1] - c[0]).cross(&(c[2] - c[0]));
    let w = n.normalize().cross(&u);
    let at = |x: f64, y: f64| g + u * x + w * y;
    let worst = |p: &Point3| {
        (0..3)
            .map(|k| ((c[k] - p).norm() + (p - c[(k + 1) % 3]).norm()) / free[k])
            .fold(0.0, f64::max)
    };
    // The commissures span at most a few centimetres: 0.5 mm steps over
    // their extent, then 0.02 and 0.001 mm steps around the best.
    let half = c.iter().map(|p| (p - g).norm()).fold(0.0, f64::max);
    let (mut x0, mut y0) = (0.0, 0.0);
    let mut span = half;
    for step in [0.5, 0.02, 0.001] {
        let n = (span / step).ceil() as i64;
        let mut best = (f64::INFINITY, x0, y0);
        for i in -n..=n {
            for j in -n..=n {
                let (x, y) = (x0 + i as f64 * step, y0 + j as f64 * step);
                let v = worst(&at(x, y));
                if v < best.0 {
                    best = (v, x, y);
                }
            }
        }
        (x0, y0) = (best.1, best.2);
        span = 2.0 * step;
    }
    at(x0, y0)
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
/// as stress-free (seed 001): that closure is not a prediction. Below 2 %
/// a shortfall is within the placement's and the mesh's error.
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

/// The shortfall a closed valve may have before its closure is not taken
/// as a prediction.
pub const MAX_SHORTFALL: f64 = 0.02;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Vector3;
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

    /// No nearby point of the commissures' plane asks less of the worst
    /// leaflet (convex, so local is global), on an uneven root.
    #[test]
    fn the_meeting_point_minimises_the_worst_stretch() {
        let f = frame(13.0, 105.0, 4.0);
        let c = f.commissures_mm;
        let free = [22.0, 31.0, 27.0];
        let p = meeting_point(&c, &free);
        let worst = |p: &Point3| {
            (0..3)
                .map(|k| ((c[k] - p).norm() + (p - c[(k + 1) % 3]).norm()) / free[k])
                .fold(0.0, f64::max)
        };
        let n = (c[1] - c[0]).cross(&(c[2] - c[0])).normalize();
        assert!((p - c[0]).dot(&n).abs() < 1e-9, "in the commissures' plane");
        let u = (c[1] - c[0]).normalize();
        let w = n.cross(&u);
        let best = worst(&p);
        for k in 0..16 {
            let a = k as f64 * std::f64::consts::PI / 8.0;
            for d in [0.005, 0.1, 2.0] {
                let q = p + (u * a.cos() + w * a.sin()) * d;
                assert!(worst(&q) >= best - 1e-9, "{k} {d}: {} < {best}", worst(&q));
            }
        }
        let r = reach(&f, &placement(free));
        let max = r
            .iter()
            .map(|x| x.centre_path_mm / x.free_edge_mm)
            .fold(0.0, f64::max);
        assert!((max - best).abs() < 1e-12);
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
