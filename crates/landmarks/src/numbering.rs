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

/// How the user's numbering relates to the detector's: turned by `turn`
/// sinuses, and, when `mirrored`, run the other way round the valve. The
/// detector's C_i and N_i become C_i+s and N_i+s; mirrored, C_s−i and
/// N_s−i−1, so that N_k still lies between C_k and C_k+1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Numbering {
    pub turn: usize,
    pub mirrored: bool,
}

impl Numbering {
    /// The user's 0-based number of the detector's point `i` of `kind`.
    fn of(self, kind: char, i: usize) -> usize {
        let s = self.turn;
        match (self.mirrored, kind) {
            (false, _) => (i + s) % 3,
            (true, 'C') => (s + 3 - i) % 3,
            (true, _) => (s + 5 - i) % 3,
        }
    }

    /// The detector's label that carries the user's label `kind`, `k`.
    fn from(self, kind: char, k: usize) -> usize {
        (0..3)
            .find(|&i| self.of(kind, i) == k)
            .expect("a bijection")
    }
}

/// The numbering (of the three turns, either way round) that puts each
/// label `given` holds nearest, in angle about the detected axis, to the
/// detected point that would carry it. The detector's own when none does
/// better: nothing given, or one point alone (which cannot tell the way
/// round; then the turn without mirroring).
pub fn user_numbering(det: &Detection, given: &Landmarks) -> Numbering {
    let cost = |n: Numbering| -> f64 {
        given
            .points
            .iter()
            .filter_map(|(label, q)| {
                let (kind, k) = parse(label)?;
                let from = format!("{kind}{}", n.from(kind, k) + 1);
                let p = det.points.iter().find(|p| p.label == from)?;
                Some(apart_deg(det.angle_deg(q), det.angle_deg(&p.point_mm)))
            })
            .sum()
    };
    let mut best = (Numbering::default(), cost(Numbering::default()));
    for mirrored in [false, true] {
        for turn in 0..3 {
            let n = Numbering { turn, mirrored };
            let c = cost(n);
            // Ties go to the earlier: unmirrored, then the smaller turn.
            if c < best.1 {
                best = (n, c);
            }
        }
    }
    best.0
}

/// Renumber the detected points and sinuses by `n` (see
/// [`user_numbering`]); the points stay in label order.
pub fn renumber(det: &mut Detection, n: Numbering) {
    if n == Numbering::default() {
        return;
    }
    for p in &mut det.points {
        if let Some((kind, i)) = parse(&p.label) {
            p.label = format!("{kind}{}", n.of(kind, i) + 1);
        }
    }
    det.points.sort_by(|a, b| a.label.cmp(&b.label));
    if det.sinuses.len() == 3 {
        let mut sinuses = det.sinuses.clone();
        for (i, sinus) in det.sinuses.drain(..).enumerate() {
            sinuses[n.of('N', i)] = sinus;
        }
        for (k, sinus) in sinuses.iter_mut().enumerate() {
            sinus.nadir = format!("N{}", k + 1);
        }
        det.sinuses = sinuses;
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

    /// The angles (degrees, rounded) of C1, N1, C2, N2, C3, N3 about the axis.
    fn angles(det: &Detection) -> [f64; 6] {
        ["C1", "N1", "C2", "N2", "C3", "N3"].map(|label| {
            let p = det.points.iter().find(|p| p.label == label).unwrap();
            det.angle_deg(&p.point_mm).round()
        })
    }

    /// (nadir, name) of each sinus, in list order.
    fn sinus_names(det: &Detection) -> Vec<(&str, &'static str)> {
        det.sinuses
            .iter()
            .map(|s| (s.nadir.as_str(), s.name))
            .collect()
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
        let n = user_numbering(&det, &g);
        assert_eq!(
            n,
            Numbering {
                turn: 2,
                mirrored: false
            }
        );
        renumber(&mut det, n);
        let labels: Vec<&str> = det.points.iter().map(|p| p.label.as_str()).collect();
        assert_eq!(labels, ["C1", "C2", "C3", "N1", "N2", "N3"]);
        // N_k between C_k and C_k+1 in the user's numbering.
        assert_eq!(angles(&det), [120.0, 180.0, 240.0, 300.0, 0.0, 60.0]);
        assert_eq!(
            sinus_names(&det),
            [
                ("N1", "left_coronary"),
                ("N2", "non_coronary"),
                ("N3", "right_coronary")
            ]
        );
    }

    /// A lone commissure decides the turn as well (not the way round,
    /// which one point cannot tell); a file in the detector's numbering and
    /// none keep it.
    #[test]
    fn the_numbering_is_kept_unless_a_given_point_asks_for_another() {
        let det = detection();
        let turn = |turn| Numbering {
            turn,
            mirrored: false,
        };
        assert_eq!(user_numbering(&det, &given(&[("C1", 241.0)])), turn(1));
        assert_eq!(
            user_numbering(&det, &given(&[("C1", 1.0), ("N1", 61.0), ("N2", 179.0)])),
            turn(0)
        );
        assert_eq!(user_numbering(&det, &given(&[("STJ", 90.0)])), turn(0));
        assert_eq!(user_numbering(&det, &Landmarks::new(Frame::Lps)), turn(0));
    }

    /// Numbered clockwise: N1 at 60°, N2 at 300°, N3 at 180° (the
    /// detector's N1, N3, N2). The commissures found take the same way
    /// round, so that N_k still lies between C_k and C_k+1, and the sinus
    /// names follow their nadirs.
    #[test]
    fn a_file_numbered_clockwise_is_mirrored() {
        let mut det = detection();
        let g = given(&[("N1", 60.0), ("N2", 300.0), ("N3", 180.0)]);
        let n = user_numbering(&det, &g);
        assert!(n.mirrored, "{n:?}");
        renumber(&mut det, n);
        assert_eq!(angles(&det), [120.0, 60.0, 0.0, 300.0, 240.0, 180.0]);
        assert_eq!(
            sinus_names(&det),
            [
                ("N1", "right_coronary"),
                ("N2", "non_coronary"),
                ("N3", "left_coronary")
            ]
        );
        // Every mirrored numbering maps both kinds one to one and keeps
        // each sinus between its two commissures.
        for turn in 0..3 {
            let n = Numbering {
                turn,
                mirrored: true,
            };
            for i in 0..3 {
                let (c0, c1, s) = (n.of('C', i), n.of('C', (i + 1) % 3), n.of('N', i));
                assert_eq!(
                    [s, (s + 1) % 3].map(|k| [c0, c1].contains(&k)),
                    [true, true]
                );
                assert_eq!(n.from('N', s), i);
            }
        }
    }
}
