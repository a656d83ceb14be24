//! Mass–spring model as a per-triangle element (seeds 000/002/004;
//! docs/close.md, "The mass–spring model (MSM)").
//!
//! Each triangle T puts one spring on each of its three edges with the
//! Van Gelder (ν = 0) = Lloyd stiffness k = E H A_T / ℓ₀², so summing the two
//! triangles of an interior edge gives the seed's k_ij = E H Σ_s A_s / ℓ₀²
//! (A_T is the *rest* area, so k is a constant of the reference mesh).
//!
//! Non-linear law: E(ε) is a *tangent* modulus, i.e. a continuous
//! piecewise-linear engineering stress σ(ε), ε = ℓ/ℓ₀ − 1:
//!   σ = E₁ ε                               (ε ≤ ε₁, compression included)
//!   σ = E₁ ε₁ + E₂ (ε − ε₁)                (ε₁ < ε ≤ ε₂)
//!   σ = E₁ ε₁ + E₂ (ε₂ − ε₁) + E₃ (ε − ε₂)  (ε > ε₂)
//! Spring energy U = H A_T Φ(ε), Φ(ε) = ∫₀^ε σ, so the spring force is
//! dU/dℓ = H A_T σ(ε)/ℓ₀ (= k (ℓ − ℓ₀) for a constant E) and the stiffness
//! d²U/dℓ² = H A_T E_t(ε)/ℓ₀². (The brief's "H A_T ℓ₀ ∫σ" would give a
//! force ℓ₀² times too large; the energy above is the one whose gradient
//! is the seed's spring force.)
//! Spring Hessian block K = k_t e eᵀ + (f/ℓ)(I − e eᵀ), which for a
//! constant E is k[(1 − ℓ₀/ℓ)(I − e eᵀ) + e eᵀ]; the vertex blocks are
//! [[K, −K], [−K, K]]. E_t is discontinuous at the breakpoints (σ is
//! continuous, the Hessian jumps), exactly as in the seed.
//!
//! Anisotropy (seed 000): E(ε, α₀) = √(E_f² sin²α₀ + E_cf² cos²α₀). Since α₀
//! is fixed per edge, the exact-energy form used here is a per-edge
//! effective three-step law whose moduli are E_s(α₀) = √(E_f,s² w_f +
//! E_cf,s² w_c) for each step s, with the same breakpoints. Convention:
//! `fibre` moduli act along `RefTri::fiber[0]`: w_f = cos²φ, w_c = sin²φ,
//! φ = angle between the rest edge and fiber[0] (i.e. the seed's α₀ is
//! measured from the cross-fibre direction, α₀ = π/2 − φ). A triangle
//! without a fibre direction uses the isotropic mean law
//! √((E_f,s² + E_cf,s²)/2) (the φ-average of E_s²).
//!
//! Newton and this element (measured on the sample, suturing on, planes):
//! the closure converges at h 3 and 2 mm (32 and 43 iterations with the
//! solver of 2026-11-22; earlier 48 and 300), not at 1 or 0.5 mm in 300
//! iterations. Not because of the breakpoints —
//! the linear law fails the same way, and smoothing each jump of E_t over
//! ±0.25 % strain left the iteration counts unchanged (h 2 mm without
//! bending 147 → 148, h 1 mm 188 → 171) — but because three springs give
//! a triangle no resistance to collapsing: with hinge bending on, triangles
//! fold right over their neighbours (dihedral change up to 3.1 rad, where
//! the hinge energy wraps; neo-Hookean at the same small-strain modulus
//! stays below 1.7 rad and converges in 33 iterations). Without bending
//! (the seeds' MSM) h 2 and 1 mm converge in 147 and 188 iterations, h
//! 0.5 mm does not in 300. Clamping the compressed springs' transverse
//! term, |λ| instead of max(λ, 0) in the projection, a minimum area ratio
//! and a growing continuation shift did not fix it either.
//!
//! What the folds are (sample, h 1 mm, bending on, closure only): the
//! folded hinges are squashed triangles, not a sheet folding on itself —
//! at |Δθ| > 2.8 rad the lower of the two wing heights is a median 0.18
//! of the hinge edge (0.002 at worst; 0.87 for an equilateral wing), with
//! edges stretched up to 2.3 mm. Seed 000's springs let a triangle pass
//! through zero area for the few per cent of strain that takes (and a
//! compressed spring's transverse stiffness is negative), so collapse is a
//! cheap, even downhill, path; neo-Hookean's J → 0 barrier is not. The
//! first fold comes in continuation step 5 (shift 3.9e-3, full step,
//! residual 0.80 → 1.48 N, max |Δθ| 0.80 → 3.03 rad); with neo-Hookean the
//! same schedule's residual also rises (0.39 → 1.65 N) but |Δθ| stays
//! ≤ 1.19 rad and the closure converges in 12 + 3 iterations. Not fixed by
//! (each tried, measured, not kept): W = k (2 tan(Δθ/2))², which cannot
//! wrap (the fold is then stopped but the residual doubles per accepted
//! step, 0.9 → 920 N in 13 steps, 2.75 N after 300); capping each step's
//! first-order hinge turn at 0.5 rad (still folds, 0.91 N after 300);
//! holding the continuation shift while the residual rises (folds at
//! shift 0.25, 0.036 N after 300). The seeds' MSM has no area or angle
//! term, so none is added here.
//!
//! Which triangles collapse, and why (sample, h 1 mm, bending on, the
//! default sutured reference): every triangle that lost more than 70 % of
//! its area in the first failing steps had a rest angle of 112–157°. The
//! sutured leaflets, the stress-free state, are the flat template mesh
//! bent and stretched onto the root (edge strains −0.72 … +0.89 from the
//! template): 763 of 2418 triangles have an angle over 100° and 235 over
//! 120° (the template mesh itself: 9 and 0; h 0.5 mm: 2676 and 919 of
//! 9804). Three springs on an obtuse triangle are a shallow truss: moving
//! the obtuse vertex towards the long edge stretches the short springs
//! only by (h/ℓ)·δ, so that mode is ~(h/ℓ)² softer than shear and a few
//! per cent of compression turns it negative (test
//! `msm_obtuse_triangle_has_a_soft_flattening_mode`); a constant-strain
//! membrane pays for the area and is not affected — St.V-K at E 1 MPa
//! (ν 0, 0.3 or 0.45) converges there in 18–23 iterations with bending,
//! linear springs at E 1 MPa do not in 300 (19 N); a Green-strain spring
//! (ℓ² instead of ℓ) does not either (4.2 N). Seed 004 §2.3.1 names this
//! limit of Van Gelder's springs ("For an obtuse triangle the term
//! |a|²+|b|²−|c|² becomes negative … To avoid obtuse triangles in a mesh an
//! adaptive remeshing procedure … could be an option"; §2.4.2: "… if a mesh
//! procedure is used that does not allow obtuse triangles"), and seed 000
//! puts its springs on the advancing-front mesh of the flat template. With
//! that mesh as the stress-free state (`reference = "flat"`, an existing
//! option) the MSM converges with Newton at h 3 to 0.5 mm (grid, planes, bending,
//! one thread: h 3 / 2 / 1 / 0.5 mm in 17 / 16 / 15 / 19 iterations, 0.10
//! / 0.07 / 0.51 / 2.84 s; coaptation height 12.68 / 12.92 / 12.98 / 13.00
//! mm, central 5.78 / 6.93 / 8.66 / 8.83 mm), against 32 / 43 / 300 / 300
//! iterations (5.6e-2 and 1.87 N left at h 1 and 0.5) with the sutured
//! reference. With true contact (seed 000's law, h 0.5 mm) it does not
//! converge: the iterates cycle at about 4e-3 N over ~59 000 contact pairs;
//! linear springs (E 1 MPa, seed 000's closure benchmark) converge in 31
//! iterations, 4.2–4.4 s with suturing at `--threads 2`. That reference
//! keeps the placing and suturing distortion as stress, and for the other
//! models it changes the answer (same grid, h 0.5 mm, sutured → flat:
//! neo-Hookean μ 900 kPa coaptation height 7.56 → 8.11 mm, central 6.44 mm
//! → none, area 515 → 420 mm²; GOH 7.32 mm → a residual of 3.9e41 N, not an
//! equilibrium). It is the MSM's default all the same (`config`): it is
//! where seed 000 puts the springs, and the sutured mesh's obtuse triangles
//! leave three springs nothing to hold. The cure the seeds point to for a
//! sutured rest state is a rest mesh without obtuse triangles, i.e. a
//! placement closer to an isometry of the template. Flipping the sutured
//! mesh's spring network to Delaunay (springs across a hinge where the
//! opposite angles sum over π; 575 flips at h 1 mm, angles over 120°: 235
//! → 19) was tried and not kept: h 3 mm 23 iterations, h 2 mm 300
//! (6.0e-2 N, worse), h 1 mm a failed line search at 6.3e-3 N after 94,
//! h 0.5 mm 300 (0.97 N).
//!
//! With bending on, the flat template as reference now bends by the
//! quadratic stencil of `mech::flat_bending` rather than by hinges: a
//! triangle the springs let collapse made the hinges' 1/height forces
//! unbounded, and five plausible stress cases (MSM, bending, h 0.30–0.40
//! mm) stopped at a triangle collapsed to 0.2–3 % of its area; with the
//! stencil they converge.

use super::invariants::{COLLAPSE_RATIO, finite_eval};
use crate::element::{Eval, Grad9, Hess9, Membrane, RefTri, V3};
use nalgebra::Matrix3;

/// Stress–strain law of one spring (moduli in MPa, strains dimensionless).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Law {
    /// Constant Young's modulus.
    Linear { young: f64 },
    /// Three tangent moduli E₁, E₂, E₃ with breakpoints ε₁ < ε₂.
    ThreeStep { e: [f64; 3], eps: [f64; 2] },
    /// Three-step moduli along the fibre (`fibre`, along RefTri::fiber[0])
    /// and across it (`cross`), combined per edge (see the module doc).
    Anisotropic {
        fibre: [f64; 3],
        cross: [f64; 3],
        eps: [f64; 2],
    },
}

/// Seed 000 three-step breakpoints ε₁ = 0.175, ε₂ = 0.3.
pub const SEED000_EPS: [f64; 2] = [0.175, 0.3];

/// Seed 000 averaged isotropic pericardium: 106 / 569 / 1200 kPa.
pub fn seed000_isotropic() -> Law {
    Law::ThreeStep {
        e: [0.106, 0.569, 1.2],
        eps: SEED000_EPS,
    }
}

/// Seed 000 longitudinal direction, used isotropically: 137 / 568 / 968 kPa.
pub fn seed000_longitudinal() -> Law {
    Law::ThreeStep {
        e: [0.137, 0.568, 0.968],
        eps: SEED000_EPS,
    }
}

/// Seed 000 transverse direction, used isotropically: 63 / 570 / 1400 kPa.
pub fn seed000_transverse() -> Law {
    Law::ThreeStep {
        e: [0.063, 0.57, 1.4],
        eps: SEED000_EPS,
    }
}

/// Seed 000 anisotropic: longitudinal moduli along fiber[0], transverse
/// across it.
pub fn seed000_anisotropic() -> Law {
    Law::Anisotropic {
        fibre: [0.137, 0.568, 0.968],
        cross: [0.063, 0.57, 1.4],
        eps: SEED000_EPS,
    }
}

/// A resolved per-edge piecewise-linear law.
#[derive(Debug, Clone, Copy)]
pub struct Steps {
    pub e: [f64; 3],
    pub eps: [f64; 2],
}

impl Steps {
    /// (Φ(ε), σ(ε), E_t(ε)).
    pub fn eval(&self, x: f64) -> (f64, f64, f64) {
        let [e1, e2, e3] = self.e;
        let [x1, x2] = self.eps;
        if x <= x1 {
            return (0.5 * e1 * x * x, e1 * x, e1);
        }
        let s1 = e1 * x1;
        let p1 = 0.5 * e1 * x1 * x1;
        if x <= x2 {
            let t = x - x1;
            return (p1 + s1 * t + 0.5 * e2 * t * t, s1 + e2 * t, e2);
        }
        let d = x2 - x1;
        let s2 = s1 + e2 * d;
        let p2 = p1 + s1 * d + 0.5 * e2 * d * d;
        let t = x - x2;
        (p2 + s2 * t + 0.5 * e3 * t * t, s2 + e3 * t, e3)
    }
}

impl Law {
    /// The law of an edge whose rest direction makes cos²φ = `c2` with the
    /// first fibre direction (`None`: no fibre on this triangle).
    pub fn steps(&self, c2: Option<f64>) -> Steps {
        match *self {
            Law::Linear { young } => Steps {
                e: [young; 3],
                eps: [0.0, 0.0],
            },
            Law::ThreeStep { e, eps } => Steps { e, eps },
            Law::Anisotropic { fibre, cross, eps } => {
                let (wf, wc) = match c2 {
                    Some(c2) => (c2, 1.0 - c2),
                    None => (0.5, 0.5),
                };
                Steps {
                    e: [0, 1, 2]
                        .map(|s| (fibre[s] * fibre[s] * wf + cross[s] * cross[s] * wc).sqrt()),
                    eps,
                }
            }
        }
    }
}

/// Mass–spring membrane (three edge springs per triangle).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassSpring {
    pub law: Law,
}

impl Membrane for MassSpring {
    fn name(&self) -> &'static str {
        "msm"
    }

    fn eval(&self, r: &RefTri, q: &[V3; 3], want_hess: bool) -> Option<Eval> {
        let area = 0.5 * (q[1] - q[0]).cross(&(q[2] - q[0])).norm();
        if !area.is_finite() || area <= COLLAPSE_RATIO * r.area {
            return None;
        }
        let ha = r.thickness * r.area;
        let fib = r.fiber[0];
        let has_fibre = fib.norm_squared() > 0.0;
        let mut energy = 0.0;
        let mut grad = Grad9::zeros();
        let mut hess = want_hess.then(Hess9::zeros);
        for e in 0..3 {
            let (i, j) = ((e + 1) % 3, (e + 2) % 3);
            let l0 = r.rest_len2[e].sqrt();
            let c2 = has_fibre.then(|| {
                // Rest edge P_j − P_i = −2 A_P n_P × D_e.
                let t = r.normal.cross(&r.d[e]);
                let c = t.dot(&fib);
                (c * c / t.norm_squared()).min(1.0)
            });
            let law = self.law.steps(c2);
            let v = q[j] - q[i];
            let l = v.norm();
            let (phi, sigma, et) = law.eval(l / l0 - 1.0);
            energy += ha * phi;
            let f = ha * sigma / l0;
            let u = v / l;
            for c in 0..3 {
                grad[3 * j + c] += f * u[c];
                grad[3 * i + c] -= f * u[c];
            }
            if let Some(h) = hess.as_mut() {
                let kt = ha * et / (l0 * l0);
                let uu = u * u.transpose();
                let k = uu * kt + (Matrix3::identity() - uu) * (f / l);
                for a in 0..3 {
                    for b in 0..3 {
                        let x = k[(a, b)];
                        h[(3 * i + a, 3 * i + b)] += x;
                        h[(3 * j + a, 3 * j + b)] += x;
                        h[(3 * i + a, 3 * j + b)] -= x;
                        h[(3 * j + a, 3 * i + b)] -= x;
                    }
                }
            }
        }
        finite_eval(energy, &grad, hess.as_ref()).then_some(Eval { energy, grad, hess })
    }
}
