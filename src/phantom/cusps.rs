//! Closed native cusps: distance to their mid-surfaces.
//!
//! In diastole the three cusps hang from their hinge lines (nadir up to the
//! commissures) and meet in the middle: seen from the aorta, a "Y" of three
//! coaptation sheets along the commissure directions. Each cusp belly is the
//! height field h = h_c + (hinge(θ) − h_c)·(ρ/R_h(θ))^p over its sector,
//! from the central point (height h_c on the axis) to the hinge line on the
//! wall (height hinge(θ), radius R_h(θ)); hinge(θ) rises from the (possibly
//! tilted) annulus at the sinus centre to h_comm at the commissures. Above
//! where two bellies meet, at each commissure angle, a radial coaptation
//! sheet stands up to the free edge h_free, a few mm below the commissures.
//! All heights are arc length along the valve axis (the root is on the
//! straight piece of the centreline, where that is the valve-frame height).

use super::anatomy::{Anatomy, Cusps};
use crate::geom::{Point3, Vector3};

/// Hinge height at angle θ: the annulus at the sinus centre, h_comm at the
/// commissures, following the sinus lobe shape in between.
fn hinge(an: &Anatomy, theta: f64) -> f64 {
    let p = &an.lumen.profile;
    let (_, lobe, _) = p.lobe(theta);
    let d = p.annulus_s(theta).0;
    d + (an.h_comm_mm - d) * (1.0 - lobe)
}

/// Unsigned distance from `p` to the nearest cusp mid-surface, with an
/// approximate unit normal (for the partial-volume width). First-order
/// accurate near the sheets, a lower-bound-like estimate far away.
pub fn sheet_distance(an: &Anatomy, c: &Cusps, p: &Point3) -> (f64, Vector3) {
    let lumen = &an.lumen;
    let prof = &lumen.profile;
    let l = lumen.local(p);
    let (s, rho, th) = (l.station.s, l.rho, l.theta);
    let st = &l.station;
    let pw = c.belly_power;

    // Belly of the cusp whose sector holds θ.
    let hz = hinge(an, th);
    let r_h = prof.eval(hz, th).r;
    let mut best = if rho <= r_h {
        let t = rho / r_h;
        let h = c.h_centre_mm + (hz - c.h_centre_mm) * t.powf(pw);
        let slope = (hz - c.h_centre_mm) * pw * t.powf(pw - 1.0) / r_h;
        let g = (1.0 + slope * slope).sqrt();
        let d = (s - h) / g;
        let n = (st.tangent - l.radial * slope) / g;
        (d.abs(), if d >= 0.0 { n } else { -n })
    } else {
        // Beyond the hinge (in the sinus, or in the wall): distance to it.
        let (a, b) = (rho - r_h, s - hz);
        let d = a.hypot(b);
        let n = (l.radial * a + st.tangent * b) / d.max(1e-12);
        (d, n)
    };

    // Coaptation sheets at the commissure angles.
    let h_comm = an.h_comm_mm;
    for &cj in &prof.commissure_angles_rad {
        let phi = th - cj;
        let (sin, cos) = phi.sin_cos();
        let x = (rho * cos).max(0.0);
        let lateral = if cos >= 0.0 { rho * sin } else { rho };
        let r_c = prof.eval(h_comm, cj).r;
        let t = (x / r_c).min(1.0);
        let bottom = c.h_centre_mm + (h_comm - c.h_centre_mm) * t.powf(pw);
        let e = if s < bottom {
            s - bottom
        } else if s > c.h_free_mm {
            s - c.h_free_mm
        } else {
            0.0
        };
        let ex = (x - r_c).max(0.0);
        let d = (lateral * lateral + e * e + ex * ex).sqrt();
        if d < best.0 {
            // In-plane normal of the sheet, then towards the nearest edge.
            let u_perp = -st.e1 * cj.sin() + st.e2 * cj.cos();
            let n = u_perp * lateral + st.tangent * e + (st.e1 * cj.cos() + st.e2 * cj.sin()) * ex;
            let n = if d > 1e-12 { n / d } else { u_perp };
            best = (d, n);
        }
    }
    best
}
