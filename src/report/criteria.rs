//! The surgical criteria (seed 001 §1, VERIFICATION.md §5): central
//! coaptation > 4 mm, effective height > 9 mm, coaptation above the VAJ, no
//! prolapse, closed. Each is judged pass, fail, or not measurable.

use super::metrics::Metrics;

/// Configurable thresholds, mm.
#[derive(Debug, Clone, Copy)]
pub struct Thresholds {
    pub central_coaptation_mm: f64,
    pub effective_height_mm: f64,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            central_coaptation_mm: 4.0,
            effective_height_mm: 9.0,
        }
    }
}

/// A value a criterion compares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    Mm(Option<f64>),
    Bool(Option<bool>),
}

#[derive(Debug, Clone)]
pub struct Criterion {
    pub id: &'static str,
    pub name: &'static str,
    pub value: Value,
    /// Numeric criteria: value must exceed this (mm).
    pub threshold_mm: Option<f64>,
    /// `None`: could not be measured.
    pub pass: Option<bool>,
    pub note: String,
}

/// Judge `m`; `pressure_mmhg` is the pressure the effective height was
/// read at, when known.
pub fn judge(m: &Metrics, t: &Thresholds, pressure_mmhg: Option<f64>) -> Vec<Criterion> {
    let above = |v: Option<f64>, th: f64| v.map(|v| v > th);
    let central = m.central_coaptation_height_mm;
    vec![
        Criterion {
            id: "central_coaptation",
            name: "Central coaptation height",
            value: Value::Mm(central),
            threshold_mm: Some(t.central_coaptation_mm),
            // No triple zone: there is no central coaptation at all.
            pass: Some(above(central, t.central_coaptation_mm).unwrap_or(false)),
            note: match central {
                Some(_) => "axial extent of the zone where all three leaflets touch".into(),
                None => "no zone where all three leaflets touch".into(),
            },
        },
        Criterion {
            id: "effective_height",
            name: "Effective height",
            value: Value::Mm(m.effective_height_mm),
            threshold_mm: Some(t.effective_height_mm),
            pass: above(m.effective_height_mm, t.effective_height_mm),
            note: match pressure_mmhg {
                Some(p) => format!(
                    "annulus plane to the central free-edge point, along the axis, at {p} mmHg"
                ),
                None => "annulus plane to the central free-edge point, along the axis".into(),
            },
        },
        Criterion {
            id: "coaptation_above_vaj",
            name: "Coaptation above the VAJ",
            value: Value::Bool(m.coaptation_above_vaj),
            threshold_mm: None,
            pass: m.coaptation_above_vaj,
            note: match m.lowest_coaptation_mm {
                Some(z) => {
                    format!("lowest point of the coaptation zone {z:.2} mm above the annulus plane")
                }
                None => "no coaptation zone to place".into(),
            },
        },
        Criterion {
            id: "no_prolapse",
            name: "No prolapse",
            value: Value::Bool(Some(m.lowest_free_edge_mm > 0.0)),
            threshold_mm: None,
            pass: Some(m.lowest_free_edge_mm > 0.0),
            note: format!(
                "lowest free-edge point {:.2} mm above the annulus plane",
                m.lowest_free_edge_mm
            ),
        },
        Criterion {
            id: "closed",
            name: "Valve closed",
            value: Value::Bool(Some(m.closed)),
            threshold_mm: None,
            pass: Some(m.closed),
            note: "a zone where all three leaflets touch exists".into(),
        },
    ]
}
