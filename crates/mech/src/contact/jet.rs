//! Second-order forward differentiation in the 12 coordinates of a
//! node–triangle pair: a value with its exact gradient and Hessian.
//!
//! The point–triangle distance has three closed forms (face, edge, vertex
//! region) whose Hessians by hand are long and easy to get wrong; written
//! once over [`Num`] they give the energy in `f64` and the exact
//! derivatives through [`Jet`], which the finite-difference tests then check.

use std::ops::{Add, Mul, Sub};

pub const N: usize = 12;

/// What the distance formulas need of a number.
pub trait Num: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> {
    fn cst(v: f64) -> Self;
    fn value(&self) -> f64;
    /// self / d for a d known to be nonzero.
    fn div(self, d: Self) -> Self;
}

impl Num for f64 {
    fn cst(v: f64) -> f64 {
        v
    }
    fn value(&self) -> f64 {
        *self
    }
    fn div(self, d: f64) -> f64 {
        self / d
    }
}

/// v with ∂v (gradient) and ∂²v (Hessian, symmetric) in 12 variables.
#[derive(Clone, Copy, Debug)]
pub struct Jet {
    pub v: f64,
    pub g: [f64; N],
    pub h: [[f64; N]; N],
}

impl Jet {
    /// Variable number `k` with value `v`.
    pub fn var(v: f64, k: usize) -> Jet {
        let mut j = Jet::cst(v);
        j.g[k] = 1.0;
        j
    }
}

impl Num for Jet {
    fn cst(v: f64) -> Jet {
        Jet {
            v,
            g: [0.0; N],
            h: [[0.0; N]; N],
        }
    }
    fn value(&self) -> f64 {
        self.v
    }
    fn div(self, d: Jet) -> Jet {
        // 1/d: gradient −∂d/d², Hessian 2 ∂d ∂dᵀ/d³ − ∂²d/d².
        let (d1, d2, d3) = (d.v, d.v * d.v, d.v * d.v * d.v);
        let mut r = Jet::cst(1.0 / d1);
        for i in 0..N {
            r.g[i] = -d.g[i] / d2;
            for j in 0..N {
                r.h[i][j] = 2.0 * d.g[i] * d.g[j] / d3 - d.h[i][j] / d2;
            }
        }
        self * r
    }
}

impl Add for Jet {
    type Output = Jet;
    fn add(mut self, o: Jet) -> Jet {
        self.v += o.v;
        for i in 0..N {
            self.g[i] += o.g[i];
            for j in 0..N {
                self.h[i][j] += o.h[i][j];
            }
        }
        self
    }
}

impl Sub for Jet {
    type Output = Jet;
    fn sub(mut self, o: Jet) -> Jet {
        self.v -= o.v;
        for i in 0..N {
            self.g[i] -= o.g[i];
            for j in 0..N {
                self.h[i][j] -= o.h[i][j];
            }
        }
        self
    }
}

impl Mul for Jet {
    type Output = Jet;
    fn mul(self, o: Jet) -> Jet {
        let mut r = Jet::cst(self.v * o.v);
        for i in 0..N {
            r.g[i] = self.v * o.g[i] + o.v * self.g[i];
            for j in 0..N {
                r.h[i][j] = self.v * o.h[i][j]
                    + o.v * self.h[i][j]
                    + self.g[i] * o.g[j]
                    + o.g[i] * self.g[j];
            }
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn products_and_quotients_match_closed_forms() {
        // f = x0·x1 / (x2·x2 + 1) at (2, 3, 0.5): known gradient and Hessian.
        let (a, b, c) = (2.0, 3.0, 0.5);
        let (x0, x1, x2) = (Jet::var(a, 0), Jet::var(b, 1), Jet::var(c, 2));
        let f = (x0 * x1).div(x2 * x2 + Jet::cst(1.0));
        let q = c * c + 1.0;
        assert!((f.v - a * b / q).abs() < 1e-15);
        assert!((f.g[0] - b / q).abs() < 1e-15);
        assert!((f.g[2] + a * b * 2.0 * c / (q * q)).abs() < 1e-14);
        assert!((f.h[0][1] - 1.0 / q).abs() < 1e-15 && (f.h[1][0] - 1.0 / q).abs() < 1e-15);
        assert!((f.h[0][2] + b * 2.0 * c / (q * q)).abs() < 1e-14);
        // ∂²/∂c² of ab/(c²+1) = ab (6c² − 2)/(c²+1)³.
        assert!((f.h[2][2] - a * b * (6.0 * c * c - 2.0) / (q * q * q)).abs() < 1e-13);
        assert_eq!(f.h[0][0], 0.0);
    }
}
