//! Labelled points (commissures, nadirs) in world coordinates.

use super::{Frame, Point3};
use coapt_base::{Error, Result};

/// Sinus names, in the order sinus k lies between commissures C_k and
/// C_k+1 (counter-clockwise about the valve axis seen from the aorta): the
/// phantom's convention, and the one the landmarks stage labels by.
pub const SINUS_NAMES: [&str; 3] = ["right_coronary", "left_coronary", "non_coronary"];

/// Labelled points in one frame. Readers return them in LPS.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Landmarks {
    pub frame: Frame,
    pub points: Vec<(String, Point3)>,
}

impl Landmarks {
    pub fn new(frame: Frame) -> Self {
        Self {
            frame,
            points: Vec::new(),
        }
    }

    pub fn push(&mut self, label: impl Into<String>, p: Point3) {
        self.points.push((label.into(), p));
    }

    pub fn get(&self, label: &str) -> Option<Point3> {
        self.points
            .iter()
            .find(|(l, _)| l == label)
            .map(|(_, p)| *p)
    }

    /// The points for `labels`, in that order; the error lists every one missing.
    pub fn require(&self, labels: &[&str]) -> Result<Vec<Point3>> {
        let missing: Vec<&str> = labels
            .iter()
            .copied()
            .filter(|l| self.get(l).is_none())
            .collect();
        if !missing.is_empty() {
            let have: Vec<&str> = self.points.iter().map(|(l, _)| l.as_str()).collect();
            return Err(Error::value(format!(
                "missing landmark{} {} (found: {})",
                if missing.len() > 1 { "s" } else { "" },
                missing.join(", "),
                if have.is_empty() {
                    "none".to_string()
                } else {
                    have.join(", ")
                }
            )));
        }
        Ok(labels.iter().map(|l| self.get(l).unwrap()).collect())
    }

    /// The same points expressed in `frame`.
    pub fn to_frame(&self, frame: Frame) -> Landmarks {
        Landmarks {
            frame,
            points: self
                .points
                .iter()
                .map(|(l, p)| {
                    (
                        l.clone(),
                        Point3::from(self.frame.convert(frame, [p.x, p.y, p.z])),
                    )
                })
                .collect(),
        }
    }

    /// Labels are unique and non-empty; coordinates finite.
    pub fn sanity_check(&self) -> Result<()> {
        for (i, (l, p)) in self.points.iter().enumerate() {
            if l.trim().is_empty() {
                return Err(Error::value(format!("point {} has an empty label", i + 1)));
            }
            if !p.iter().all(|c| c.is_finite()) {
                return Err(Error::value(format!(
                    "point '{l}' has a non-finite coordinate"
                )));
            }
            if self.points[..i].iter().any(|(m, _)| m == l) {
                return Err(Error::value(format!("label '{l}' appears more than once")));
            }
        }
        Ok(())
    }
}
