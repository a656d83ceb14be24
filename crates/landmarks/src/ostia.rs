//! Coronary ostia on the root wall, and the sinus names they give.
//!
//! The lumen mask stops at the aortic wall, but a coronary artery leaves
//! the sinus through it: at an ostium the contrast runs on unbroken from
//! the root's lumen into the artery, where everywhere else the wall (and
//! whatever lies beyond it: fat, myocardium, the atria's own walls) puts a
//! dark gap of a millimetre or more between the aortic blood and any other
//! bright structure. So, on rays from the root axis at every degree and
//! every half millimetre of height between the annulus and just above the
//! STJ, a cell is an ostium cell when the CT stays bright from 1 mm inside
//! the wall to [`OUT_MM`] outside it; the cells, joined across neighbouring
//! angles and heights, form patches, and the largest patch of a sector
//! (between two commissural pillars) of at least [`MIN_AREA_MM2`] is its
//! ostium.
//!
//! Names: the two sinuses with an ostium are the coronary sinuses, the
//! third the non-coronary one; going counter-clockwise about the axis
//! (right-handed about ventricle → aorta, so counter-clockwise as seen
//! from the aorta; anterior → left → posterior) the sinuses run right →
//! left → non-coronary, so the sinus after the non-coronary
//! one is the right. Without exactly two ostia the sinuses are named by
//! position, as before: the one facing anterior is the right-coronary
//! sinus.

use std::f64::consts::TAU;

use serde::Serialize;

use super::lumen_rays::LumenProbe;
use coapt_geom::resample::value_at;
use coapt_geom::{Point3, Vector3, Volume};

/// Ray spacing: heights (mm) and angles (degrees).
const H_STEP_MM: f64 = 0.5;
const ANGLES: usize = 360;
/// The search runs from this far above the annulus to this far above the
/// STJ (mm): ostia lie in the sinuses, a high take-off just above the STJ.
const FROM_ANNULUS_MM: f64 = 1.0;
const ABOVE_STJ_MM: f64 = 3.0;
/// How far the contrast must run on unbroken: from this far inside the
/// mask's wall to this far outside it, sampled every half millimetre (mm).
const IN_MM: f64 = 1.0;
const OUT_MM: f64 = 3.0;
/// Soft tissue's HU, the other end of the brightness threshold: a sample
/// is bright when it is nearer the lumen's median than this.
const TISSUE_HU: f64 = 40.0;
/// Smallest ostium patch (mm² of wall). An artery leaving the wall
/// obliquely keeps the contrast unbroken over less than its section: the
/// clinical phantom's 1.38 mm right coronary gave 1.9 mm², the real CT's
/// left main 2.6 mm². The phantoms show no other patch; the real CT four
/// under 0.7 mm², a 1.75 mm² piece beside its left main and a 1.4 mm² one
/// at the foot of a pillar, each smaller than its sector's ostium.
const MIN_AREA_MM2: f64 = 1.0;
/// Cells whose wall point lies closer than this above the annulus plane
/// are not searched (mm): there the mask's wall is its cut through the
/// outflow tract, and the ventricle's blood runs on beyond it (on the real
/// CT, two false patches 1–2 mm above the plane).
const ABOVE_PLANE_MM: f64 = 3.0;
/// Longest ray (mm).
const REACH_MM: f64 = 40.0;

/// The root's frame as the detector found it.
pub struct RootFrame {
    pub origin: Point3,
    pub axis: Vector3,
    /// Zero angle (⟂ axis); angles turn from it towards `axis × e1`.
    pub e1: Vector3,
}

impl RootFrame {
    fn dir(&self, deg: f64) -> Vector3 {
        let e2 = self.axis.cross(&self.e1);
        let t = deg.to_radians();
        self.e1 * t.cos() + e2 * t.sin()
    }
}

/// A coronary ostium as found: a patch of the wall where the contrast runs
/// through it.
#[derive(Debug, Clone, Serialize)]
pub struct Ostium {
    /// The patch's mean wall point.
    pub point_mm: Point3,
    pub height_mm: f64,
    pub angle_deg: f64,
    /// Area of the patch on the wall (mm²).
    pub area_mm2: f64,
}

/// Per sector k (from pillar k counter-clockwise to pillar k+1), its
/// largest ostium patch; and the lumen's median HU the threshold used.
pub struct Search {
    pub per_sector: [Option<Ostium>; 3],
    /// Patches too small to count, and patches beyond the largest of their
    /// sector: what else looked like contrast through the wall.
    pub other_patches: usize,
    pub lumen_hu: f64,
    pub threshold_hu: f64,
}

/// Which sector holds a direction at `deg`, the pillars at `pillars_deg`
/// in increasing order (mod 360).
pub fn sector_of(deg: f64, pillars_deg: &[f64; 3]) -> usize {
    (0..3)
        .find(|&k| {
            let a = pillars_deg[k];
            let span = (pillars_deg[(k + 1) % 3] - a).rem_euclid(360.0);
            (deg - a).rem_euclid(360.0) < span
        })
        .unwrap_or(0)
}

/// Look for ostia in `ct` around the root of `mask` (the same world frame;
/// grids may differ), between the annulus plane (a point on it and its
/// unit normal towards the aorta) and `h_stj` above the frame's origin.
pub fn search(
    ct: &Volume<i16>,
    mask: &Volume<u8>,
    frame: &RootFrame,
    plane: (&Point3, &Vector3),
    h_stj: f64,
    pillars_deg: &[f64; 3],
) -> Search {
    let probe = LumenProbe::new(mask);
    let heights: Vec<f64> = (0..)
        .map(|i| FROM_ANNULUS_MM + i as f64 * H_STEP_MM)
        .take_while(|&h| h <= h_stj + ABOVE_STJ_MM + 1e-9)
        .collect();
    // Wall distance per cell (NaN where a ray finds none).
    let mut wall = vec![f64::NAN; heights.len() * ANGLES];
    let mut inside = Vec::new();
    for (i, &h) in heights.iter().enumerate() {
        let c = frame.origin + frame.axis * h;
        for a in 0..ANGLES {
            let d = frame.dir(a as f64);
            if let Some(r) = probe.exit(&c, &d, REACH_MM) {
                if (c + d * r - plane.0).dot(plane.1) < ABOVE_PLANE_MM {
                    continue;
                }
                wall[i * ANGLES + a] = r;
                inside.push(value_at(ct, &(c + d * (0.5 * r)), i16::MIN) as f64);
            }
        }
    }
    inside.retain(|v| *v > i16::MIN as f64);
    inside.sort_by(f64::total_cmp);
    let lumen_hu = inside.get(inside.len() / 2).copied().unwrap_or(f64::NAN);
    let threshold_hu = 0.5 * (lumen_hu + TISSUE_HU);
    let steps = ((IN_MM + OUT_MM) / 0.5).round() as usize;
    let bright: Vec<bool> = (0..wall.len())
        .map(|cell| {
            let r = wall[cell];
            if !r.is_finite() || !(lumen_hu > TISSUE_HU) {
                return false;
            }
            let (i, a) = (cell / ANGLES, cell % ANGLES);
            let c = frame.origin + frame.axis * heights[i];
            let d = frame.dir(a as f64);
            (0..=steps).all(|s| {
                let t = r - IN_MM + 0.5 * s as f64;
                value_at(ct, &(c + d * t), i16::MIN) as f64 > threshold_hu
            })
        })
        .collect();
    // Patches: 4-connected over (height, angle), the angle wrapping.
    let mut patch = vec![usize::MAX; wall.len()];
    let mut patches: Vec<Vec<usize>> = Vec::new();
    for start in 0..wall.len() {
        if !bright[start] || patch[start] != usize::MAX {
            continue;
        }
        let id = patches.len();
        let mut cells = vec![start];
        patch[start] = id;
        let mut k = 0;
        while k < cells.len() {
            let (i, a) = (cells[k] / ANGLES, cells[k] % ANGLES);
            let mut next = vec![
                i * ANGLES + (a + 1) % ANGLES,
                i * ANGLES + (a + ANGLES - 1) % ANGLES,
            ];
            if i > 0 {
                next.push((i - 1) * ANGLES + a);
            }
            if i + 1 < heights.len() {
                next.push((i + 1) * ANGLES + a);
            }
            for q in next {
                if bright[q] && patch[q] == usize::MAX {
                    patch[q] = id;
                    cells.push(q);
                }
            }
            k += 1;
        }
        patches.push(cells);
    }
    let dtheta = TAU / ANGLES as f64;
    let mut per_sector: [Option<Ostium>; 3] = [None, None, None];
    for cells in &patches {
        let area: f64 = cells.iter().map(|&q| wall[q] * dtheta * H_STEP_MM).sum();
        if area < MIN_AREA_MM2 {
            continue;
        }
        let mut s = Vector3::zeros();
        for &q in cells {
            let (i, a) = (q / ANGLES, q % ANGLES);
            s += (frame.origin + frame.axis * heights[i] + frame.dir(a as f64) * wall[q]).coords;
        }
        let p = Point3::from(s / cells.len() as f64);
        let rel = p - frame.origin;
        let height = rel.dot(&frame.axis);
        let flat = rel - frame.axis * height;
        let e2 = frame.axis.cross(&frame.e1);
        let angle = flat
            .dot(&e2)
            .atan2(flat.dot(&frame.e1))
            .to_degrees()
            .rem_euclid(360.0);
        let k = sector_of(angle, pillars_deg);
        if per_sector[k].as_ref().is_none_or(|o| o.area_mm2 < area) {
            per_sector[k] = Some(Ostium {
                point_mm: p,
                height_mm: height,
                angle_deg: angle,
                area_mm2: area,
            });
        }
    }
    let kept = per_sector.iter().filter(|o| o.is_some()).count();
    Search {
        per_sector,
        other_patches: patches.len() - kept,
        lumen_hu,
        threshold_hu,
    }
}

/// How the sinuses got their names.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NamedBy {
    /// Two ostia seen: the sinus without one is the non-coronary sinus.
    CoronaryOstia,
    /// The sinus facing anterior is the right-coronary sinus.
    Position,
}

/// The sector of the right-coronary sinus and how it was decided; the
/// left follows it counter-clockwise, then the non-coronary.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Naming {
    pub right_sector: usize,
    pub by: NamedBy,
    /// Whether the position rule gives the same names (always true when
    /// named by position).
    pub agrees_with_position: bool,
    /// 1: two ostia and the position agree; 0.7: two ostia against the
    /// position; 0.5: by position alone.
    pub confidence: f64,
}

/// Names from the sectors holding an ostium and the sector facing anterior.
pub fn name(with_ostium: [bool; 3], anterior_sector: usize) -> Naming {
    let count = with_ostium.iter().filter(|&&b| b).count();
    if count == 2 {
        let non = (0..3).find(|&k| !with_ostium[k]).unwrap_or(0);
        let right = (non + 1) % 3;
        let agrees = right == anterior_sector;
        return Naming {
            right_sector: right,
            by: NamedBy::CoronaryOstia,
            agrees_with_position: agrees,
            confidence: if agrees { 1.0 } else { 0.7 },
        };
    }
    Naming {
        right_sector: anterior_sector,
        by: NamedBy::Position,
        agrees_with_position: true,
        confidence: 0.5,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_ostia_name_the_third_sinus_non_coronary_and_the_next_right() {
        // Ostia in sectors 0 and 1: sector 2 is non-coronary, so the right
        // sinus is sector 0 and the left sector 1.
        let n = name([true, true, false], 0);
        assert_eq!(
            (n.right_sector, n.by, n.confidence),
            (0, NamedBy::CoronaryOstia, 1.0)
        );
        // The same ostia while sector 1 faces anterior: the ostia decide,
        // with less confidence.
        let n = name([true, true, false], 1);
        assert_eq!(n.right_sector, 0);
        assert!(!n.agrees_with_position && n.confidence < 1.0);
        // Ostia in sectors 2 and 0: sector 1 is non-coronary, 2 is right.
        assert_eq!(name([true, false, true], 0).right_sector, 2);
    }

    #[test]
    fn without_two_ostia_the_anterior_sinus_is_the_right_one() {
        for seen in [[false; 3], [true, false, false], [true; 3]] {
            let n = name(seen, 2);
            assert_eq!((n.right_sector, n.by), (2, NamedBy::Position));
        }
    }

    #[test]
    fn sectors_run_counter_clockwise_from_their_pillar() {
        let p = [350.0, 100.0, 230.0];
        assert_eq!(sector_of(355.0, &p), 0);
        assert_eq!(sector_of(20.0, &p), 0);
        assert_eq!(sector_of(100.0, &p), 1);
        assert_eq!(sector_of(229.0, &p), 1);
        assert_eq!(sector_of(300.0, &p), 2);
    }
}
