//! Penalty planes of seed 001, eq. 37 (`contact = "planes"`; docs/close.md).
//!
//! For node x and plane (R, n): d = (x − R)·n (mm), f(d) = max(1 − 2d/η₂, 0)
//! and the seed's force is
//!
//! ```text
//! F = (η₁ ΣA/3) f(d) n          (N; η₁ in MPa, ΣA = current area of the incident triangles, mm²)
//! ```
//!
//! It acts from d = η₂/2 down and grows linearly. Treating the area as a
//! constant parameter a (= ΣA, e.g. from the last converged state) F is the
//! negative gradient of
//!
//! ```text
//! e = (η₁ a/3)·(η₂/4)·f(d)²     (N·mm)
//! ∂e/∂x = −(η₁ a/3) f(d) n      (= −F)
//! ∂²e/∂x² = (2η₁ a/(3η₂)) n nᵀ  when f > 0, else 0
//! ```
//!
//! which is only C¹: the Hessian jumps at d = η₂/2, and at equilibrium the
//! nodes at the rim of a coaptation zone sit right there (their contact
//! force tends to zero), which stalls Newton. So the kink of f is rounded:
//! with u = 1 − 2d/η₂, f = u for u ≥ w, (u + w)²/(4w) for |u| < w, 0 below,
//! w = [`ROUND`] (a change of the force by at most η₁ΣA/3 · w/4, only at
//! the rim). With a pressure P < η₁ the equilibrium sits at
//! d* = (η₂/2)(1 − P/η₁).

use nalgebra::Matrix3;

use crate::element::V3;
use coapt_base::units::MMHG_IN_MPA;

/// Half-width w of the rounded kink of f, in units of u = 1 − 2d/η₂.
pub const ROUND: f64 = 0.05;

/// The rounded ramp: (f, f′, F) with F′ = f, F(−w) = 0.
fn ramp(u: f64) -> (f64, f64, f64) {
    let w = ROUND;
    if u >= w {
        (u, 1.0, 0.5 * u * u + w * w / 6.0)
    } else if u > -w {
        let v = u + w;
        (v * v / (4.0 * w), v / (2.0 * w), v * v * v / (12.0 * w))
    } else {
        (0.0, 0.0, 0.0)
    }
}

/// A penalty plane. `normal` must be a unit vector (use [`Plane::new`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// A point R of the plane (mm).
    pub point: V3,
    /// Unit normal n: the side the plane pushes towards.
    pub normal: V3,
    /// η₁ (MPa): the contact pressure at d = 0.
    pub eta1: f64,
    /// η₂ (mm): the force acts for d < η₂/2.
    pub eta2: f64,
}

impl Plane {
    /// Normalises `normal`; `None` when it is zero or not finite, or when
    /// η₁ < 0 or η₂ ≤ 0.
    pub fn new(point: V3, normal: V3, eta1: f64, eta2: f64) -> Option<Plane> {
        let l = normal.norm();
        if !(l > 0.0 && l.is_finite() && point.iter().all(|v| v.is_finite())) {
            return None;
        }
        if !(eta1 >= 0.0 && eta1.is_finite() && eta2 > 0.0 && eta2.is_finite()) {
            return None;
        }
        Some(Plane {
            point,
            normal: normal / l,
            eta1,
            eta2,
        })
    }

    /// The seed's two coaptation planes (symmetric one-leaflet model, in the
    /// seed's frame): R = 0, n = (±sin π/3, cos π/3, 0) for the left and
    /// right leaflet edge, η₁ = 1.1 · 90 mmHg, η₂ = 0.01 · `radius`.
    pub fn seed001_coaptation(radius: f64) -> [Plane; 2] {
        let (s, c) = (
            std::f64::consts::FRAC_PI_3.sin(),
            std::f64::consts::FRAC_PI_3.cos(),
        );
        let eta1 = 1.1 * 90.0 * MMHG_IN_MPA;
        let eta2 = 0.01 * radius;
        [
            Plane {
                point: V3::zeros(),
                normal: V3::new(s, c, 0.0),
                eta1,
                eta2,
            },
            Plane {
                point: V3::zeros(),
                normal: V3::new(-s, c, 0.0),
                eta1,
                eta2,
            },
        ]
    }

    /// Signed distance d = (x − R)·n (mm).
    pub fn distance(&self, x: &V3) -> f64 {
        (x - self.point).dot(&self.normal)
    }

    /// f(d) = max(1 − 2d/η₂, 0) with its kink rounded (module docs).
    pub fn factor(&self, x: &V3) -> f64 {
        ramp(1.0 - 2.0 * self.distance(x) / self.eta2).0
    }

    /// Whether the plane pushes on `x` (d < η₂/2).
    pub fn active(&self, x: &V3) -> bool {
        self.factor(x) > 0.0
    }

    /// The seed's force (N) on a node whose incident triangles have the
    /// current total area `area_sum` (mm²). Zero for non-finite input.
    pub fn seed_force(&self, x: &V3, area_sum: f64) -> V3 {
        let f = self.eta1 * area_sum / 3.0 * self.factor(x);
        if f.is_finite() {
            self.normal * f
        } else {
            V3::zeros()
        }
    }

    /// Energy (N·mm), gradient (N; force = −gradient) and optional Hessian
    /// (N/mm) with the area `area_sum` (mm²) held constant. Zeros for
    /// non-finite input.
    pub fn eval(&self, x: &V3, area_sum: f64, want_hess: bool) -> (f64, V3, Option<Matrix3<f64>>) {
        let c = self.eta1 * area_sum / 3.0;
        let (f, df, big_f) = ramp(1.0 - 2.0 * self.distance(x) / self.eta2);
        let e = c * self.eta2 / 2.0 * big_f;
        let h =
            want_hess.then(|| self.normal * self.normal.transpose() * (2.0 * c / self.eta2 * df));
        if !(e.is_finite() && (c * f).is_finite()) {
            return (0.0, V3::zeros(), want_hess.then(Matrix3::zeros));
        }
        (e, -self.normal * (c * f), h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use coapt_base::rng::SplitMix64;

    #[test]
    fn gradient_hessian_fd_and_seed_force() {
        let mut r = SplitMix64::new(4);
        let mut worst_g: f64 = 0.0;
        let mut worst_h: f64 = 0.0;
        let mut active = 0;
        for _ in 0..300 {
            let n = V3::new(r.normal(), r.normal(), r.normal());
            let p = Plane::new(
                V3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0)),
                n,
                r.range(0.005, 0.05),
                r.range(0.05, 0.3),
            )
            .unwrap();
            let x = p.point
                + p.normal * r.range(-0.3, 0.3)
                + V3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0))
                    .cross(&p.normal);
            let a = r.range(0.1, 2.0);
            let d = p.distance(&x);
            if (d - p.eta2 / 2.0).abs() < 1e-4 {
                continue;
            }
            let (_, g, h) = p.eval(&x, a, true);
            let h = h.unwrap();
            // −∇e is the seed's force.
            assert!((-g - p.seed_force(&x, a)).norm() <= 1e-15 * (1.0 + g.norm()));
            if p.active(&x) {
                active += 1;
            }
            let s = 1e-6;
            for k in 0..3 {
                let (mut xp, mut xm) = (x, x);
                xp[k] += s;
                xm[k] -= s;
                let fd = (p.eval(&xp, a, false).0 - p.eval(&xm, a, false).0) / (2.0 * s);
                worst_g = worst_g.max((fd - g[k]).abs() / (g.norm() + 1e-300).max(1e-12));
                let fdh = (p.eval(&xp, a, false).1 - p.eval(&xm, a, false).1) / (2.0 * s);
                let hn = h.norm().max(1e-12);
                worst_h = worst_h.max((fdh - h.column(k)).norm() / hn);
            }
        }
        eprintln!(
            "planes: FD gradient rel. error {worst_g:.2e}, Hessian {worst_h:.2e} ({active} active)"
        );
        assert!(active > 50);
        assert!(worst_g < 1e-6 && worst_h < 1e-6);
    }

    #[test]
    fn equilibrium_and_presets() {
        let [l, rgt] = Plane::seed001_coaptation(15.0);
        assert!((l.normal.norm() - 1.0).abs() < 1e-15 && (rgt.normal.norm() - 1.0).abs() < 1e-15);
        assert!((l.eta2 - 0.15).abs() < 1e-15);
        // Pressure P balances the plane at d* = (η₂/2)(1 − P/η₁).
        let pres = 90.0 * MMHG_IN_MPA;
        let d = l.eta2 / 2.0 * (1.0 - pres / l.eta1);
        let x = l.normal * d;
        let f = l.seed_force(&x, 3.0);
        assert!((f.norm() - pres * 3.0 / 3.0).abs() < 1e-12);
        assert!(Plane::new(V3::zeros(), V3::zeros(), 1.0, 1.0).is_none());
        assert_eq!(l.seed_force(&(l.normal * 0.1), 1.0), V3::zeros());
    }
}
