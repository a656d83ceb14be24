//! Closed-form inflation references (membranes under follower pressure;
//! docs/verification.md) and the discrete experiments that are held against
//! them: a free sphere (rigid modes pinned by three symmetric constraints)
//! and a long cylinder with its axial stretch held at 1.

use super::element::{Membrane, RefTri, V3};
use super::shapes;
use super::solve::{NewtonOptions, Outcome, newton};
use super::sparse::Dofs;
use super::system::{PressureMode, System};

/// 1 mmHg in MPa.
pub const MMHG: f64 = 133.322e-6;

/// Inverse of a monotone law k(λ) on [1, hi] by bisection.
pub fn invert(k: f64, hi: f64, law: impl Fn(f64) -> f64) -> f64 {
    let (mut a, mut b) = (1.0, hi);
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if law(m) < k { a = m } else { b = m }
    }
    0.5 * (a + b)
}

/// Sphere, any W(I₁) (incompressible): P R0/H = 4 W₁(I₁)(λ⁻¹ − λ⁻⁷).
pub fn sphere_w1(lambda: f64, w1: impl Fn(f64) -> f64) -> f64 {
    let i1 = 2.0 * lambda * lambda + lambda.powi(-4);
    4.0 * w1(i1) * (1.0 / lambda - lambda.powi(-7))
}

/// Sphere, St.V-K plane stress: k_E = P R0/(E H) = (λ² − 1)/((1 − ν)λ).
pub fn sphere_svk(lambda: f64, nu: f64) -> f64 {
    (lambda * lambda - 1.0) / ((1.0 - nu) * lambda)
}

/// Cylinder (axial stretch 1), neo-Hookean: k = P R0/(μ H) = 1 − λ⁻⁴.
pub fn cylinder_nh(lambda: f64) -> f64 {
    1.0 - lambda.powi(-4)
}

/// Cylinder, Gent: k = Jm(1 − λ⁻⁴)/(Jm − λ² − λ⁻² + 2).
pub fn cylinder_gent(lambda: f64, jm: f64) -> f64 {
    jm * (1.0 - lambda.powi(-4)) / (jm - lambda * lambda - lambda.powi(-2) + 2.0)
}

/// Cylinder, St.V-K: k_E = (λ² − 1)/(2(1 − ν²)).
pub fn cylinder_svk(lambda: f64, nu: f64) -> f64 {
    (lambda * lambda - 1.0) / (2.0 * (1.0 - nu * nu))
}

/// Result of one discrete inflation.
#[derive(Debug, Clone)]
pub struct Inflation {
    /// Mean stretch of the node radii.
    pub lambda: f64,
    /// (max − min)/mean of the node radii: how round it stayed.
    pub spread: f64,
    pub nodes: usize,
    pub mean_edge_mm: f64,
    pub outcome: Outcome,
}

pub(crate) fn refs(
    x: &[V3],
    tris: &[[u32; 3]],
    thickness: f64,
    fibers: Option<[V3; 2]>,
) -> Vec<RefTri> {
    tris.iter()
        .map(|t| {
            RefTri::new(t.map(|i| x[i as usize]), thickness, fibers).expect("non-degenerate shape")
        })
        .collect()
}

/// One material, one pressure on every triangle, no other terms.
pub(crate) fn uniform_system(
    refs: Vec<RefTri>,
    tris: &[[u32; 3]],
    mat: Box<dyn Membrane>,
    fixed: Vec<[bool; 3]>,
    p: f64,
    pressure_mode: PressureMode,
    project: bool,
) -> System {
    System {
        refs,
        tris: tris.to_vec(),
        materials: vec![mat],
        tri_material: vec![0; tris.len()],
        dofs: Dofs::new(&fixed),
        fixed,
        tri_pressure: vec![p; tris.len()],
        pressure_scale: 1.0,
        pressure_mode,
        terms: Vec::new(),
        project,
        pressure_tangent: true,
        watch: None,
    }
}

fn mean_edge(x: &[V3], tris: &[[u32; 3]]) -> f64 {
    let s: f64 = tris
        .iter()
        .map(|t| {
            (0..3)
                .map(|k| (x[t[k] as usize] - x[t[(k + 1) % 3] as usize]).norm())
                .sum::<f64>()
        })
        .sum();
    s / (3 * tris.len()) as f64
}

fn radii(x: &[V3], planar: bool) -> (f64, f64) {
    let r: Vec<f64> = x
        .iter()
        .map(|p| if planar { p.xy().norm() } else { p.norm() })
        .collect();
    let mean = r.iter().sum::<f64>() / r.len() as f64;
    let (lo, hi) = r
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    (mean, (hi - lo) / mean)
}

/// Inflate a free sphere of radius `r0` (mm), thickness `h` (mm) under `p`
/// (MPa), subdivision `level`, with the conservative pressure and Newton.
/// Fibres (for GOH) lie along the local ±45° of the z-meridian, pushed into
/// each triangle's plane.
pub fn inflate_sphere(mat: Box<dyn Membrane>, r0: f64, h: f64, level: u32, p: f64) -> Inflation {
    let (x0, tris) = shapes::icosphere(r0, level);
    let mut fixed = vec![[false; 3]; x0.len()];
    // Poles (0, ±1, ±t)-type vertices are not on the axes; pin the three
    // nodes closest to +z, −z and +x against rigid motion, compatible with a
    // uniform expansion about the origin.
    let closest = |d: V3| {
        (0..x0.len())
            .min_by(|&a, &b| (x0[a] - d * r0).norm().total_cmp(&(x0[b] - d * r0).norm()))
            .unwrap()
    };
    let (top, bot, eq) = (closest(V3::z()), closest(-V3::z()), closest(V3::x()));
    for n in [top, bot] {
        // Keep this node on its own ray from the origin: fix the two
        // coordinates that carry the least of its position.
        let d = x0[n].normalize();
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()));
        fixed[n][order[0]] = true;
        fixed[n][order[1]] = true;
    }
    {
        let d = x0[eq].normalize();
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()));
        fixed[eq][order[0]] = true;
    }
    // Fixing a coordinate pins it at its reference value, which is only
    // compatible with radial growth if it is zero: move those nodes onto
    // the pinned planes exactly.
    let mut x = x0.clone();
    let mut xr = x0.clone();
    for (n, f) in fixed.iter().enumerate() {
        for c in 0..3 {
            if f[c] {
                x[n][c] = 0.0;
                xr[n][c] = 0.0;
            }
        }
    }
    let fib = [
        V3::new(1.0, 0.0, 1.0).normalize(),
        V3::new(1.0, 0.0, -1.0).normalize(),
    ];
    let mut sys = uniform_system(
        refs(&xr, &tris, h, Some(fib)),
        &tris,
        mat,
        fixed,
        p,
        PressureMode::Volume { origin: [0.0; 3] },
        true,
    );
    let mut opt = NewtonOptions::default();
    opt.stop.abs_n = 1e-10;
    opt.stop.rel = 1e-11;
    opt.max_step_mm = r0;
    let outcome = newton(&mut sys, &mut x, &opt);
    let (mean, spread) = radii(&x, false);
    let (m0, _) = radii(&xr, false);
    Inflation {
        lambda: mean / m0,
        spread,
        nodes: x.len(),
        mean_edge_mm: mean_edge(&xr, &tris),
        outcome,
    }
}

/// Inflate a cylinder of radius `r0`, `nt` nodes around, with every axial
/// coordinate fixed (axial stretch 1) and in-plane rigid modes pinned by
/// symmetric constraints; follower pressure, LU Newton.
pub fn inflate_cylinder(mat: Box<dyn Membrane>, r0: f64, h: f64, nt: usize, p: f64) -> Inflation {
    inflate_cylinder_with(mat, r0, h, nt, p, |_| {})
}

/// [`inflate_cylinder`] with Newton's options changed by `tune` (the
/// stagnation, creep and plateau rules' tests).
pub fn inflate_cylinder_with(
    mat: Box<dyn Membrane>,
    r0: f64,
    h: f64,
    nt: usize,
    p: f64,
    tune: impl FnOnce(&mut NewtonOptions),
) -> Inflation {
    assert!(nt % 4 == 0);
    let dl = std::f64::consts::TAU * r0 / nt as f64;
    let (x0, tris) = shapes::cylinder(r0, 4.0 * dl * 3f64.sqrt() / 2.0, nt, 5);
    let mut fixed = vec![[false, false, true]; x0.len()];
    for (n, v) in x0.iter().enumerate() {
        if v.y.abs() < 1e-9 * r0 {
            fixed[n][1] = true;
        }
        if v.x.abs() < 1e-9 * r0 {
            fixed[n][0] = true;
        }
    }
    let fib = [
        V3::new(1.0, 1.0, 1.0).normalize(),
        V3::new(1.0, 1.0, -1.0).normalize(),
    ];
    let mut sys = uniform_system(
        refs(&x0, &tris, h, Some(fib)),
        &tris,
        mat,
        fixed,
        p,
        PressureMode::Follower,
        false,
    );
    let mut x = x0.clone();
    let mut opt = NewtonOptions::default();
    opt.stop.abs_n = 1e-11;
    opt.stop.rel = 1e-11;
    opt.max_step_mm = r0;
    tune(&mut opt);
    let outcome = newton(&mut sys, &mut x, &opt);
    let (mean, spread) = radii(&x, true);
    Inflation {
        lambda: mean / r0,
        spread,
        nodes: x.len(),
        mean_edge_mm: mean_edge(&x0, &tris),
        outcome,
    }
}

/// Hencky's clamped circular membrane: centre deflection (mm) of a disc of
/// radius `a`, thickness `h`, under `q` (MPa), with the conservative
/// pressure (the rim is fixed) and projected Newton.
pub fn hencky(mat: Box<dyn Membrane>, a: f64, h: f64, q: f64, mesh: f64) -> (f64, Outcome) {
    hencky_capped(mat, a, h, q, mesh, 0.2 * a)
}

/// [`hencky`] with the Newton step's first cap `max_step_mm`.
pub fn hencky_capped(
    mat: Box<dyn Membrane>,
    a: f64,
    h: f64,
    q: f64,
    mesh: f64,
    max_step_mm: f64,
) -> (f64, Outcome) {
    let (x0, tris, rim) = shapes::disc(a, mesh);
    let fixed: Vec<[bool; 3]> = rim.iter().map(|&r| [r; 3]).collect();
    let mut sys = uniform_system(
        refs(&x0, &tris, h, None),
        &tris,
        mat,
        fixed,
        q,
        PressureMode::Volume { origin: [0.0; 3] },
        true,
    );
    // A flat membrane has no out-of-plane stiffness: start from a small
    // paraboloid so the first tangent is not singular.
    let mut x: Vec<V3> = x0
        .iter()
        .map(|p| V3::new(p.x, p.y, 0.05 * a * (1.0 - p.xy().norm_squared() / (a * a))))
        .collect();
    let mut opt = NewtonOptions::default();
    opt.stop.abs_n = 1e-10;
    opt.stop.rel = 1e-10;
    opt.max_step_mm = max_step_mm;
    let o = newton(&mut sys, &mut x, &opt);
    (x[0].z, o)
}
