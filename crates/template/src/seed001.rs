//! Seed 001's five-parameter leaflet (§2.1, eq. 1–3).
//!
//! Local frame of one leaflet: the cylinder axis is z, the leaflet's middle
//! (x_b = 0) lies at angle 0, i.e. on +x. The template surface is the union
//! of segments r_c(t) + s·v, s ∈ [0, d(t)], with the constant direction
//! v = (sin ω, 0, cos ω). A surface swept by a constant direction is a
//! generalised cylinder and hence developable: cutting it with planes
//! ⟂ v gives congruent curves γ, so (σ, t̂) — σ the arc length of the
//! projection of r_c on the plane P ⟂ v, t̂ = (x − A)·v — are isometric
//! flat coordinates. That is the unfolded template Ω' of the seed; the
//! mesher works on it, and (σ, t̂) ↦ (t, t̂) ↦ x is exact.

use std::f64::consts::PI;

use super::outline::{Edge, Outline, P2, Piece, Shape};

#[derive(Debug, Clone, PartialEq)]
pub struct Seed001 {
    pub r: f64,
    pub phi: f64,
    pub hc: f64,
    pub hb: f64,
    pub omega: f64,
    /// Table t_i (uniform), σ(t_i), for inverting σ.
    sigma: Vec<f64>,
    /// Attachment length ∫|r_c'| at the same t_i.
    alen: Vec<f64>,
}

/// Table samples per unit of t.
const PER_T: usize = 2048;

impl Seed001 {
    pub fn new(r: f64, phi: f64, hc: f64, hb: f64, omega: f64) -> Result<Self, String> {
        if !(r > 0.0) {
            return Err(format!("radius R = {r} mm must be positive"));
        }
        if !(phi > 0.0 && phi < 2.0 * PI / 3.0 + 1e-12) {
            return Err(format!(
                "phi = {:.4} rad must lie in (0, 2π/3] (three leaflets share the circle)",
                phi
            ));
        }
        if !(hc > 0.0) {
            return Err(format!("commissure height H_c = {hc} mm must be positive"));
        }
        if !(hb > 0.0) {
            return Err(format!("belly depth H_b = {hb} mm must be positive"));
        }
        if !(omega.abs() < PI / 2.0 - 1e-3) {
            return Err(format!(
                "omega = {:.4} rad must lie in (−π/2, π/2) (cos ω divides eq. 3)",
                omega
            ));
        }
        let mut s = Seed001 {
            r,
            phi,
            hc,
            hb,
            omega,
            sigma: Vec::new(),
            alen: Vec::new(),
        };
        // σ(t) by Gauss–Legendre (5 points) per table interval: the
        // integrand is smooth within each piece and the pieces meet at
        // table nodes (t = 1, 3).
        let n = 4 * PER_T;
        let mut sig = Vec::with_capacity(n + 1);
        sig.push(0.0);
        let dt = 1.0 / PER_T as f64;
        for i in 0..n {
            let t0 = i as f64 * dt;
            let acc = gauss5(|t| s.sigma_rate(t), t0, t0 + dt);
            sig.push(sig[i] + acc);
        }
        s.sigma = sig;
        let mut al = Vec::with_capacity(n + 1);
        al.push(0.0);
        for i in 0..n {
            let t0 = i as f64 * dt;
            al.push(al[i] + gauss5(|t| s.speed(t), t0, t0 + dt));
        }
        s.alen = al;
        Ok(s)
    }

    /// l = Rφ.
    pub fn l(&self) -> f64 {
        self.r * self.phi
    }

    /// Eq. 1: the planar attachment line.
    pub fn rb(&self, t: f64) -> P2 {
        let l = self.l();
        if t <= 1.0 {
            [-l / 2.0, self.hc * (1.0 - t)]
        } else if t < 3.0 {
            let a = PI * (t - 2.0) / 2.0;
            [l / 2.0 * a.sin(), -self.hb * a.cos()]
        } else {
            [l / 2.0, self.hc * (t - 3.0)]
        }
    }

    fn rb_rate(&self, t: f64) -> P2 {
        let l = self.l();
        if t <= 1.0 {
            [0.0, -self.hc]
        } else if t < 3.0 {
            let a = PI * (t - 2.0) / 2.0;
            let k = PI / 2.0;
            [l / 2.0 * a.cos() * k, self.hb * a.sin() * k]
        } else {
            [0.0, self.hc]
        }
    }

    /// Eq. 2: the attachment line on the cylinder.
    pub fn rc(&self, t: f64) -> [f64; 3] {
        let [x, y] = self.rb(t);
        [self.r * (x / self.r).cos(), self.r * (x / self.r).sin(), y]
    }

    fn rc_rate(&self, t: f64) -> [f64; 3] {
        let [x, _] = self.rb(t);
        let [dx, dy] = self.rb_rate(t);
        let a = x / self.r;
        [-a.sin() * dx, a.cos() * dx, dy]
    }

    /// v = (sin ω, 0, cos ω).
    pub fn v(&self) -> [f64; 3] {
        [self.omega.sin(), 0.0, self.omega.cos()]
    }

    /// Eq. 3: extrusion length.
    pub fn d(&self, t: f64) -> f64 {
        let z = self.rc(t)[2];
        (self.hc - z) / self.omega.cos() * (0.8 + 0.15 * bump(t - 2.0, 1.0, 0.5))
    }

    /// t̂ of the attachment point r_c(t): (r_c(t) − A)·v.
    pub fn that_att(&self, t: f64) -> f64 {
        let a = self.rc(0.0);
        let p = self.rc(t);
        dot3(sub3(p, a), self.v())
    }

    /// |dγ/dt|: speed of the projection of r_c on the plane ⟂ v.
    fn sigma_rate(&self, t: f64) -> f64 {
        let d = self.rc_rate(t);
        let v = self.v();
        let k = dot3(d, v);
        let p = [d[0] - k * v[0], d[1] - k * v[1], d[2] - k * v[2]];
        dot3(p, p).sqrt()
    }

    /// σ(t), the unfolded abscissa (mm).
    pub fn sigma(&self, t: f64) -> f64 {
        let x = (t.clamp(0.0, 4.0) * PER_T as f64).min((4 * PER_T) as f64);
        let i = (x.floor() as usize).min(4 * PER_T - 1);
        let t0 = i as f64 / PER_T as f64;
        self.sigma[i] + gauss5(|u| self.sigma_rate(u), t0, t)
    }

    /// t from σ: bracket in the table, then Newton on the exact σ.
    pub fn t_of_sigma(&self, s: f64) -> f64 {
        let n = 4 * PER_T;
        let i = self.sigma.partition_point(|&x| x <= s).clamp(1, n);
        let (s0, s1) = (self.sigma[i - 1], self.sigma[i]);
        let (t0, t1) = ((i - 1) as f64 / PER_T as f64, i as f64 / PER_T as f64);
        let mut t = if s1 > s0 {
            t0 + (s - s0) / (s1 - s0) * (t1 - t0)
        } else {
            t0
        };
        for _ in 0..4 {
            let rate = self.sigma_rate(t);
            if !(rate > 1e-12) {
                break;
            }
            t = (t - (self.sigma(t) - s) / rate).clamp(t0, t1);
        }
        t
    }

    /// Unfolded coordinates of the attachment point and the free-edge point at t.
    pub fn unfolded_att(&self, t: f64) -> P2 {
        [self.sigma(t), self.that_att(t)]
    }

    pub fn unfolded_free(&self, t: f64) -> P2 {
        [self.sigma(t), self.that_att(t) + self.d(t)]
    }

    /// Point of Ω_template (local frame) from unfolded coordinates (σ, t̂).
    pub fn to_3d(&self, p: P2) -> [f64; 3] {
        let t = self.t_of_sigma(p[0]);
        let s = p[1] - self.that_att(t);
        let c = self.rc(t);
        let v = self.v();
        [c[0] + s * v[0], c[1] + s * v[1], c[2] + s * v[2]]
    }

    /// Area of Ω_template = ∫ d(t) σ'(t) dt (developable: flat = 3-D).
    pub fn analytic_area(&self) -> f64 {
        let n = 4 * PER_T;
        (0..n)
            .map(|i| {
                let t0 = i as f64 / PER_T as f64;
                gauss5(
                    |t| self.d(t) * self.sigma_rate(t),
                    t0,
                    t0 + 1.0 / PER_T as f64,
                )
            })
            .sum()
    }

    /// Attachment length from t = 0 to t (table plus one Gauss panel).
    pub fn attachment_length_to(&self, t: f64) -> f64 {
        let t = t.clamp(0.0, 4.0);
        let i = ((t * PER_T as f64).floor() as usize).min(4 * PER_T - 1);
        let t0 = i as f64 / PER_T as f64;
        self.alen[i] + gauss5(|u| self.speed(u), t0, t)
    }

    fn speed(&self, t: f64) -> f64 {
        let d = self.rc_rate(t);
        dot3(d, d).sqrt()
    }

    /// Length of the attachment line, ∫|r_c'| dt (equal to the length of
    /// the planar eq. 1 curve: the cylinder map is an isometry).
    pub fn attachment_length(&self) -> f64 {
        self.alen[4 * PER_T]
    }

    /// Flat outline: attachment A→B, B→D, D→E (sutured), free edge E→A.
    pub fn outline(&self) -> Outline {
        let samples = |a: f64, b: f64, f: &dyn Fn(f64) -> P2| -> Vec<P2> {
            let n = ((b - a) * PER_T as f64).round() as usize;
            (0..=n)
                .map(|i| f(a + (b - a) * i as f64 / n as f64))
                .collect()
        };
        let att = |t| self.unfolded_att(t);
        let pieces = vec![
            Piece {
                shape: Shape::sampled(samples(0.0, 1.0, &att)),
                edge: Edge::Sutured,
            },
            Piece {
                shape: Shape::sampled(samples(1.0, 3.0, &att)),
                edge: Edge::Sutured,
            },
            Piece {
                shape: Shape::sampled(samples(3.0, 4.0, &att)),
                edge: Edge::Sutured,
            },
            Piece {
                shape: Shape::sampled(
                    samples(0.0, 4.0, &|t| self.unfolded_free(t))
                        .into_iter()
                        .rev()
                        .collect(),
                ),
                edge: Edge::Free,
            },
        ];
        Outline::new(pieces).expect("seed 001 outline closes")
    }
}

/// b(t, t_m, w) of eq. 3.
pub fn bump(t: f64, tm: f64, w: f64) -> f64 {
    let e = (-(tm / w).powi(2)).exp();
    ((-(t / w).powi(2)).exp() - e) / (1.0 - e)
}

fn gauss5(f: impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    const X: [f64; 5] = [
        0.0,
        -0.538_469_310_105_683,
        0.538_469_310_105_683,
        -0.906_179_845_938_664,
        0.906_179_845_938_664,
    ];
    const W: [f64; 5] = [
        0.568_888_888_888_889,
        0.478_628_670_499_366,
        0.478_628_670_499_366,
        0.236_926_885_056_189,
        0.236_926_885_056_189,
    ];
    let (m, h) = ((a + b) / 2.0, (b - a) / 2.0);
    h * X.iter().zip(W).map(|(x, w)| w * f(m + h * x)).sum::<f64>()
}

pub fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    pub fn paper() -> Seed001 {
        Seed001::new(15.0, 2.0 * PI / 3.0 - 0.4, 1.5, 15.0, -2.0 * PI / 9.0).unwrap()
    }

    #[test]
    fn unfolding_is_consistent() {
        let s = paper();
        for k in 0..=40 {
            let t = k as f64 * 0.1;
            // σ inverts, the attachment maps back onto eq. 2, and d(0) = d(4) = 0.
            assert!((s.t_of_sigma(s.sigma(t)) - t).abs() < 1e-10, "t = {t}");
            let p = s.to_3d(s.unfolded_att(t));
            let q = s.rc(t);
            assert!(sub3(p, q).iter().all(|c| c.abs() < 1e-9), "t = {t}");
        }
        assert!(s.d(0.0).abs() < 1e-12 && s.d(4.0).abs() < 1e-12);
        // The flat outline's exact polyline area matches ∫ d σ' dt.
        let o = s.outline();
        assert!((o.area() - s.analytic_area()).abs() < 1e-4 * s.analytic_area());
        assert!((o.length(Edge::Sutured) - s.attachment_length()).abs() < 1e-6);
    }
}
