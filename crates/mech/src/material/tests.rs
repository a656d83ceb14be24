//! Finite-difference, invariance and analytic patch tests for every
//! membrane material. Run with `--nocapture` to see the measured errors.

#![allow(clippy::needless_range_loop)]

use super::invariants::Kin;
use super::*;
use crate::element::{Eval, Grad9, Hess9, Membrane, RefTri, V3};
use coapt_base::rng::SplitMix64;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

const H: f64 = 0.4;

fn rand_unit(rng: &mut SplitMix64) -> V3 {
    loop {
        let v = V3::new(rng.normal(), rng.normal(), rng.normal());
        let n = v.norm();
        if n > 1e-3 {
            return v / n;
        }
    }
}

fn rand_rotation(rng: &mut SplitMix64) -> Matrix3<f64> {
    let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
        rng.normal(),
        rng.normal(),
        rng.normal(),
        rng.normal(),
    ));
    *q.to_rotation_matrix().matrix()
}

/// A random, reasonably shaped 3-D reference triangle (all angles ≥ 20°).
fn rand_tri(rng: &mut SplitMix64) -> ([V3; 3], f64) {
    loop {
        let scale = rng.range(0.5, 3.0);
        let c = V3::new(
            rng.range(-10.0, 10.0),
            rng.range(-10.0, 10.0),
            rng.range(-10.0, 10.0),
        );
        let p = [0, 1, 2].map(|_| c + V3::new(rng.normal(), rng.normal(), rng.normal()) * scale);
        let ok = (0..3).all(|k| {
            let a = p[(k + 1) % 3] - p[k];
            let b = p[(k + 2) % 3] - p[k];
            a.angle(&b) > 20f64.to_radians()
        });
        if ok {
            return (p, scale);
        }
    }
}

/// Fibres at ±θ from a random in-plane direction e_x (unit, tangent).
fn fibres(p: &[V3; 3], theta: f64, rng: &mut SplitMix64) -> [V3; 2] {
    let n = (p[1] - p[0]).cross(&(p[2] - p[0])).normalize();
    let ex = n.cross(&rand_unit(rng)).normalize();
    let ey = n.cross(&ex);
    [
        ex * theta.cos() + ey * theta.sin(),
        ex * theta.cos() - ey * theta.sin(),
    ]
}

/// Current positions: in-plane principal stretches in [lo, hi] along a
/// random in-plane frame, a random rotation and translation, plus a small
/// per-node perturbation (so the map is a general one, out of plane too).
fn rand_state(
    r: &RefTri,
    p: &[V3; 3],
    lo: f64,
    hi: f64,
    noise: f64,
    rng: &mut SplitMix64,
) -> [V3; 3] {
    let n = r.normal;
    let a = n.cross(&rand_unit(rng)).normalize();
    let b = n.cross(&a);
    let (l1, l2) = (rng.range(lo, hi), rng.range(lo, hi));
    let u = a * a.transpose() * l1 + b * b.transpose() * l2 + n * n.transpose();
    let rot = rand_rotation(rng);
    let t = V3::new(rng.normal(), rng.normal(), rng.normal()) * 5.0;
    let c = (p[0] + p[1] + p[2]) / 3.0;
    let scale = (r.area).sqrt();
    p.map(|x| {
        rot * u * (x - c)
            + c
            + t
            + V3::new(rng.normal(), rng.normal(), rng.normal()) * (noise * scale)
    })
}

fn perturb(q: &[V3; 3], c: usize, h: f64) -> [V3; 3] {
    let mut out = *q;
    out[c / 3][c % 3] += h;
    out
}

#[derive(Debug, Default, Clone, Copy)]
struct Errs {
    grad: f64,
    hess: f64,
    sum: f64,
    torque: f64,
    sym: f64,
    n: usize,
}

impl Errs {
    fn max(&mut self, o: Errs) {
        self.grad = self.grad.max(o.grad);
        self.hess = self.hess.max(o.hess);
        self.sum = self.sum.max(o.sum);
        self.torque = self.torque.max(o.torque);
        self.sym = self.sym.max(o.sym);
        self.n += o.n;
    }
}

/// Central-difference check of one state: relative errors measured against
/// the max-norm of the analytic gradient / Hessian.
fn fd_check(m: &dyn Membrane, r: &RefTri, q: &[V3; 3], scale: f64) -> Option<Errs> {
    let e = m.eval(r, q, true)?;
    let hmat = e.hess.unwrap();
    let h = 1e-6 * scale;
    let mut g_fd = Grad9::zeros();
    let mut h_fd = Hess9::zeros();
    for c in 0..9 {
        let ep = m.eval(r, &perturb(q, c, h), true)?;
        let em = m.eval(r, &perturb(q, c, -h), true)?;
        g_fd[c] = (ep.energy - em.energy) / (2.0 * h);
        let col = (ep.grad - em.grad) / (2.0 * h);
        h_fd.set_column(c, &col);
    }
    let gn = e.grad.amax().max(1e-300);
    let hn = hmat.amax().max(1e-300);
    let fsum = V3::new(
        e.grad[0] + e.grad[3] + e.grad[6],
        e.grad[1] + e.grad[4] + e.grad[7],
        e.grad[2] + e.grad[5] + e.grad[8],
    );
    let mut torque = V3::zeros();
    for i in 0..3 {
        torque += q[i].cross(&V3::new(
            e.grad[3 * i],
            e.grad[3 * i + 1],
            e.grad[3 * i + 2],
        ));
    }
    let qn = q.iter().map(|x| x.norm()).fold(0.0, f64::max);
    Some(Errs {
        grad: (e.grad - g_fd).amax() / gn,
        hess: (hmat - h_fd).amax() / hn,
        sum: fsum.amax() / gn,
        torque: torque.amax() / (gn * qn),
        sym: (hmat - hmat.transpose()).amax() / hn,
        n: 1,
    })
}

/// Rigid motions of the reference: zero energy and gradient.
fn rigid_check(m: &dyn Membrane, r: &RefTri, p: &[V3; 3], energy_scale: f64, rng: &mut SplitMix64) {
    let rot = rand_rotation(rng);
    let t = V3::new(rng.normal(), rng.normal(), rng.normal()) * 10.0;
    let q = p.map(|x| rot * x + t);
    let e = m.eval(r, &q, true).expect("rigid state admissible");
    let gscale = energy_scale / r.area.sqrt();
    assert!(
        e.energy.abs() <= 1e-10 * energy_scale,
        "{}: rigid energy {}",
        m.name(),
        e.energy
    );
    assert!(
        e.grad.amax() <= 1e-10 * gscale,
        "{}: rigid grad {}",
        m.name(),
        e.grad.amax()
    );
}

/// The common harness: `n` random states with stretches in [lo, hi].
#[allow(clippy::too_many_arguments)]
fn run_material(
    label: &str,
    m: &dyn Membrane,
    modulus: f64,
    theta: Option<f64>,
    lo: f64,
    hi: f64,
    noise: f64,
    n: usize,
    seed: u64,
) -> Errs {
    let mut rng = SplitMix64::new(seed);
    let mut worst = Errs::default();
    let mut tries = 0;
    while worst.n < n {
        tries += 1;
        assert!(tries < 20 * n, "{label}: too many inadmissible states");
        let (p, scale) = rand_tri(&mut rng);
        let fib = theta.map(|t| fibres(&p, t, &mut rng));
        let r = RefTri::new(p, H, fib).unwrap();
        rigid_check(m, &r, &p, modulus * r.area * H, &mut rng);
        let q = rand_state(&r, &p, lo, hi, noise, &mut rng);
        if let Some(e) = fd_check(m, &r, &q, scale) {
            worst.max(e);
        }
    }
    eprintln!(
        "{label}: {} states; max rel err grad {:.2e} hess {:.2e}; Σf {:.2e} torque {:.2e} asym {:.2e}",
        worst.n, worst.grad, worst.hess, worst.sum, worst.torque, worst.sym
    );
    assert!(
        worst.grad <= 1e-6,
        "{label}: gradient FD error {}",
        worst.grad
    );
    assert!(
        worst.hess <= 1e-6,
        "{label}: Hessian FD error {}",
        worst.hess
    );
    assert!(
        worst.sum <= 1e-10,
        "{label}: forces do not sum to zero {}",
        worst.sum
    );
    assert!(worst.torque <= 1e-9, "{label}: net torque {}", worst.torque);
    assert!(
        worst.sym <= 1e-12,
        "{label}: Hessian not symmetric {}",
        worst.sym
    );
    worst
}

// ---------------------------------------------------------------------------
// Invariants

#[test]
fn invariants_match_direct_formulas() {
    let mut rng = SplitMix64::new(11);
    for _ in 0..20 {
        let (p, _) = rand_tri(&mut rng);
        let r = RefTri::new(p, H, None).unwrap();
        let q = rand_state(&r, &p, 0.8, 1.4, 0.1, &mut rng);
        let k = Kin::new(&r, &q).unwrap();
        // I₁ = Σ_k ℓ_k² cot α_k / (2 A_P); J = A_Q / A_P.
        let i1: f64 = (0..3)
            .map(|e| k.edge[e].norm_squared() * r.cot[e])
            .sum::<f64>()
            / (2.0 * r.area);
        assert!((k.i1 - i1).abs() < 1e-10 * i1);
        let aq = 0.5 * (q[1] - q[0]).cross(&(q[2] - q[0])).norm();
        assert!((k.j - aq / r.area).abs() < 1e-12);
        // F maps reference edges to current edges and kills the normal.
        assert!((k.f * (p[1] - p[0]) - (q[1] - q[0])).norm() < 1e-10);
        assert!((k.f * r.normal).norm() < 1e-12);
    }
}

#[test]
fn rigid_motion_is_unstrained() {
    let mut rng = SplitMix64::new(12);
    for _ in 0..20 {
        let (p, _) = rand_tri(&mut rng);
        let r = RefTri::new(p, H, None).unwrap();
        let rot = rand_rotation(&mut rng);
        let q = p.map(|x| rot * x + V3::new(1.0, -2.0, 3.0));
        let k = Kin::new(&r, &q).unwrap();
        let (s, _, _) = k.s(&r, false);
        assert!((k.i1 - 2.0).abs() < 1e-12 && (k.j - 1.0).abs() < 1e-12 && s.abs() < 1e-12);
    }
}

#[test]
fn collapsed_triangle_is_rejected() {
    let p = [
        V3::new(0.0, 0.0, 0.0),
        V3::new(1.0, 0.0, 0.0),
        V3::new(0.0, 1.0, 0.0),
    ];
    let r = RefTri::new(p, H, None).unwrap();
    let q = [
        V3::new(0.0, 0.0, 0.0),
        V3::new(1.0, 0.0, 0.0),
        V3::new(2.0, 0.0, 0.0),
    ];
    assert!(NeoHookean { mu: 1.0 }.eval(&r, &q, true).is_none());
    let q = [
        V3::new(0.0, 0.0, 0.0),
        V3::new(1.0, 0.0, 0.0),
        V3::new(f64::NAN, 1.0, 0.0),
    ];
    assert!(NeoHookean { mu: 1.0 }.eval(&r, &q, true).is_none());
}

// ---------------------------------------------------------------------------
// Finite differences

#[test]
fn neo_hookean_fd() {
    let m = NeoHookean { mu: 1.0 / 3.0 };
    run_material("neo-hookean", &m, m.mu, None, 0.8, 1.4, 0.05, 25, 100);
}

#[test]
fn hessian_only_when_asked() {
    let p = [
        V3::new(0.0, 0.0, 0.0),
        V3::new(1.0, 0.0, 0.0),
        V3::new(0.0, 1.0, 0.0),
    ];
    let r = RefTri::new(p, H, None).unwrap();
    let q = p.map(|x| x * 1.1);
    let m = NeoHookean { mu: 1.0 };
    assert!(m.eval(&r, &q, false).unwrap().hess.is_none());
    assert!(m.eval(&r, &q, true).unwrap().hess.is_some());
}

// ---------------------------------------------------------------------------
// Analytic patch tests

/// A unit square in a tilted plane, split into two triangles, and its
/// image under the in-plane stretch diag(λ₁, λ₂) (then rotated and moved).
struct Patch {
    refs: [RefTri; 2],
    tris: [[usize; 3]; 2],
    p: [V3; 4],
    ex: V3,
    ey: V3,
    rot: Matrix3<f64>,
}

impl Patch {
    fn new(side: f64, fibres: Option<[V3; 2]>) -> Patch {
        let rot0 = *Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vector3::new(1.0, 2.0, 0.5)),
            0.7,
        )
        .matrix();
        let ex = rot0 * V3::x();
        let ey = rot0 * V3::y();
        let o = V3::new(1.0, -3.0, 2.0);
        let p = [o, o + ex * side, o + (ex + ey) * side, o + ey * side];
        let tris = [[0, 1, 2], [0, 2, 3]];
        // Fibres are given in the (ex, ey) frame.
        let fib = fibres.map(|f| f.map(|v| ex * v.x + ey * v.y));
        let refs = tris.map(|t| RefTri::new([p[t[0]], p[t[1]], p[t[2]]], H, fib).unwrap());
        let rot = *Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vector3::new(-0.3, 0.2, 1.0)),
            1.1,
        )
        .matrix();
        Patch {
            refs,
            tris,
            p,
            ex,
            ey,
            rot,
        }
    }

    fn current(&self, l1: f64, l2: f64) -> [V3; 4] {
        self.p.map(|x| {
            let d = x - self.p[0];
            self.rot * (self.ex * (l1 * d.dot(&self.ex)) + self.ey * (l2 * d.dot(&self.ey)))
                + V3::new(0.3, 0.1, -0.2)
        })
    }

    /// Total energy and the generalised forces dU/dλ₁, dU/dλ₂ (from the
    /// nodal gradients, chain rule through x(λ)).
    fn eval(&self, m: &dyn Membrane, l1: f64, l2: f64) -> (f64, f64, f64) {
        let x = self.current(l1, l2);
        let (mut u, mut d1, mut d2) = (0.0, 0.0, 0.0);
        for (r, t) in self.refs.iter().zip(self.tris.iter()) {
            let e: Eval = m.eval(r, &[x[t[0]], x[t[1]], x[t[2]]], false).unwrap();
            u += e.energy;
            for (a, &v) in t.iter().enumerate() {
                let g = V3::new(e.grad[3 * a], e.grad[3 * a + 1], e.grad[3 * a + 2]);
                let d = self.p[v] - self.p[0];
                d1 += g.dot(&(self.rot * self.ex * d.dot(&self.ex)));
                d2 += g.dot(&(self.rot * self.ey * d.dot(&self.ey)));
            }
        }
        (u, d1, d2)
    }
}

#[test]
fn neo_hookean_equibiaxial_and_uniaxial() {
    let mu = 0.3;
    let m = NeoHookean { mu };
    let side = 2.0;
    let patch = Patch::new(side, None);
    let vol = side * side * H;
    for &l in &[0.85, 1.0, 1.1, 1.3, 1.6] {
        // Equibiaxial: W = μ/2 (2λ² + λ⁻⁴ − 3), dU/dλ₁ = V μ (λ − λ⁻⁵).
        let (u, d1, d2) = patch.eval(&m, l, l);
        let w = 0.5 * mu * (2.0 * l * l + l.powi(-4) - 3.0);
        assert!(
            (u - vol * w).abs() < 1e-12 * (1.0 + u.abs()),
            "λ={l}: {u} vs {}",
            vol * w
        );
        let t = vol * mu * (l - l.powi(-5));
        assert!(
            (d1 - t).abs() < 1e-10 * (1.0 + t.abs()) && (d2 - t).abs() < 1e-10 * (1.0 + t.abs())
        );
        // Uniaxial, free lateral edge: λ₂ = λ^(−1/2) makes dU/dλ₂ vanish, and
        // the axial force is V μ (λ − λ⁻²).
        let l2 = l.powf(-0.5);
        let (_, d1, d2) = patch.eval(&m, l, l2);
        assert!(d2.abs() < 1e-10, "λ={l}: lateral force {d2}");
        let t = vol * mu * (l - l.powi(-2));
        assert!(
            (d1 - t).abs() < 1e-10 * (1.0 + t.abs()),
            "λ={l}: {d1} vs {t}"
        );
    }
}

// ---------------------------------------------------------------------------
// St Venant–Kirchhoff (Delingette springs)

#[test]
fn svk_fd() {
    for (nu, seed) in [(0.0, 200), (0.45, 201)] {
        let m = StVenantKirchhoff {
            young: 1.0,
            poisson: nu,
        };
        run_material(
            &format!("svk ν={nu}"),
            &m,
            m.young,
            None,
            0.8,
            1.4,
            0.05,
            25,
            seed,
        );
    }
}

/// W_T = A₀ H (λ/2 (tr E)² + μ tr E²) with the plane-stress λ, μ, with E
/// computed from F independently of the springs.
#[test]
fn svk_equals_green_lagrange_energy() {
    let mut rng = SplitMix64::new(210);
    let mut worst: f64 = 0.0;
    for nu in [0.0, 0.3, 0.45] {
        let young = 2.0;
        let m = StVenantKirchhoff { young, poisson: nu };
        let lam = young * nu / (1.0 - nu * nu);
        let mu = young / (2.0 * (1.0 + nu));
        for _ in 0..20 {
            let (p, _) = rand_tri(&mut rng);
            let r = RefTri::new(p, H, None).unwrap();
            let q = rand_state(&r, &p, 0.8, 1.4, 0.1, &mut rng);
            let k = Kin::new(&r, &q).unwrap();
            let c = k.f.transpose() * k.f;
            let e = (c - (Matrix3::identity() - r.normal * r.normal.transpose())) * 0.5;
            let w = r.area * H * (0.5 * lam * e.trace().powi(2) + mu * (e * e).trace());
            let u = m.eval(&r, &q, false).unwrap().energy;
            worst = worst.max((u - w).abs() / w.abs());
        }
    }
    eprintln!("svk vs Green–Lagrange energy: max rel err {worst:.2e}");
    assert!(worst < 1e-12, "{worst}");
}

/// Uniaxial stress: with the lateral stretch from E₂₂ = −ν E₁₁ the lateral
/// force vanishes and the axial one is V E E₁₁ λ₁ (S₁₁ = E E₁₁); the
/// energy equals the plane-stress closed form for any (λ₁, λ₂).
#[test]
fn svk_uniaxial_and_biaxial_closed_form() {
    let side = 1.5;
    let vol = side * side * H;
    let patch = Patch::new(side, None);
    for nu in [0.0, 0.45] {
        let young = 1.0;
        let m = StVenantKirchhoff { young, poisson: nu };
        let lam = young * nu / (1.0 - nu * nu);
        let mu = young / (2.0 * (1.0 + nu));
        for &l1 in &[0.9, 1.05, 1.2, 1.4] {
            let e11 = 0.5 * (l1 * l1 - 1.0);
            let e22 = -nu * e11;
            let l2 = (1.0 + 2.0 * e22).sqrt();
            let (u, d1, d2) = patch.eval(&m, l1, l2);
            let w = vol * (0.5 * lam * (e11 + e22).powi(2) + mu * (e11 * e11 + e22 * e22));
            assert!((u - w).abs() < 1e-12 * w, "ν={nu} λ={l1}: {u} vs {w}");
            assert!(
                d2.abs() < 1e-12 * d1.abs().max(1e-3),
                "ν={nu} λ={l1}: lateral {d2}"
            );
            let t = vol * young * e11 * l1;
            assert!(
                (d1 - t).abs() < 1e-10 * t.abs(),
                "ν={nu} λ={l1}: {d1} vs {t}"
            );
        }
    }
}

// ---------------------------------------------------------------------------
// Gent

#[test]
fn gent_fd() {
    let m = Gent {
        mu: 1.0 / 3.0,
        jm: 2.3,
    };
    run_material("gent Jm=2.3", &m, m.mu, None, 0.8, 1.4, 0.05, 25, 300);
    // Close to lock-up (equibiaxial λ ≈ 1.55–1.6 gives s ≈ 1.9–2.27).
    run_material("gent near lock-up", &m, m.mu, None, 1.55, 1.6, 0.0, 20, 301);
}

#[test]
fn gent_closed_form_and_lock_up() {
    let (mu, jm) = (0.3, 2.3);
    let m = Gent { mu, jm };
    let side = 2.0;
    let vol = side * side * H;
    let patch = Patch::new(side, None);
    for &l in &[0.85f64, 1.0, 1.2, 1.5, 1.6] {
        let s: f64 = 2.0 * l * l + l.powi(-4) - 3.0;
        let (u, d1, _) = patch.eval(&m, l, l);
        let w = -0.5 * mu * jm * (1.0 - s / jm).ln();
        assert!((u - vol * w).abs() < 1e-12 * (1.0 + u.abs()), "λ={l}");
        // dU/dλ = V W_s ds/dλ / 2 per direction: ds/dλ₁ = 2λ − 2λ⁻⁵.
        let t = vol * 0.5 * mu / (1.0 - s / jm) * (2.0 * l - 2.0 * l.powi(-5));
        assert!(
            (d1 - t).abs() < 1e-10 * (1.0 + t.abs()),
            "λ={l}: {d1} vs {t}"
        );
    }
    // Beyond lock-up (λ = 1.7: s ≈ 2.9 > J_m): inadmissible, not NaN.
    let x = patch.current(1.7, 1.7);
    let t = patch.tris[0];
    assert!(
        m.eval(&patch.refs[0], &[x[t[0]], x[t[1]], x[t[2]]], true)
            .is_none()
    );
    // Large J_m: Gent → neo-Hookean.
    let g = Gent { mu, jm: 1e9 };
    let nh = NeoHookean { mu };
    let (ug, _, _) = patch.eval(&g, 1.3, 0.9);
    let (un, _, _) = patch.eval(&nh, 1.3, 0.9);
    assert!((ug - un).abs() < 1e-8 * un);
}

// ---------------------------------------------------------------------------
// GOH

#[test]
fn goh_fd() {
    let theta = std::f64::consts::FRAC_PI_4;
    for (kappa, ks) in [(0.2, "0.2"), (1.0 / 3.0, "1/3")] {
        // Seed stiffness at moderate strain (most states have I* > 1).
        let m = Goh {
            mu: 0.9,
            k1: 1.1,
            k2: 1000.0,
            kappa,
        };
        run_material(
            &format!("goh κ={ks} k2=1000"),
            &m,
            m.mu,
            Some(theta),
            0.97,
            1.08,
            0.01,
            25,
            400,
        );
        // Small k₂, large strain.
        let m = Goh {
            mu: 0.9,
            k1: 1.1,
            k2: 2.0,
            kappa,
        };
        run_material(
            &format!("goh κ={ks} k2=2"),
            &m,
            m.mu,
            Some(theta),
            0.8,
            1.4,
            0.05,
            25,
            401,
        );
        // k₂ = 1000 well inside the guarded (Taylor-continued) region.
        let m = Goh {
            mu: 0.9,
            k1: 1.1,
            k2: 1000.0,
            kappa,
        };
        run_material(
            &format!("goh κ={ks} k2=1000 guarded"),
            &m,
            m.mu,
            Some(theta),
            1.3,
            1.6,
            0.02,
            20,
            402,
        );
    }
    // One fibre family only (the other zero): still consistent.
    let mut rng = SplitMix64::new(403);
    let m = Goh {
        mu: 0.9,
        k1: 1.1,
        k2: 5.0,
        kappa: 0.1,
    };
    let mut worst = Errs::default();
    while worst.n < 20 {
        let (p, scale) = rand_tri(&mut rng);
        let f = fibres(&p, 0.3, &mut rng);
        let r = RefTri::new(p, H, Some([f[0], V3::zeros()])).unwrap();
        assert!(r.fiber[1].norm() == 0.0);
        let q = rand_state(&r, &p, 0.8, 1.4, 0.05, &mut rng);
        worst.max(fd_check(&m, &r, &q, scale).unwrap());
    }
    eprintln!(
        "goh one family: grad {:.2e} hess {:.2e}",
        worst.grad, worst.hess
    );
    assert!(worst.grad <= 1e-6 && worst.hess <= 1e-6);
}

#[test]
fn goh_guard_is_finite_and_c2() {
    let m = Goh {
        mu: 0.9,
        k1: 1.1,
        k2: 1000.0,
        kappa: 0.2,
    };
    let xc = (GOH_EXP_MAX / m.k2).sqrt();
    let (a, b) = (m.psi(xc * (1.0 - 1e-12)), m.psi(xc * (1.0 + 1e-12)));
    assert!(
        (a.0 - b.0).abs() <= 1e-9 * a.0
            && (a.1 - b.1).abs() <= 1e-9 * a.1
            && (a.2 - b.2).abs() <= 1e-9 * a.2
    );
    // A hugely stretched triangle: finite, no NaN.
    let p = [
        V3::new(0.0, 0.0, 0.0),
        V3::new(1.0, 0.0, 0.0),
        V3::new(0.0, 1.0, 0.0),
    ];
    let r = RefTri::new(
        p,
        H,
        Some([V3::new(1.0, 1.0, 0.0), V3::new(1.0, -1.0, 0.0)]),
    )
    .unwrap();
    let q = p.map(|x| x * 5.0);
    let e = m.eval(&r, &q, true).unwrap();
    assert!(e.energy.is_finite() && e.energy > 1e40);
    // Small k₂ uses exp_m1 (no cancellation) and k₂ = 0 is the quadratic limit.
    let small = Goh { k2: 1e-9, ..m }.psi(0.1);
    let zero = Goh { k2: 0.0, ..m }.psi(0.1);
    assert!((small.0 - zero.0).abs() < 1e-12 && (small.1 - zero.1).abs() < 1e-9);
}

#[test]
fn goh_closed_forms() {
    let side = 2.0;
    let vol = side * side * H;
    let (mu, k1, k2) = (0.9, 1.1, 3.0);
    let psi = |i: f64| {
        if i > 1.0 {
            k1 / (2.0 * k2) * ((k2 * (i - 1.0).powi(2)).exp() - 1.0)
        } else {
            0.0
        }
    };
    for theta in [0.0, 0.4, std::f64::consts::FRAC_PI_4, 1.2] {
        let f = [
            V3::new(theta.cos(), theta.sin(), 0.0),
            V3::new(theta.cos(), -theta.sin(), 0.0),
        ];
        let patch = Patch::new(side, Some(f));
        for &l in &[0.9f64, 1.0, 1.1, 1.25] {
            let s: f64 = 2.0 * l * l + l.powi(-4) - 3.0;
            // κ = 1/3: NH + 2 ψ((s + 3)/3), independent of the fibre angle.
            let m = Goh {
                mu,
                k1,
                k2,
                kappa: 1.0 / 3.0,
            };
            let (u, _, _) = patch.eval(&m, l, l);
            let w = 0.5 * mu * s + 2.0 * psi((s + 3.0) / 3.0);
            assert!(
                (u - vol * w).abs() < 1e-12 * (1.0 + u.abs()),
                "θ={theta} λ={l}: {u} vs {}",
                vol * w
            );
            // κ = 0.2: equibiaxial gives I₄ = λ² for any in-plane angle.
            let kappa = 0.2;
            let m = Goh { mu, k1, k2, kappa };
            let (u, _, _) = patch.eval(&m, l, l);
            let w = 0.5 * mu * s + 2.0 * psi(kappa * (s + 3.0) + (1.0 - 3.0 * kappa) * l * l);
            assert!(
                (u - vol * w).abs() < 1e-12 * (1.0 + u.abs()),
                "θ={theta} λ={l}"
            );
        }
        // Uniaxial along e_x with κ = 0: I₄ = λ² cos²θ + λ₂² sin²θ.
        let (l1, l2) = (1.2, 0.95);
        let m = Goh {
            mu,
            k1,
            k2,
            kappa: 0.0,
        };
        let (u, _, _) = patch.eval(&m, l1, l2);
        let s = l1 * l1 + l2 * l2 + (l1 * l2).powi(-2) - 3.0;
        let i4 = l1 * l1 * theta.cos().powi(2) + l2 * l2 * theta.sin().powi(2);
        let w = 0.5 * mu * s + 2.0 * psi(i4);
        assert!((u - vol * w).abs() < 1e-12 * (1.0 + u.abs()), "θ={theta}");
    }
    // No fibres: GOH is neo-Hookean.
    let patch = Patch::new(side, None);
    let (ug, _, _) = patch.eval(
        &Goh {
            mu,
            k1,
            k2,
            kappa: 0.2,
        },
        1.3,
        0.8,
    );
    let (un, _, _) = patch.eval(&NeoHookean { mu }, 1.3, 0.8);
    assert!((ug - un).abs() < 1e-14 * un);
}

// ---------------------------------------------------------------------------
// Mass–spring model

/// Edge strains ε_e = ℓ_e/ℓ₀ − 1 of one triangle.
fn edge_strains(r: &RefTri, q: &[V3; 3]) -> [f64; 3] {
    [0, 1, 2].map(|e| (q[(e + 2) % 3] - q[(e + 1) % 3]).norm() / r.rest_len2[e].sqrt() - 1.0)
}

#[test]
fn msm_fd() {
    let theta = 0.6;
    let cases: [(&str, Law, Option<f64>); 4] = [
        ("msm linear", Law::Linear { young: 1.0 }, None),
        ("msm three-step", seed000_isotropic(), None),
        ("msm anisotropic", seed000_anisotropic(), Some(theta)),
        ("msm anisotropic, no fibre", seed000_anisotropic(), None),
    ];
    for (k, (label, law, th)) in cases.into_iter().enumerate() {
        let m = MassSpring { law };
        let w = run_material(label, &m, 1.0, th, 0.8, 1.4, 0.05, 30, 500 + k as u64);
        assert_eq!(w.n, 30);
    }
    // Replays the three-step states (seed 501, same draw sequence): they
    // straddle both breakpoints and include compression.
    let mut rng = SplitMix64::new(501);
    let mut count = [0usize; 4];
    for _ in 0..30 {
        let (p, _) = rand_tri(&mut rng);
        let r = RefTri::new(p, H, None).unwrap();
        rigid_check(
            &MassSpring {
                law: seed000_isotropic(),
            },
            &r,
            &p,
            1.0 * r.area * H,
            &mut rng,
        );
        let q = rand_state(&r, &p, 0.8, 1.4, 0.05, &mut rng);
        for e in edge_strains(&r, &q) {
            count[if e < 0.0 {
                0
            } else if e <= 0.175 {
                1
            } else if e <= 0.3 {
                2
            } else {
                3
            }] += 1;
        }
    }
    eprintln!("msm strain regimes (compression, E1, E2, E3): {count:?}");
    assert!(count.iter().all(|&c| c >= 5), "{count:?}");
}

#[test]
fn msm_linear_is_a_hooke_spring() {
    let mut rng = SplitMix64::new(510);
    let young = 1.3;
    let m = MassSpring {
        law: Law::Linear { young },
    };
    for _ in 0..20 {
        let (p, _) = rand_tri(&mut rng);
        let r = RefTri::new(p, H, None).unwrap();
        let q = rand_state(&r, &p, 0.8, 1.4, 0.05, &mut rng);
        let u = m.eval(&r, &q, false).unwrap().energy;
        // ½ k (ℓ − ℓ₀)², k = E H A_T / ℓ₀² (Van Gelder ν = 0 / Lloyd).
        let w: f64 = (0..3)
            .map(|e| {
                let l0 = r.rest_len2[e].sqrt();
                let l = (q[(e + 2) % 3] - q[(e + 1) % 3]).norm();
                0.5 * young * H * r.area / (l0 * l0) * (l - l0).powi(2)
            })
            .sum();
        assert!((u - w).abs() < 1e-12 * w, "{u} vs {w}");
    }
}

/// Anisotropic springs: edge-by-edge effective moduli from the angle between
/// the rest edge and fiber[0] (computed here from the reference points).
#[test]
fn msm_anisotropic_edge_moduli() {
    let law = seed000_anisotropic();
    let Law::Anisotropic { fibre, cross, eps } = law else {
        unreachable!()
    };
    let s = law.steps(Some(1.0));
    assert_eq!(s.e, fibre);
    let s = law.steps(Some(0.0));
    assert_eq!(s.e, cross);
    let mut rng = SplitMix64::new(520);
    let m = MassSpring { law };
    for _ in 0..20 {
        let (p, _) = rand_tri(&mut rng);
        let th = rng.range(0.0, 3.0);
        let f = fibres(&p, th, &mut rng);
        let r = RefTri::new(p, H, Some(f)).unwrap();
        let q = rand_state(&r, &p, 0.8, 1.4, 0.05, &mut rng);
        let strains = edge_strains(&r, &q);
        let mut w = 0.0;
        for e in 0..3 {
            let t = (p[(e + 2) % 3] - p[(e + 1) % 3]).normalize();
            let c2 = t.dot(&f[0]).powi(2);
            let es =
                [0, 1, 2].map(|k| (fibre[k].powi(2) * c2 + cross[k].powi(2) * (1.0 - c2)).sqrt());
            // Φ(ε) by numerical quadrature of the continuous σ(ε).
            let sigma = |x: f64| {
                if x <= eps[0] {
                    es[0] * x
                } else if x <= eps[1] {
                    es[0] * eps[0] + es[1] * (x - eps[0])
                } else {
                    es[0] * eps[0] + es[1] * (eps[1] - eps[0]) + es[2] * (x - eps[1])
                }
            };
            let n = 20000;
            let x = strains[e];
            let phi: f64 = (0..n)
                .map(|i| sigma((i as f64 + 0.5) / n as f64 * x))
                .sum::<f64>()
                * x
                / n as f64;
            w += H * r.area * phi;
        }
        let u = m.eval(&r, &q, false).unwrap().energy;
        assert!((u - w).abs() < 1e-6 * w, "{u} vs {w}");
    }
}

/// Two equilateral triangles sharing an edge, stretched by λ along that edge:
/// U = H A [2 Φ(λ − 1) + 4 Φ(ε₆₀)], ε₆₀ = √(λ²/4 + 3/4) − 1. The generalised
/// force dU/dλ is continuous across ε = 0.175 while the tangent jumps by
/// 2 H A (E₂ − E₁).
#[test]
fn msm_rhombus_breakpoint_continuity() {
    let law = seed000_isotropic();
    let Law::ThreeStep { e, eps } = law else {
        unreachable!()
    };
    let m = MassSpring { law };
    let a = 2.0;
    let rot = *Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(0.2, -1.0, 0.4)),
        0.9,
    )
    .matrix();
    let s3 = 3f64.sqrt() / 2.0;
    let p = [
        V3::new(0.0, 0.0, 0.0),
        V3::new(a, 0.0, 0.0),
        V3::new(0.5 * a, s3 * a, 0.0),
        V3::new(0.5 * a, -s3 * a, 0.0),
    ];
    let tris = [[0, 1, 2], [1, 0, 3]];
    let refs =
        tris.map(|t| RefTri::new([p[t[0]], p[t[1]], p[t[2]]].map(|x| rot * x), H, None).unwrap());
    let area = refs[0].area;
    // U and dU/dλ from the element gradients.
    let eval = |l: f64| {
        let x = p.map(|v| rot * V3::new(l * v.x, v.y, 0.0));
        let (mut u, mut d) = (0.0, 0.0);
        for (r, t) in refs.iter().zip(tris.iter()) {
            let ev = m.eval(r, &[x[t[0]], x[t[1]], x[t[2]]], false).unwrap();
            u += ev.energy;
            for (k, &v) in t.iter().enumerate() {
                let g = V3::new(ev.grad[3 * k], ev.grad[3 * k + 1], ev.grad[3 * k + 2]);
                d += g.dot(&(rot * V3::new(p[v].x, 0.0, 0.0)));
            }
        }
        (u, d)
    };
    let steps = law.steps(None);
    let closed = |l: f64| {
        let e60 = (0.25 * l * l + 0.75).sqrt() - 1.0;
        let (p0, s0, _) = steps.eval(l - 1.0);
        let (p6, s6, _) = steps.eval(e60);
        (
            H * area * (2.0 * p0 + 4.0 * p6),
            H * area * (2.0 * s0 + 4.0 * s6 * 0.25 * l / (1.0 + e60)),
        )
    };
    for &l in &[0.9, 1.1, 1.175, 1.2, 1.3, 1.45] {
        let (u, d) = eval(l);
        let (uc, dc) = closed(l);
        assert!(
            (u - uc).abs() < 1e-12 * uc && (d - dc).abs() < 1e-10 * dc.abs(),
            "λ={l}"
        );
    }
    for b in eps {
        let l = 1.0 + b;
        let dl = 1e-9;
        let (_, dm) = eval(l - dl);
        let (_, dp) = eval(l + dl);
        // Continuous force: the jump is only the O(δ) tangent term.
        assert!((dp - dm).abs() < 1e-6 * dp.abs(), "ε={b}: {dm} vs {dp}");
        // Tangent jumps by 2 H A (E_next − E_prev) (the 60° edges stay in E₁).
        let h = 1e-4;
        let tan = |l: f64| (eval(l + h).1 - eval(l - h).1) / (2.0 * h);
        let jump = tan(l + 2.0 * h) - tan(l - 2.0 * h);
        let k = if b == eps[0] { 1 } else { 2 };
        let expect = 2.0 * H * area * (e[k] - e[k - 1]);
        assert!(
            (jump - expect).abs() < 1e-3 * expect.abs(),
            "ε={b}: jump {jump} vs {expect}"
        );
    }
}

/// Why the MSM needs a rest mesh without obtuse triangles (seed 004
/// §2.3.1): moving the obtuse vertex of a flat triangle towards the long
/// edge changes the two short springs only by (h/ℓ)·δ, so the three-spring
/// element is ~h² times softer in that mode than in shear, and a few per cent
/// of compression makes it negative (a shallow truss snapping through). The
/// constant-strain membrane (St.V-K, same E) pays for the lost area and stays
/// stiff. An equilateral triangle shows neither.
#[test]
fn msm_obtuse_triangle_has_a_soft_flattening_mode() {
    let msm = MassSpring {
        law: Law::Linear { young: 1.0 },
    };
    let svk = StVenantKirchhoff {
        young: 1.0,
        poisson: 1.0 / 3.0,
    };
    // ∂²U/∂y² and ∂²U/∂x² at the apex (vertex 2), the base along x.
    let k = |m: &dyn Membrane, p: &[V3; 3], scale: f64| {
        let r = RefTri::new(*p, H, None).unwrap();
        let q = p.map(|v| v * scale);
        let h = m.eval(&r, &q, true).unwrap().hess.unwrap();
        (h[(7, 7)], h[(6, 6)])
    };
    let hgt = 0.2;
    let obtuse = [
        V3::new(0.0, 0.0, 0.0),
        V3::new(2.0, 0.0, 0.0),
        V3::new(1.0, hgt, 0.0),
    ];
    let (m_flat, m_shear) = k(&msm, &obtuse, 1.0);
    let (s_flat, _) = k(&svk, &obtuse, 1.0);
    assert!(
        m_flat > 0.0 && m_flat < 2.0 * hgt * hgt * m_shear,
        "{m_flat} vs {m_shear}"
    );
    assert!(m_flat < 1e-2 * s_flat, "msm {m_flat} vs svk {s_flat}");
    // 6 % uniform compression: the springs' flattening stiffness turns
    // negative, the membrane's does not.
    let (m_c, _) = k(&msm, &obtuse, 0.94);
    let (s_c, _) = k(&svk, &obtuse, 0.94);
    assert!(m_c < 0.0 && s_c > 0.0, "msm {m_c}, svk {s_c}");
    let s3 = 3f64.sqrt() / 2.0;
    let equilateral = [
        V3::new(0.0, 0.0, 0.0),
        V3::new(2.0, 0.0, 0.0),
        V3::new(1.0, 2.0 * s3, 0.0),
    ];
    let (me, _) = k(&msm, &equilateral, 1.0);
    let (se, _) = k(&svk, &equilateral, 1.0);
    assert!(
        me > 0.3 * se && me < 3.0 * se,
        "equilateral: msm {me} vs svk {se}"
    );
    let (me_c, _) = k(&msm, &equilateral, 0.94);
    assert!(me_c > 0.0, "equilateral, compressed: {me_c}");
}

// ---------------------------------------------------------------------------
// Tension field (wrinkling neo-Hookean)

/// Finite differences in each tension-field state separately (the Hessian
/// jumps where they meet): states are drawn over stretches 0.4–1.5 and kept
/// only when clearly inside `want`.
#[test]
fn wrinkling_fd_in_each_state() {
    let m = WrinklingNeoHookean {
        mu: 1.0 / 3.0,
        residual: 0.0,
    };
    let mut rng = SplitMix64::new(700);
    for (want, m) in [
        TensionState::Taut,
        TensionState::Wrinkled,
        TensionState::Slack,
    ]
    .into_iter()
    .flat_map(|s| {
        [
            (s, m),
            (
                s,
                WrinklingNeoHookean {
                    residual: 0.05,
                    ..m
                },
            ),
        ]
    }) {
        let mut worst = Errs::default();
        let mut tries = 0;
        while worst.n < 25 {
            tries += 1;
            assert!(tries < 20_000, "{want:?}: too few states drawn");
            let (p, scale) = rand_tri(&mut rng);
            let r = RefTri::new(p, H, None).unwrap();
            let q = rand_state(&r, &p, 0.4, 1.5, 0.03, &mut rng);
            // Every perturbation of the FD stencil must stay in the state.
            let inside = (0..9).all(|c| {
                [-1e-4, 1e-4].iter().all(|&d| {
                    WrinklingNeoHookean::state(&r, &perturb(&q, c, d * scale)) == Some(want)
                })
            });
            if !inside {
                continue;
            }
            if let Some(e) = fd_check(&m, &r, &q, scale) {
                worst.max(e);
            }
        }
        eprintln!(
            "wrinkling {want:?}, residual {}: grad {:.2e} hess {:.2e} Σf {:.2e} torque {:.2e} asym {:.2e}",
            m.residual, worst.grad, worst.hess, worst.sum, worst.torque, worst.sym
        );
        if want != TensionState::Slack || m.residual > 0.0 {
            assert!(
                worst.grad <= 1e-6 && worst.hess <= 1e-6,
                "{want:?}: {worst:?}"
            );
            assert!(worst.sum <= 1e-10 && worst.torque <= 1e-9 && worst.sym <= 1e-12);
        }
    }
}

/// A strip pulled along e_x: whatever its width (below the free width
/// λ^(−1/2)), its energy and axial force are the free uniaxial strip's and
/// the lateral force is zero; a sheet shorter than its reference both ways
/// costs nothing; taut, the law is the neo-Hookean one.
#[test]
fn wrinkling_uniaxial_slack_and_taut_closed_forms() {
    let mu = 0.3;
    let m = WrinklingNeoHookean { mu, residual: 0.0 };
    let nh = NeoHookean { mu };
    let side = 2.0;
    let patch = Patch::new(side, None);
    let vol = side * side * H;
    for &l in &[1.05f64, 1.3, 1.6] {
        let free = l.powf(-0.5);
        for &l2 in &[0.3, 0.6, 0.95 * free, free] {
            let (u, d1, d2) = patch.eval(&m, l, l2);
            let w = 0.5 * mu * (l * l + 2.0 / l - 3.0);
            assert!(
                (u - vol * w).abs() < 1e-12 * (1.0 + u.abs()),
                "λ {l} {l2}: {u}"
            );
            let t = vol * mu * (l - l.powi(-2));
            assert!(
                (d1 - t).abs() < 1e-10 * (1.0 + t),
                "λ {l} {l2}: {d1} vs {t}"
            );
            assert!(d2.abs() < 1e-10, "λ {l} {l2}: lateral force {d2}");
        }
        // A kept fraction c of the neo-Hookean energy blends the two laws.
        let blend = WrinklingNeoHookean { residual: 0.1, ..m };
        let (ub, _, _) = patch.eval(&blend, l, 0.6);
        let (un, _, _) = patch.eval(&nh, l, 0.6);
        let w = vol * 0.5 * mu * (l * l + 2.0 / l - 3.0);
        assert!(
            (ub - (0.9 * w + 0.1 * un)).abs() < 1e-12 * un,
            "λ {l}: {ub}"
        );
        // Wider than free: taut, and exactly the neo-Hookean law.
        for &l2 in &[1.02 * free, 1.0, l] {
            assert_eq!(patch.eval(&m, l, l2), patch.eval(&nh, l, l2));
        }
    }
    for &(l1, l2) in &[(1.0, 1.0), (0.9, 0.5), (0.99, 0.99), (0.6, 0.2)] {
        // At λ = 1 rounding may leave a ≈ 1 + 1e-16: wrinkled, by nothing.
        let (u, d1, d2) = patch.eval(&m, l1, l2);
        assert!(
            u.abs() < 1e-15 && d1.abs() < 1e-14 && d2.abs() < 1e-14,
            "λ {l1} {l2}"
        );
    }
}

/// The relaxed energy never exceeds the neo-Hookean one, equals it when
/// taut, and is continuous with its forces across the taut–wrinkled and
/// wrinkled–slack boundaries.
#[test]
fn wrinkling_relaxes_and_is_c1() {
    let mu = 0.3;
    let m = WrinklingNeoHookean { mu, residual: 0.0 };
    let nh = NeoHookean { mu };
    let mut rng = SplitMix64::new(701);
    for _ in 0..200 {
        let (p, _) = rand_tri(&mut rng);
        let r = RefTri::new(p, H, None).unwrap();
        let q = rand_state(&r, &p, 0.4, 1.5, 0.05, &mut rng);
        let (Some(a), Some(b)) = (m.eval(&r, &q, false), nh.eval(&r, &q, false)) else {
            continue;
        };
        assert!(a.energy <= b.energy * (1.0 + 1e-12) + 1e-15);
        if WrinklingNeoHookean::state(&r, &q) == Some(TensionState::Taut) {
            assert_eq!(a.energy, b.energy);
        }
    }
    let patch = Patch::new(2.0, None);
    let eps = 1e-7;
    for &l in &[1.1f64, 1.4] {
        let free = l.powf(-0.5);
        let (u0, a0, b0) = patch.eval(&m, l, free * (1.0 - eps));
        let (u1, a1, b1) = patch.eval(&m, l, free * (1.0 + eps));
        assert!((u0 - u1).abs() < 1e-6 * u0 && (a0 - a1).abs() < 1e-5 * a0.abs());
        assert!(b0.abs() < 1e-9 && b1.abs() < 1e-5);
    }
    let (u, a, b) = patch.eval(&m, 1.0 + eps, 0.7);
    assert!(u.abs() < 1e-12 && a.abs() < 1e-6 && b.abs() < 1e-12);
}
