//! Patient coordinate frames.

use serde::{Deserialize, Serialize};

/// Anatomical frame of world coordinates, in millimetres.
///
/// coapt works in LPS (x → patient left, y → posterior, z → superior), as
/// DICOM, ITK and 3D Slicer files do. NIfTI and some markup files store RAS;
/// the two differ by the sign of x and y.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Frame {
    #[default]
    #[serde(rename = "LPS")]
    Lps,
    #[serde(rename = "RAS")]
    Ras,
}

impl Frame {
    pub fn name(self) -> &'static str {
        match self {
            Frame::Lps => "LPS",
            Frame::Ras => "RAS",
        }
    }

    /// Parse "LPS"/"RAS" (case-insensitive).
    pub fn parse(s: &str) -> Option<Frame> {
        match s.trim().to_ascii_uppercase().as_str() {
            "LPS" => Some(Frame::Lps),
            "RAS" => Some(Frame::Ras),
            _ => None,
        }
    }

    /// Convert a point given in `self` to `to` (LPS ↔ RAS flips x and y).
    pub fn convert(self, to: Frame, p: [f64; 3]) -> [f64; 3] {
        if self == to { p } else { [-p[0], -p[1], p[2]] }
    }
}

impl std::fmt::Display for Frame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
