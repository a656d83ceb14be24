//! The aortic lumen tube (LVOT, root, ascending aorta): the truth object.
//!
//! Cross-sections are star-shaped about the centreline: a point at distance
//! ρ from its closest centreline station, at angle θ from the transported
//! frame vector e1, is inside when ρ < r(s, θ). Because the centreline's
//! curvature radius exceeds every lumen radius, this is the image of the
//! normal-plane map (s, θ, ρ) ↦ c(s) + ρ·u(s, θ); on the straight pieces its
//! Jacobian is ρ, and on the arc the cross-sections are circular, so the
//! curvature term integrates to zero and the volume is ∫∫ r²/2 dθ ds exactly
//! (Pappus).

use std::f64::consts::{PI, TAU};

use serde::Serialize;

use super::centreline::{Centreline, Station};
use super::shapes::Aabb;
use coapt_geom::{DataArray, DataValues, Point3, TriMesh, Vector3};

/// Shape of r(s, θ); see the module docs of `phantom` for the ranges.
#[derive(Debug, Clone, Serialize)]
pub struct RadiusProfile {
    /// Annulus (VAJ) radius.
    pub r_annulus_mm: f64,
    /// LVOT ellipticity (relative), fading to 0 at the annulus.
    pub lvot_ellipticity: f64,
    /// Angle of the LVOT's long semi-axis from e1.
    pub lvot_major_angle_rad: f64,
    /// Length over which the ellipticity fades in, below the annulus.
    pub lvot_fade_mm: f64,
    pub h_stj_mm: f64,
    pub r_stj_mm: f64,
    /// Length of the STJ → ascending transition.
    pub stj_transition_mm: f64,
    pub r_ascending_mm: f64,
    /// Relative amplitude and wavelength of the slow variation of the
    /// ascending radius (circular cross-sections, so volume stays exact).
    pub ascending_variation: f64,
    pub ascending_wavelength_mm: f64,
    /// Commissure angles in the transported frame, increasing, first = 0.
    pub commissure_angles_rad: [f64; 3],
    /// Sinus k lies between commissures k and k+1: its bulge amplitude.
    pub sinus_amplitude: [f64; 3],
    /// Tilt of the annulus (nadir) plane to the commissure plane (which is
    /// normal to the valve axis). Zero: both planes normal to the axis and
    /// the profile is exactly the untilted one.
    #[serde(skip_serializing_if = "is_zero")]
    pub annulus_tilt_rad: f64,
    /// Angle (from e1) of the annulus plane's lowest point.
    #[serde(skip_serializing_if = "is_zero")]
    pub annulus_low_angle_rad: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// Normalisation of the sinus bump t²(1−t)³, whose maximum is at t = 0.4.
const BUMP_PEAK_T: f64 = 0.4;
fn bump_norm() -> f64 {
    BUMP_PEAK_T.powi(2) * (1.0 - BUMP_PEAK_T).powi(3)
}

/// C¹ smoothstep 3t²−2t³ and its derivative, t clamped to [0, 1].
fn smoothstep(t: f64) -> (f64, f64) {
    let t = t.clamp(0.0, 1.0);
    (t * t * (3.0 - 2.0 * t), 6.0 * t * (1.0 - t))
}

/// Below a tilted annulus the LVOT's axis turns from the valve axis onto
/// the annulus plane's normal over this depth (mm; the real CT's least
/// sections turn 27° over 7 mm onto its annulus), and back to the valve axis at
/// [`LVOT_TURN_END_MM`], past the LVOT's end inside the LV.
pub const LVOT_TURN_MM: f64 = 6.0;
pub const LVOT_TURN_END_MM: f64 = 20.0;
/// Newton iterations of [`RadiusProfile::lvot_tilted`] (it takes 3–5).
const MAX_LVOT_NEWTON: usize = 30;

/// Radius with its partial derivatives.
#[derive(Debug, Clone, Copy)]
pub struct RadiusSample {
    pub r: f64,
    pub dr_ds: f64,
    pub dr_dtheta: f64,
}

impl RadiusProfile {
    /// Start of the ascending part (end of the STJ transition).
    pub fn s_ascending(&self) -> f64 {
        self.h_stj_mm + self.stj_transition_mm
    }

    /// Radius at the STJ-free part of the root, without the sinus bulge.
    pub fn base_root(&self, s: f64) -> (f64, f64) {
        let h = self.h_stj_mm;
        let (w, dw) = smoothstep(s / h);
        let dr = self.r_stj_mm - self.r_annulus_mm;
        (self.r_annulus_mm + dr * w, dr * dw / h)
    }

    /// Sinus bump along s (0 at the annulus and at the STJ, C¹ there).
    fn bump(&self, s: f64) -> (f64, f64) {
        let h = self.h_stj_mm;
        let t = (s / h).clamp(0.0, 1.0);
        let n = bump_norm();
        let b = t * t * (1.0 - t).powi(3) / n;
        let db = (2.0 * t * (1.0 - t).powi(3) - 3.0 * t * t * (1.0 - t).powi(2)) / n / h;
        (b, db)
    }

    /// Sector (sinus index) of angle θ and its lobe value and derivative:
    /// sin²(π u) over the sector, zero with zero slope at both commissures,
    /// so unequal sectors still join C¹.
    pub fn lobe(&self, theta: f64) -> (usize, f64, f64) {
        let c = &self.commissure_angles_rad;
        let th = (theta - c[0]).rem_euclid(TAU) + c[0];
        let k = if th < c[1] {
            0
        } else if th < c[2] {
            1
        } else {
            2
        };
        let start = c[k];
        let end = if k == 2 { c[0] + TAU } else { c[k + 1] };
        let w = end - start;
        let u = (th - start) / w;
        let sp = (PI * u).sin();
        (k, sp * sp, PI * (2.0 * PI * u).sin() / w)
    }

    /// Angle of the centre of sinus k (midway between its commissures).
    pub fn sinus_centre(&self, k: usize) -> f64 {
        let c = &self.commissure_angles_rad;
        let end = if k == 2 { c[0] + TAU } else { c[k + 1] };
        0.5 * (c[k] + end)
    }

    /// Arc length where the annulus plane meets the wall at angle θ, and its
    /// θ-derivative. The plane passes through the annulus centre; the wall
    /// there is the circle ρ = r_annulus (the warped profile starts with it),
    /// so the intersection is exactly s = −tan α · r_a · cos(θ − θ_low).
    pub fn annulus_s(&self, theta: f64) -> (f64, f64) {
        if self.annulus_tilt_rad == 0.0 {
            return (0.0, 0.0);
        }
        let k = self.annulus_tilt_rad.tan() * self.r_annulus_mm;
        let a = theta - self.annulus_low_angle_rad;
        (-k * a.cos(), k * a.sin())
    }

    /// r(s, θ). With an annulus tilt the root part is the untilted profile
    /// stretched per angle from [δ(θ), h_stj] onto [0, h_stj], δ(θ) the
    /// annulus plane's arc length at the wall: the sinuses, nadirs and VAJ
    /// follow the tilted plane while the STJ and everything above stay where
    /// they were. Below the plane the LVOT turns onto the plane's normal
    /// ([`RadiusProfile::lvot_tilted`]), and the wall stays C¹.
    pub fn eval(&self, s: f64, theta: f64) -> RadiusSample {
        if self.annulus_tilt_rad == 0.0 || s > self.h_stj_mm {
            return self.eval_plain(s, theta);
        }
        let (d, dd) = self.annulus_s(theta);
        let h = self.h_stj_mm;
        if s < d {
            self.lvot_tilted(s, theta)
        } else {
            let se = (s - d) * h / (h - d);
            let r = self.eval_plain(se, theta);
            RadiusSample {
                r: r.r,
                dr_ds: r.dr_ds * h / (h - d),
                dr_dtheta: r.dr_dtheta + r.dr_ds * h * dd * (s - h) / ((h - d) * (h - d)),
            }
        }
    }

    /// Lateral shift of the tilted LVOT's sections at `depth` below the
    /// annulus plane, away from the plane's lowest point, and its
    /// derivative: tan α times the integral of a window that turns the
    /// axis onto the plane's normal over [`LVOT_TURN_MM`] and back to the
    /// valve axis at [`LVOT_TURN_END_MM`] (inside the LV, and the shift
    /// stays bounded).
    pub fn lvot_shift(&self, depth: f64) -> (f64, f64) {
        let k = self.annulus_tilt_rad.tan();
        let l = LVOT_TURN_MM;
        let ramp = |x: f64| {
            let t = x / l;
            if t <= 0.0 {
                0.0
            } else if t < 1.0 {
                l * (t * t * t - 0.5 * t * t * t * t)
            } else {
                0.5 * l + (x - l)
            }
        };
        let end = depth - LVOT_TURN_END_MM;
        (
            k * (ramp(depth) - ramp(end)),
            k * (smoothstep(depth / l).0 - smoothstep(end / l).0),
        )
    }

    /// The LVOT's section radius `depth` below the annulus plane at angle θ
    /// of the section's own centre, with its depth and θ derivatives: the
    /// annulus circle, its ellipticity fading in with depth.
    fn lvot_section(&self, depth: f64, theta: f64) -> (f64, f64, f64) {
        let (w, dw) = smoothstep(depth / self.lvot_fade_mm);
        let ang = 2.0 * (theta - self.lvot_major_angle_rad);
        let (r, e) = (self.r_annulus_mm, self.lvot_ellipticity);
        (
            r * (1.0 + e * w * ang.cos()),
            r * e * dw / self.lvot_fade_mm * ang.cos(),
            -2.0 * r * e * w * ang.sin(),
        )
    }

    /// r(s, θ) below a tilted annulus plane. In ceCTA the lumen's least
    /// sections turn from the aorta's onto the annulus as they reach the
    /// LVOT: on the real CT of `../shared/real/` they turn 27° over the
    /// 7 mm down to the annulus and settle within 4° of the nadirs' plane
    /// (`segment/vaj_floor.rs`). So the LVOT here stands square to the
    /// plane, the annulus curve swept down the plane's normal: a wall point
    /// at depth d (along the valve axis, from its foot F on the plane) at
    /// F − d·t − G(d)·l, l towards the plane's lowest point and G
    /// ([`RadiusProfile::lvot_shift`]) turning the sweep from the valve
    /// axis at the plane (so the wall is C¹ there) onto the normal. For
    /// the ray at (s, θ) Newton solves for the radius ρ and the depth d:
    /// the plane through F (E1) and F on the section circle (E2); the
    /// derivatives follow by implicit differentiation.
    fn lvot_tilted(&self, s: f64, theta: f64) -> RadiusSample {
        let (sa, ca) = self.annulus_tilt_rad.sin_cos();
        let (sd, cd) = (theta - self.annulus_low_angle_rad).sin_cos();
        let u = [theta.cos(), theta.sin()];
        let up = [-u[1], u[0]];
        let l = [
            self.annulus_low_angle_rad.cos(),
            self.annulus_low_angle_rad.sin(),
        ];
        let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
        let mut rho = self.r_annulus_mm;
        let mut d = -s - rho * sa / ca * cd;
        let mut jac = [[0.0; 2]; 2];
        let mut e2_theta = 0.0;
        for _ in 0..MAX_LVOT_NEWTON {
            let (g, g1) = self.lvot_shift(d);
            let f = [rho * u[0] + g * l[0], rho * u[1] + g * l[1]];
            let fl = f[0].hypot(f[1]);
            let fh = [f[0] / fl, f[1] / fl];
            let tau = [-fh[1], fh[0]];
            let (r, dr_dd, dr_dth) = self.lvot_section(d, f[1].atan2(f[0]));
            let e1 = (d + s) * ca + g * sa + rho * sa * cd;
            let e2 = fl - r;
            jac = [
                [sa * cd, ca + g1 * sa],
                [
                    dot(fh, u) - dr_dth * dot(tau, u) / fl,
                    g1 * dot(fh, l) - dr_dd - dr_dth * g1 * dot(tau, l) / fl,
                ],
            ];
            e2_theta = rho * dot(fh, up) - dr_dth * rho * dot(tau, up) / fl;
            let det = jac[0][0] * jac[1][1] - jac[0][1] * jac[1][0];
            let d_rho = -(jac[1][1] * e1 - jac[0][1] * e2) / det;
            let d_d = -(-jac[1][0] * e1 + jac[0][0] * e2) / det;
            rho += d_rho;
            d += d_d;
            if d_rho.abs() + d_d.abs() < 1e-12 * self.r_annulus_mm {
                break;
            }
        }
        // ∂(ρ, d)/∂x = −J⁻¹ ∂E/∂x; only ρ's row is needed.
        let det = jac[0][0] * jac[1][1] - jac[0][1] * jac[1][0];
        let d_rho = |e1: f64, e2: f64| -(jac[1][1] * e1 - jac[0][1] * e2) / det;
        RadiusSample {
            r: rho,
            dr_ds: d_rho(ca, 0.0),
            dr_dtheta: d_rho(-rho * sa * sd, e2_theta),
        }
    }

    /// The untilted profile.
    pub fn eval_plain(&self, s: f64, theta: f64) -> RadiusSample {
        if s < 0.0 {
            let (w, dw) = smoothstep(-s / self.lvot_fade_mm);
            let ang = 2.0 * (theta - self.lvot_major_angle_rad);
            let e = self.lvot_ellipticity;
            RadiusSample {
                r: self.r_annulus_mm * (1.0 + e * w * ang.cos()),
                dr_ds: -self.r_annulus_mm * e * dw / self.lvot_fade_mm * ang.cos(),
                dr_dtheta: -2.0 * self.r_annulus_mm * e * w * ang.sin(),
            }
        } else if s <= self.h_stj_mm {
            let (base, dbase) = self.base_root(s);
            let (b, db) = self.bump(s);
            let (k, l, dl) = self.lobe(theta);
            let a = self.sinus_amplitude[k];
            let f = 1.0 + a * b * l;
            RadiusSample {
                r: base * f,
                dr_ds: dbase * f + base * a * db * l,
                dr_dtheta: base * a * b * dl,
            }
        } else if s <= self.s_ascending() {
            let (w, dw) = smoothstep((s - self.h_stj_mm) / self.stj_transition_mm);
            let dr = self.r_ascending_mm - self.r_stj_mm;
            RadiusSample {
                r: self.r_stj_mm + dr * w,
                dr_ds: dr * dw / self.stj_transition_mm,
                dr_dtheta: 0.0,
            }
        } else {
            let ph = TAU * (s - self.s_ascending()) / self.ascending_wavelength_mm;
            let v = self.ascending_variation;
            RadiusSample {
                r: self.r_ascending_mm * (1.0 + v * 0.5 * (1.0 - ph.cos())),
                dr_ds: self.r_ascending_mm * v * 0.5 * ph.sin() * TAU
                    / self.ascending_wavelength_mm,
                dr_dtheta: 0.0,
            }
        }
    }

    /// An upper bound of r over all s and θ (for culling and checks).
    pub fn r_max_bound(&self) -> f64 {
        let sinus = (0..3)
            .map(|k| self.base_root(self.h_stj_mm).0 * (1.0 + self.sinus_amplitude[k]))
            .fold(0.0, f64::max);
        sinus
            .max(self.r_ascending_mm * (1.0 + self.ascending_variation.abs()))
            .max(
                self.r_annulus_mm * (1.0 + self.lvot_ellipticity)
                    + self.annulus_tilt_rad.tan() * LVOT_TURN_END_MM,
            )
            .max(self.r_stj_mm)
    }

    /// Maximum radius of sinus k over the root height, by dense sampling
    /// (along the sinus centre, where the lobe peaks).
    pub fn sinus_max(&self, k: usize) -> f64 {
        let th = self.sinus_centre(k);
        const SAMPLES: usize = 4000;
        (0..=SAMPLES)
            .map(|i| {
                self.eval_plain(self.h_stj_mm * i as f64 / SAMPLES as f64, th)
                    .r
            })
            .fold(0.0, f64::max)
    }
}

/// Where a point sits relative to the tube.
#[derive(Debug, Clone, Copy)]
pub struct LocalCoords {
    pub station: Station,
    pub rho: f64,
    pub theta: f64,
    /// Unit radial direction (arbitrary on the centreline).
    pub radial: Vector3,
}

#[derive(Debug, Clone)]
pub struct Lumen {
    pub centreline: Centreline,
    pub profile: RadiusProfile,
    /// The tube is capped this far below the annulus (it continues as LV).
    pub lvot_length_mm: f64,
    /// `profile.r_max_bound()`, cached for the far-field test.
    pub r_max_mm: f64,
    /// The truth region ends at this plane z = const (∞: at the top face).
    pub truth_top_z: f64,
}

/// Gauss–Legendre nodes and weights on [−1, 1], 8 points.
const GL8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// Composite Gauss–Legendre on [a, b] with `n` panels.
fn integrate(a: f64, b: f64, n: usize, f: impl Fn(f64) -> f64) -> f64 {
    if b <= a {
        return 0.0;
    }
    let h = (b - a) / n as f64;
    let mut sum = 0.0;
    for i in 0..n {
        let m = a + h * (i as f64 + 0.5);
        for &(x, w) in &GL8 {
            sum += w * f(m + 0.5 * h * x);
        }
    }
    sum * 0.5 * h
}

impl Lumen {
    pub fn local(&self, p: &Point3) -> LocalCoords {
        let st = self.centreline.project(p);
        let q = p - st.point;
        let (x, y) = (q.dot(&st.e1), q.dot(&st.e2));
        // sqrt rather than hypot: no overflow risk at mm scale, and much faster.
        let rho = (x * x + y * y).sqrt();
        let radial = if rho > 1e-12 {
            (st.e1 * x + st.e2 * y) / rho
        } else {
            st.e1
        };
        LocalCoords {
            station: st,
            rho,
            theta: y.atan2(x),
            radial,
        }
    }

    /// Exact inside test of the (uncapped) tube.
    pub fn inside(&self, p: &Point3) -> bool {
        let l = self.local(p);
        l.rho < self.profile.eval(l.station.s, l.theta).r
    }

    /// Height above the annulus plane along the valve axis.
    pub fn height(&self, p: &Point3) -> f64 {
        (p - self.centreline.origin).dot(&self.centreline.axis)
    }

    /// Centre of the LVOT's section `depth` below the annulus centre: on the
    /// valve axis, shifted away from the tilted plane's lowest point
    /// ([`RadiusProfile::lvot_shift`]).
    pub fn lvot_centre(&self, depth: f64) -> Point3 {
        let st = self.centreline.station(0.0);
        let low = self.profile.annulus_low_angle_rad;
        let l = st.e1 * low.cos() + st.e2 * low.sin();
        st.point - st.tangent * depth - l * self.profile.lvot_shift(depth).0
    }

    /// Unit normal of the annulus (nadir, VAJ) plane, towards the aorta: the
    /// valve axis tipped by the annulus tilt towards the plane's lowest point.
    pub fn annulus_normal(&self) -> Vector3 {
        let p = &self.profile;
        if p.annulus_tilt_rad == 0.0 {
            return self.centreline.axis;
        }
        let st = self.centreline.station(0.0);
        let low = st.e1 * p.annulus_low_angle_rad.cos() + st.e2 * p.annulus_low_angle_rad.sin();
        st.tangent * p.annulus_tilt_rad.cos() + low * p.annulus_tilt_rad.sin()
    }

    /// Whether `p` lies in the truth region's height range: on or above the
    /// annulus plane and not above the truth top (`truth_top_z`).
    pub fn in_truth_range(&self, p: &Point3) -> bool {
        let above = if self.profile.annulus_tilt_rad == 0.0 {
            self.height(p) >= 0.0
        } else {
            (p - self.centreline.origin).dot(&self.annulus_normal()) >= 0.0
        };
        above && p.z <= self.truth_top_z
    }

    /// Approximate signed distance of the uncapped tube and its normal:
    /// (ρ − r) scaled by the wall's gradient norm, first-order exact at the wall.
    pub fn sdf(&self, p: &Point3) -> (f64, Vector3) {
        let l = self.local(p);
        let rs = self.profile.eval(l.station.s, l.theta);
        let rho = l.rho.max(1e-6);
        let tangential = rs.dr_dtheta / rho;
        let e_theta = l.station.tangent.cross(&l.radial);
        let g = l.radial - e_theta * tangential - l.station.tangent * rs.dr_ds;
        let gn = g.norm();
        ((l.rho - rs.r) / gn, g / gn)
    }

    /// Point on the analytic wall.
    pub fn wall_point(&self, s: f64, theta: f64) -> Point3 {
        let st = self.centreline.station(s);
        let r = self.profile.eval(s, theta).r;
        st.point + (st.e1 * theta.cos() + st.e2 * theta.sin()) * r
    }

    /// Volume of the tube between s = 0 and `s_top`: ∫∫ r²/2 dθ ds, by
    /// Gauss–Legendre per smooth piece (sectors in θ, s-intervals between
    /// the profile's breakpoints), accurate to ~1e-10 relative.
    pub fn volume(&self, s_top: f64) -> f64 {
        let p = &self.profile;
        const PANELS: usize = 64;
        let c = p.commissure_angles_rad;
        let sectors = [(c[0], c[1]), (c[1], c[2]), (c[2], c[0] + TAU)];
        let root_top = p.h_stj_mm.min(s_top);
        let root = if p.annulus_tilt_rad == 0.0 {
            integrate(0.0, root_top, PANELS, |s| {
                sectors
                    .iter()
                    .map(|&(a, b)| integrate(a, b, PANELS / 4, |t| 0.5 * p.eval(s, t).r.powi(2)))
                    .sum()
            })
        } else {
            // Tilted annulus: the region above the plane is, per θ, the wall
            // from δ(θ) up plus a cone wedge k(θ)·r_a³/6 (k = the plane's
            // slope along θ), whose integral over θ is zero since k ∝ cos.
            // The stretch s ↦ s_eff has constant Jacobian (h − δ)/h per θ.
            // (Assumes s_top ≥ h_stj, which the grid placement guarantees.)
            let h = p.h_stj_mm;
            integrate(0.0, h, PANELS, |se| {
                sectors
                    .iter()
                    .map(|&(a, b)| {
                        integrate(a, b, PANELS / 4, |t| {
                            let d = p.annulus_s(t).0;
                            0.5 * p.eval_plain(se, t).r.powi(2) * (h - d) / h
                        })
                    })
                    .sum()
            })
        };
        // Above the STJ the sections are circles.
        let circle = |s: f64| PI * p.eval(s, 0.0).r.powi(2);
        let mid_top = p.s_ascending().min(s_top);
        let trans = integrate(p.h_stj_mm.min(s_top), mid_top, PANELS, circle);
        let asc = integrate(mid_top, s_top, 4 * PANELS, circle);
        root + trans + asc
    }

    /// Box containing the tube between s_lo and s_hi.
    pub fn aabb(&self, s_lo: f64, s_hi: f64) -> Aabb {
        let r = self.profile.r_max_bound();
        let mut b = Aabb::empty();
        const STEPS: usize = 64;
        for i in 0..=STEPS {
            let s = s_lo + (s_hi - s_lo) * i as f64 / STEPS as f64;
            b = b.union(&Aabb::around(&self.centreline.station(s).point, r));
        }
        b
    }

    /// Ring and sector counts of [`Lumen::surface`].
    pub fn surface_grid(&self, s_top: f64, grid_mm: f64) -> (usize, usize) {
        let cl = &self.centreline;
        let stretch = if cl.has_arc() {
            1.0 + self.r_max_mm / cl.arc_radius
        } else {
            1.0
        };
        let n_s = ((s_top * stretch / grid_mm).ceil() as usize).max(2);
        let n_t = ((TAU * self.r_max_mm / grid_mm).ceil() as usize).max(12);
        (n_s, n_t)
    }

    /// Closed parametric surface of the truth region s ∈ [0, s_top]: wall
    /// vertices exactly on the analytic wall, flat fan caps at both ends.
    /// Cell data `region`: 0 wall, 1 VAJ cap, 2 top cap.
    ///
    /// `grid_mm` bounds the spacing of the (s, θ) vertex grid on the wall,
    /// both around (at the largest radius) and along (on the outside of the
    /// arc, where rings spread by 1 + r/R_c); the quad diagonals are √2
    /// longer.
    pub fn surface(&self, s_top: f64, grid_mm: f64) -> TriMesh {
        let (n_s, n_t) = self.surface_grid(s_top, grid_mm);
        let mut vertices = Vec::with_capacity((n_s + 1) * n_t + 2);
        let tilted = self.profile.annulus_tilt_rad != 0.0;
        for i in 0..=n_s {
            let s = s_top * i as f64 / n_s as f64;
            let st = self.centreline.station(s);
            for j in 0..n_t {
                let th = TAU * j as f64 / n_t as f64;
                if tilted {
                    // Rings run from the tilted annulus curve to the top cap.
                    let d = self.profile.annulus_s(th).0;
                    let si = d + (s_top - d) * i as f64 / n_s as f64;
                    vertices.push(self.wall_point(si, th));
                } else {
                    let r = self.profile.eval(s, th).r;
                    vertices.push(st.point + (st.e1 * th.cos() + st.e2 * th.sin()) * r);
                }
            }
        }
        let idx = |i: usize, j: usize| (i * n_t + j % n_t) as u32;
        let mut triangles = Vec::with_capacity(2 * n_s * n_t + 2 * n_t);
        let mut region = Vec::with_capacity(triangles.capacity());
        // Wall: (∂θ × ∂s) points outward for θ counter-clockwise about the tangent.
        for i in 0..n_s {
            for j in 0..n_t {
                triangles.push([idx(i, j), idx(i, j + 1), idx(i + 1, j)]);
                triangles.push([idx(i, j + 1), idx(i + 1, j + 1), idx(i + 1, j)]);
                region.extend([0, 0]);
            }
        }
        let bottom = vertices.len() as u32;
        vertices.push(self.centreline.station(0.0).point);
        let top = vertices.len() as u32;
        vertices.push(self.centreline.station(s_top).point);
        for j in 0..n_t {
            triangles.push([bottom, idx(0, j + 1), idx(0, j)]);
            region.push(1);
        }
        for j in 0..n_t {
            triangles.push([top, idx(n_s, j), idx(n_s, j + 1)]);
            region.push(2);
        }
        let mut mesh = TriMesh::new(vertices, triangles);
        mesh.cell_data
            .insert(DataArray::new("region", 1, DataValues::I32(region)));
        mesh
    }
}
