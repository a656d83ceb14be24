//! Bending of a leaflet whose stress-free state is flat (the cut
//! pericardium: `reference = "flat"`, the MSM's default), as the quadratic
//! energy of Bergou, Wardetzky, Harmon, Zorin and Grinspun, "A quadratic
//! bending model for inextensible surfaces" (SGP 2006):
//!
//! ```text
//! W = Σ_e q_e |Σ_i K_e,i x_i|²,   q_e = (D/2) / (Ā₁ + Ā₂),   D = E' t³/12
//! ```
//!
//! over the interior edges e with their four nodes (a, b; wings c, d).
//! K_e are the cotangent weights of the flat hinge: with α, β the angles at
//! a and b in wing c and γ, δ those in wing d,
//! K = (cot β + cot δ, cot α + cot γ, −cot α − cot β, −cot γ − cot δ).
//! They sum to zero and Σ K_i x̄_i = 0 on the flat hinge (so translations,
//! rotations and uniform in-plane stretches cost nothing), and folding wing
//! d by θ about the edge moves Σ K_i x_i by |ē| θ: for small folds W is the
//! hinge energy k_e θ² of [`super::bending`] with the same k_e (tested),
//! and a strip rolled onto a cylinder stores D/2 ∫κ² dA as the hinges do.
//!
//! Why a second bending term: the hinge angle's gradient is 1/(wing
//! height), so a triangle squashed towards a line drives the hinge forces
//! without bound. The MSM's three springs let a triangle collapse (seed 004
//! §2.3.1), and on `bench stress-close --plausible` five of the six MSM
//! cases with bending at h < 0.45 mm stopped with a triangle collapsed to
//! 0.2–3 % of its area and residuals of 0.2–970 N (docs/close.md, "A flat
//! rest state"). Here the Hessian is the constant 2 q_e K Kᵀ ⊗ I₃
//! (positive semi-definite) and the force is linear in the positions:
//! nothing degenerates, whatever a triangle does.
//!
//! What it charges beyond the hinges: Σ K_i x_i also has an in-plane part
//! where the sheet is distorted non-uniformly within its plane, a strain
//! gradient costing about D |∇F|², i.e. (t/ℓ)²/12 of the membrane energy
//! for a strain that varies over a length ℓ. That is negligible for
//! anything wider than the thickness (the sample's MSM closure, h 1 and
//! 0.5 mm: coaptation heights within 0.02 mm of the hinges', areas within
//! 1.1 mm²) and is what keeps triangles narrower than the thickness from
//! collapsing.

use super::bending::Hinge;
use super::element::V3;
use super::sparse::{Dofs, Pattern};
use super::system::Term;
use nalgebra::SMatrix;

/// One interior edge of the flat reference: nodes (a, b, c, d) and the
/// weighted cotangent stencil.
#[derive(Debug, Clone, Copy)]
pub struct Stencil {
    pub nodes: [u32; 4],
    /// The cotangent weights K of (a, b, c, d).
    pub k: [f64; 4],
    /// q_e = (D/2) / (Ā₁ + Ā₂) (N·mm per mm²).
    pub q: f64,
}

fn cot(u: V3, v: V3) -> Option<f64> {
    let s = u.cross(&v).norm();
    (s > 0.0).then(|| u.dot(&v) / s)
}

impl Stencil {
    /// From the reference positions of (a, b, c, d); `None` for a
    /// degenerate wing.
    pub fn new(nodes: [u32; 4], p: &[V3; 4], d: f64) -> Option<Stencil> {
        let [a, b, c, w] = *p;
        let e = b - a;
        // Angles at a and b in each wing.
        let ca = cot(e, c - a)?;
        let cb = cot(-e, c - b)?;
        let da = cot(e, w - a)?;
        let db = cot(-e, w - b)?;
        let area = 0.5 * (e.cross(&(c - a)).norm() + e.cross(&(w - a)).norm());
        if !(area > 0.0) {
            return None;
        }
        Some(Stencil {
            nodes,
            k: [cb + db, ca + da, -ca - cb, -da - db],
            q: 0.5 * d / area,
        })
    }

    fn vector(&self, x: &[V3]) -> V3 {
        self.nodes
            .iter()
            .zip(self.k)
            .fold(V3::zeros(), |s, (&n, k)| s + x[n as usize] * k)
    }
}

/// Largest rest angle (rad) a hinge of a "flat" reference may have.
const FLAT: f64 = 1e-6;

pub struct FlatBending {
    pub stencils: Vec<Stencil>,
}

impl FlatBending {
    /// The stencils of the reference mesh `x_ref` (edges shared by other
    /// than two consistently oriented triangles are left out, as in
    /// [`super::bending::hinges`]); `None` unless every hinge is flat there.
    pub fn new(x_ref: &[V3], tris: &[[u32; 3]], d: f64) -> Option<FlatBending> {
        FlatBending::from_hinges(&super::bending::hinges(x_ref, tris, d), x_ref, d)
    }

    /// From hinges already found on `x_ref` (bending stiffness `d`).
    pub fn from_hinges(hinges: &[Hinge], x_ref: &[V3], d: f64) -> Option<FlatBending> {
        if hinges.iter().any(|h| h.rest.abs() > FLAT) {
            return None;
        }
        let stencils = hinges
            .iter()
            .filter_map(|h| Stencil::new(h.nodes, &h.nodes.map(|i| x_ref[i as usize]), d))
            .collect();
        Some(FlatBending { stencils })
    }
}

impl Term for FlatBending {
    fn name(&self) -> &'static str {
        "bending"
    }

    fn energy(&self, x: &[V3]) -> Option<f64> {
        Some(
            self.stencils
                .iter()
                .map(|s| s.q * s.vector(x).norm_squared())
                .sum(),
        )
    }

    fn add_force(&self, x: &[V3], f: &mut [V3]) {
        for s in &self.stencils {
            let v = s.vector(x) * (2.0 * s.q);
            for (&n, k) in s.nodes.iter().zip(s.k) {
                f[n as usize] -= v * k;
            }
        }
    }

    fn couplings(&self, out: &mut Vec<[u32; 2]>) {
        for s in &self.stencils {
            super::bending::couple(s.nodes, out);
        }
    }

    fn add_tangent(&self, _x: &[V3], dofs: &Dofs, pat: &Pattern, vals: &mut [f64]) {
        let nodes: Vec<[u32; 4]> = self.stencils.iter().map(|s| s.nodes).collect();
        let slots = pat.element_slots(dofs, &nodes);
        for (s, sl) in self.stencils.iter().zip(slots.chunks_exact(144)) {
            let mut h = SMatrix::<f64, 12, 12>::zeros();
            for i in 0..4 {
                for j in 0..4 {
                    let v = 2.0 * s.q * s.k[i] * s.k[j];
                    for c in 0..3 {
                        h[(3 * i + c, 3 * j + c)] = v;
                    }
                }
            }
            Pattern::add_block_at(vals, sl, &h);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::bending::{Bending, Hinge, jiggled_grid};
    use super::*;
    use coapt_base::rng::SplitMix64;
    use nalgebra::Rotation3;

    fn flat(uv: &[(f64, f64)]) -> Vec<V3> {
        uv.iter().map(|&(u, v)| V3::new(u, v, 0.0)).collect()
    }

    /// A strip rolled onto a cylinder of radius ρ.
    fn rolled(uv: &[(f64, f64)], rho: f64) -> Vec<V3> {
        uv.iter()
            .map(|&(u, v)| V3::new(rho * (u / rho).sin(), v, rho * (1.0 - (u / rho).cos())))
            .collect()
    }

    #[test]
    fn a_small_fold_costs_what_the_hinge_costs() {
        let mut r = SplitMix64::new(3);
        let mut n = 0;
        while n < 100 {
            let mut p = || V3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), 0.0);
            let (a, b, c, d) = (p(), p(), p(), p());
            let e = (b - a).normalize();
            // c and d on opposite sides of the edge, neither nearly on it.
            let side = |q: V3| e.cross(&(q - a)).z;
            if side(c) < 0.2 || side(d) > -0.2 {
                continue;
            }
            n += 1;
            let rest = [a, b, c, d];
            let s = Stencil::new([0, 1, 2, 3], &rest, 0.7).unwrap();
            assert!(
                s.vector(&rest).norm() < 1e-12,
                "linear precision on the flat hinge"
            );
            let h = Hinge {
                nodes: [0, 1, 2, 3],
                k: s.q * (b - a).norm_squared(),
                rest: 0.0,
                near: 0.0,
            };
            for th in [1e-4, 1e-2] {
                // Fold wing d about the edge.
                let rot = Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(b - a), th);
                let folded = [a, b, c, a + rot * (d - a)];
                let w = s.q * s.vector(&folded).norm_squared();
                let wh = h.eval(&folded, false, false).unwrap().energy;
                assert!(
                    (w / wh - 1.0).abs() < 2.0 * th,
                    "θ {th}: {w} against the hinge's {wh}"
                );
            }
        }
    }

    /// Rolled onto a cylinder, the strip stores D/2 · A/ρ², as the hinges do.
    #[test]
    fn a_rolled_strip_stores_the_plate_energy() {
        let (w, len, rho, d) = (4.0, 3.0, 5.0, 0.7);
        let exact = 0.5 * d * w * len / (rho * rho);
        let mut r = SplitMix64::new(5);
        for n in [8usize, 16, 32] {
            let (uv, tris) = jiggled_grid(w, len, n, &mut r);
            let x = rolled(&uv, rho);
            let q = FlatBending::new(&flat(&uv), &tris, d)
                .unwrap()
                .energy(&x)
                .unwrap();
            let h = Bending::new(&flat(&uv), &tris, d).energy(&x).unwrap();
            assert!((q / exact - 1.0).abs() < 0.2, "n {n}: {q} against {exact}");
            assert!(
                (q / h - 1.0).abs() < 0.01,
                "n {n}: {q} against the hinges' {h}"
            );
        }
    }

    #[test]
    fn flat_sheets_and_rigid_motions_cost_nothing() {
        let (uv, tris) = jiggled_grid(4.0, 3.0, 8, &mut SplitMix64::new(1));
        let b = FlatBending::new(&flat(&uv), &tris, 0.7).unwrap();
        assert!(
            FlatBending::new(&rolled(&uv, 5.0), &tris, 0.7).is_none(),
            "a curved reference needs the hinges' rest angles"
        );
        // A flat sheet stretched and sheared uniformly in its plane: no bending.
        let sheared: Vec<V3> = uv
            .iter()
            .map(|&(u, v)| V3::new(1.3 * u + 0.4 * v, 0.8 * v, 0.0))
            .collect();
        assert!(b.energy(&sheared).unwrap() < 1e-20);
        let x = rolled(&uv, 5.0);
        let rot = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
        let moved: Vec<V3> = x
            .iter()
            .map(|p| rot * p + V3::new(1.0, -2.0, 3.0))
            .collect();
        let (e0, e1) = (b.energy(&x).unwrap(), b.energy(&moved).unwrap());
        assert!((e0 - e1).abs() < 1e-12 * e0, "{e0} {e1}");
    }

    fn forces(b: &FlatBending, x: &[V3]) -> Vec<V3> {
        let mut f = vec![V3::zeros(); x.len()];
        b.add_force(x, &mut f);
        f
    }

    #[test]
    fn forces_are_the_negative_gradient_and_the_tangent_their_derivative() {
        let mut r = SplitMix64::new(8);
        let (uv, tris) = jiggled_grid(2.0, 2.0, 4, &mut r);
        let b = FlatBending::new(&flat(&uv), &tris, 0.7).unwrap();
        let x: Vec<V3> = rolled(&uv, 3.0)
            .iter()
            .map(|p| p + V3::new(r.range(-0.1, 0.1), r.range(-0.1, 0.1), r.range(-0.1, 0.1)))
            .collect();
        let n = x.len();
        let k = crate::system::dense_tangent(&b, &x);
        let f = forces(&b, &x);
        let s = 1e-6;
        let (mut worst_f, mut worst_k) = (0.0f64, 0.0f64);
        for j in 0..3 * n {
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[j / 3][j % 3] += s;
            xm[j / 3][j % 3] -= s;
            let fd = (b.energy(&xp).unwrap() - b.energy(&xm).unwrap()) / (2.0 * s);
            worst_f = worst_f.max((fd + f[j / 3][j % 3]).abs());
            let (fp, fm) = (forces(&b, &xp), forces(&b, &xm));
            for i in 0..3 * n {
                let dk = -(fp[i / 3][i % 3] - fm[i / 3][i % 3]) / (2.0 * s);
                worst_k = worst_k.max((dk - k[(i, j)]).abs());
            }
        }
        let fscale = f.iter().map(|v| v.norm()).fold(0.0, f64::max);
        assert!(
            worst_f < 1e-6 * fscale,
            "force vs −∇W: {worst_f} (scale {fscale})"
        );
        assert!(worst_k < 1e-6 * k.amax(), "tangent vs ∂(−f): {worst_k}");
        // Positive semi-definite.
        let eig = nalgebra::SymmetricEigen::new(k.clone());
        assert!(eig.eigenvalues.iter().all(|&l| l > -1e-9 * k.amax()));
    }

    /// What the term is for: squashing a triangle towards a line drives the
    /// hinge forces up as 1/height (the hinge angle is undefined at the
    /// end), while this term's forces stay bounded.
    #[test]
    fn a_collapsing_triangle_keeps_the_forces_bounded() {
        let (uv, tris) = jiggled_grid(2.0, 2.0, 4, &mut SplitMix64::new(2));
        let b = FlatBending::new(&flat(&uv), &tris, 0.7).unwrap();
        let h = Bending::new(&flat(&uv), &tris, 0.7);
        let x0 = rolled(&uv, 3.0);
        // Move a vertex of an interior triangle towards the middle of the
        // opposite edge.
        let t = tris[tris.len() / 2];
        let (a, p, q) = (t[0] as usize, x0[t[1] as usize], x0[t[2] as usize]);
        let foot = p + (q - p) * 0.5;
        let largest = |term: &dyn Term, s: f64| {
            let mut x = x0.clone();
            x[a] = x0[a] + (foot - x0[a]) * s;
            let mut f = vec![V3::zeros(); x.len()];
            term.add_force(&x, &mut f);
            f.iter().map(|v| v.norm()).fold(0.0, f64::max)
        };
        let (q1, q2) = (largest(&b, 0.9), largest(&b, 0.999));
        let (h1, h2) = (largest(&h, 0.9), largest(&h, 0.999));
        eprintln!("largest force, flat bending {q1} → {q2}, hinges {h1} → {h2}");
        assert!(q2.is_finite() && q2 < 1.5 * q1, "flat bending {q1} → {q2}");
        assert!(h2 > 10.0 * h1, "hinges {h1} → {h2}");
    }
}
