//! The general contents of a VTK PolyData file: points, polylines and
//! triangles with their data arrays. Stage artifacts convert to and from the
//! more specific [`TriMesh`](super::TriMesh).

use super::{Attributes, Frame, Point3};
use coapt_base::{Error, Result};

/// Points, polylines and triangles as a `.vtp` file holds them.
///
/// Cell data covers lines first, then triangles (VTK's cell order).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PolyData {
    pub points: Vec<Point3>,
    pub lines: Vec<Vec<u32>>,
    pub triangles: Vec<[u32; 3]>,
    pub point_data: Attributes,
    pub cell_data: Attributes,
    pub field_data: Attributes,
}

impl PolyData {
    pub fn cell_count(&self) -> usize {
        self.lines.len() + self.triangles.len()
    }

    /// The frame recorded in field data (`frame`), LPS when absent.
    pub fn frame(&self) -> Result<Frame> {
        match self.field_data.get_str("frame") {
            None => Ok(Frame::Lps),
            Some(s) => Frame::parse(s)
                .ok_or_else(|| Error::value(format!("unknown frame '{s}' in field data"))),
        }
    }

    /// Verify indices, array lengths and finiteness.
    pub fn sanity_check(&self) -> Result<()> {
        let n = self.points.len();
        if let Some(p) = self
            .points
            .iter()
            .position(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(Error::value(format!(
                "point {p} has a NaN or infinite coordinate"
            )));
        }
        for (c, line) in self.lines.iter().enumerate() {
            if line.len() < 2 {
                return Err(Error::value(format!("line {c} has fewer than 2 points")));
            }
            if let Some(&i) = line.iter().find(|&&i| i as usize >= n) {
                return Err(Error::value(format!(
                    "line {c} refers to point {i}, but there are only {n} points"
                )));
            }
        }
        for (t, tri) in self.triangles.iter().enumerate() {
            if let Some(&i) = tri.iter().find(|&&i| i as usize >= n) {
                return Err(Error::value(format!(
                    "triangle {t} refers to point {i}, but there are only {n} points"
                )));
            }
        }
        self.point_data.check(Some(n), "point data")?;
        self.cell_data.check(Some(self.cell_count()), "cell data")?;
        self.field_data.check(None, "field data")?;
        Ok(())
    }
}
