//! The user's numbering of the sinuses. The detector numbers them from the
//! right-coronary sinus (N1 in it, C1 at its start); a user's file may start
//! anywhere (the hand-placed file of `../shared/real/` starts at the
//! left-coronary sinus). The detected points that complete a user's file take
//! the user's numbering, so that in the file written C_k, N_k and C_k+1
//! bound one sinus whoever placed each. Before, a file of N1–N3 alone came
//! back with the detector's C1–C3 beside the user's nadirs, every label a
//! sinus off (25 mm "apart" on the real CT).

use super::angular::apart_deg;
use super::detect::Detection;
use coapt_geom::Landmarks;

/// `("C", 0)` for "C1": the kind and 0-based number of a valve label.
fn parse(label: &str) -> Option<(char, usize)> {
    let mut chars = label.chars();
    let kind = chars.next().filter(|c| matches!(c, 'C' | 'N'))?;
    let k: usize = chars.as_str().parse().ok()?;
    (1..=3).contains(&k).then_some((kind, k - 1))
}

/// The turn s of the detector's numbering (its C_i and N_i become C_i+s and
/// N_i+s) that puts each label `given` holds nearest, in angle about the
/// detected axis, to the detected point that would carry it. 0 when no turn
/// does better: nothing given, or a file numbered the other way round the
/// valve (which the valve reads by geometry, not by label).
pub fn user_turn(det: &Detection, given: &Landmarks) -> usize {
    let cost = |s: usize| -> f64 {
        given
            .points
            .iter()
            .filter_map(|(label, q)| {
                let (kind, k) = parse(label)?;
                let from = format!("{kind}{}", (k + 3 - s) % 3 + 1);
                let p = det.points.iter().find(|p| p.label == from)?;
                Some(apart_deg(det.angle_deg(q), det.angle_deg(&p.point_mm)))
            })
            .sum()
    };
    let mut best = (0, cost(0));
    for s in 1..3 {
        let c = cost(s);
        if c < best.1 {
            best = (s, c);
        }
    }
    best.0
}

/// Renumber the detected points and sinuses turned by `s` (see
/// [`user_turn`]); the points stay in label order.
pub fn renumber(det: &mut Detection, s: usize) {
    if s == 0 {
        return;
    }
    for p in &mut det.points {
        if let Some((kind, i)) = parse(&p.label) {
            p.label = format!("{kind}{}", (i + s) % 3 + 1);
        }
    }
    det.points.sort_by(|a, b| a.label.cmp(&b.label));
    if det.sinuses.len() == 3 {
        det.sinuses.rotate_right(s);
        for (j, sinus) in det.sinuses.iter_mut().enumerate() {
            sinus.nadir = format!("N{}", j + 1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::{Found, Sinus};
    use coapt_geom::{Frame, Point3};

    /// A detection on a circle about z: C_i at 120 i degrees, N_i
    /// between C_i and C_i+1, sinuses named in the detector's order.
    fn detection() -> Detection {
        let at = |deg: f64| {
            let r = deg.to_radians();
            Point3::new(10.0 * r.cos(), 10.0 * r.sin(), 0.0)
        };
        let found = |label: String, deg: f64| Found {
            label,
            point_mm: at(deg),
            confidence: 1.0,
            evidence: serde_json::json!({"angle_deg": deg}),
        };
        let mut points: Vec<Found> = (0..3)
            .map(|i| found(format!("C{}", i + 1), 120.0 * i as f64))
            .collect();
        points.extend((0..3).map(|i| found(format!("N{}", i + 1), 60.0 + 120.0 * i as f64)));
        let sinuses = ["right_coronary", "left_coronary", "non_coronary"]
            .iter()
            .enumerate()
            .map(|(j, &name)| Sinus {
                nadir: format!("N{}", j + 1),
                name,
                ostium: None,
            })
            .collect();
        Detection::on_z_axis(points, sinuses, true)
    }

    fn given(points: &[(&str, f64)]) -> Landmarks {
        let mut lm = Landmarks::new(Frame::Lps);
        for (label, deg) in points {
            let r = deg.to_radians();
            lm.push(*label, Point3::new(9.0 * r.cos(), 9.0 * r.sin(), 1.0));
        }
        lm
    }

    /// Nadirs numbered from the detector's second sinus: the turn is the
    /// one that makes each given label the detected point beside it, and
    /// the renumbered commissures bound the given nadirs' sinuses.
    #[test]
    fn the_detected_points_take_the_given_numbering() {
        let mut det = detection();
        // The user's N1 lies in the detector's sinus 2 (180°), N2 in 3, N3 in 1.
        let g = given(&[("N1", 178.0), ("N2", 303.0), ("N3", 58.0)]);
        assert_eq!(user_turn(&det, &g), 2);
        renumber(&mut det, 2);
        let labels: Vec<&str> = det.points.iter().map(|p| p.label.as_str()).collect();
        assert_eq!(labels, ["C1", "C2", "C3", "N1", "N2", "N3"]);
        let deg = |label: &str| {
            let p = det.points.iter().find(|p| p.label == label).unwrap();
            det.angle_deg(&p.point_mm).round()
        };
        // N_k between C_k and C_k+1 in the user's numbering.
        assert_eq!(
            ["C1", "N1", "C2", "N2", "C3", "N3"].map(deg),
            [120.0, 180.0, 240.0, 300.0, 0.0, 60.0]
        );
        let names: Vec<(&str, &str)> = det
            .sinuses
            .iter()
            .map(|s| (s.nadir.as_str(), s.name))
            .collect();
        assert_eq!(
            names,
            [
                ("N1", "left_coronary"),
                ("N2", "non_coronary"),
                ("N3", "right_coronary")
            ]
        );
    }

    /// A lone commissure decides the turn as well; a file in the detector's
    /// numbering, one numbered the other way round, and none keep it.
    #[test]
    fn the_turn_is_kept_unless_a_given_point_asks_for_another() {
        let det = detection();
        assert_eq!(user_turn(&det, &given(&[("C1", 241.0)])), 1);
        assert_eq!(
            user_turn(&det, &given(&[("C1", 1.0), ("N1", 61.0), ("N2", 179.0)])),
            0
        );
        // Clockwise: N1 at 60°, N2 at 300°, N3 at 180°. N1 holds turn 0.
        assert_eq!(
            user_turn(&det, &given(&[("N1", 60.0), ("N2", 300.0), ("N3", 180.0)])),
            0
        );
        assert_eq!(user_turn(&det, &given(&[("STJ", 90.0)])), 0);
        assert_eq!(user_turn(&det, &Landmarks::new(Frame::Lps)), 0);
    }
}
