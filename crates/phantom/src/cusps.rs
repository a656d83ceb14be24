//! Closed native cusps: distance to their mid-surfaces.
//!
//! In diastole the three cusps hang from their hinge lines (nadir up to the
//! commissures) and meet in the middle: seen from the aorta, a "Y" of three
//! coaptation sheets along the commissure directions. Each cusp belly is the
//! height field over its sector from the central point (height h_c on the
//! axis) to the hinge line on the wall (height hinge(θ), radius R_h(θ));
//! hinge(θ) rises from the (possibly tilted) annulus at the sinus centre to
//! h_comm at the commissures. Where two bellies meet, at each commissure
//! angle, a radial coaptation sheet stands from the bellies up to the free
//! edge h_free, a few mm below the commissures.
//! All heights are arc length along the valve axis (the root is on the
//! straight piece of the centreline, where that is the valve-frame height).

use super::anatomy::{Anatomy, Cusps};
use coapt_geom::{Point3, Vector3};

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

    // Belly of the cusp whose sector holds θ: along the commissure
    // meridians it rises as the coaptation sheets' bottom B(t), along the
    // sinus-centre meridian it falls as D(t) to the annulus, blended by the
    // sinus lobe (0 at the commissures, 1 at the sinus centre); at the wall
    // (t = 1) that is exactly the hinge line.
    let (_, lobe, dlobe) = prof.lobe(th);
    let d_ann = prof.annulus_s(th).0;
    let hz = hinge(an, th);
    let r_h = prof.eval(hz, th).r;
    let h_comm = an.h_comm_mm;
    let hc = c.h_centre_mm;
    let mut best = if rho <= r_h {
        let t = rho / r_h;
        let tp = t.powf(pw);
        let dtp = pw * t.powf(pw - 1.0) / r_h;
        let (b, db) = (hc + (h_comm - hc) * tp, (h_comm - hc) * dtp);
        let (dd, ddd) = (hc + (d_ann - hc) * tp, (d_ann - hc) * dtp);
        let h = b * (1.0 - lobe) + dd * lobe;
        let h_rho = db * (1.0 - lobe) + ddd * lobe;
        let h_th = if rho > 1e-9 {
            (dd - b) * dlobe / rho
        } else {
            0.0
        };
        let g = (1.0 + h_rho * h_rho + h_th * h_th).sqrt();
        let d = (s - h) / g;
        let e_theta = st.tangent.cross(&l.radial);
        let n = (st.tangent - l.radial * h_rho - e_theta * h_th) / g;
        (d.abs(), if d >= 0.0 { n } else { -n })
    } else {
        // Beyond the hinge (in the sinus, or in the wall): distance to it.
        let (a, b) = (rho - r_h, s - hz);
        let d = a.hypot(b);
        let n = (l.radial * a + st.tangent * b) / d.max(1e-12);
        (d, n)
    };

    // Coaptation sheets at the commissure angles.
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
