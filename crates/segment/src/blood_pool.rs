//! The blood pool, its noise and the wall around it, read on the tracked
//! lumen's circles: they set the threshold that grows the lumen.

use super::track::{self, annulus_values, median, slice_f32};
use coapt_base::{Error, Result};
use coapt_geom::Volume;

/// Intensities (HU) measured on the track.
pub struct BloodPool {
    /// Median inside 0.6 r of the track's circles.
    pub blood: f64,
    /// Robust standard deviation (1.4826 × MAD) of those values.
    pub noise: f64,
    /// The wall ring's value, at most 100 HU under the blood.
    pub wall: f64,
    /// Halfway between blood and wall.
    pub threshold: f64,
}

/// Measure the pool on at most about 40 of the track's circles; refuse a
/// CT whose blood is darker than `contrast_min_hu`.
pub fn measure(ct: &Volume<i16>, found: &track::Found, contrast_min_hu: f64) -> Result<BloodPool> {
    let sp = ct.spacing();
    let [ni, nj, _] = ct.dims();
    let mut inside = Vec::new();
    let mut wall = Vec::new();
    let stride = (found.track.len() / 40).max(1);
    // A tube tilted from the head–feet axis cuts the axial slices in
    // ellipses, and a ring around the circle found in one lies partly in
    // the lumen (at 60°, 70 % of it): the wall is the median of the ring's
    // part outside the ellipse, the quantile (1 − inside)/2 of the ring.
    // A track that went on from its first circle met near-circular cuts
    // (the radius may change by 20 % a slice): there the plain median holds.
    let wall_quantile = match (found.direction, found.track.as_slice()) {
        (Some(d), [t]) => 0.5 * (1.0 - ring_inside_ellipse(d.z.abs().acos(), t.r_mm)),
        _ => 0.5,
    };
    for t in found.track.iter().step_by(stride) {
        let img = slice_f32(ct, t.k);
        inside.extend(annulus_values(
            &img,
            ni,
            nj,
            [sp[0], sp[1]],
            (t.i, t.j),
            0.0,
            0.6 * t.r_mm,
        ));
        wall.extend(annulus_values(
            &img,
            ni,
            nj,
            [sp[0], sp[1]],
            (t.i, t.j),
            t.r_mm + 0.5,
            t.r_mm + 1.5,
        ));
    }
    let blood = median(&mut inside);
    let mut dev: Vec<f64> = inside.iter().map(|v| (v - blood).abs()).collect();
    let noise = 1.4826 * median(&mut dev);
    wall.sort_unstable_by(f64::total_cmp);
    let wall_hu = wall
        .get((wall_quantile * wall.len() as f64) as usize)
        .copied()
        .unwrap_or(f64::NAN)
        .min(blood - 100.0);
    if !(blood >= contrast_min_hu) {
        return Err(Error::failed(
            "segment",
            format!(
                "looked for contrast-filled blood (≥ {contrast_min_hu:.0} HU) in the ascending aorta found on the top slice and measured {blood:.0} HU: this CT has no contrast"
            ),
        ));
    }
    Ok(BloodPool {
        blood,
        noise,
        wall: wall_hu,
        threshold: 0.5 * (blood + wall_hu),
    })
}

/// Fraction of the wall ring [r + 0.5, r + 1.5] mm (its mid radius) that
/// lies inside the axial cut of a tube of radius `r` tilted by `tilt` rad
/// from the slice normal: an ellipse of semi-axes r / cos(tilt) and r.
fn ring_inside_ellipse(tilt: f64, r: f64) -> f64 {
    let (a, b) = (r / tilt.cos().max(0.1), r);
    let n = 360;
    let inside = (0..n)
        .filter(|&k| {
            let th = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
            a * b / ((b * th.cos()).powi(2) + (a * th.sin()).powi(2)).sqrt() > r + 1.0
        })
        .count();
    inside as f64 / n as f64
}
