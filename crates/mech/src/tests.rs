//! The mechanics against closed-form solutions: inflated spheres and
//! cylinders, Hencky's clamped membrane (docs/verification.md).

use super::material::{NeoHookean, StVenantKirchhoff};
use super::verify::*;

const R0: f64 = 10.0;
const H: f64 = 0.5;
const MU: f64 = 1.0 / 3.0; // 333.3 kPa

fn rel_err(lam: f64, exact: f64) -> f64 {
    (lam - exact).abs() / (exact - 1.0)
}

#[test]
fn neo_hookean_sphere_matches_the_table_and_converges_quadratically() {
    // Neo-Hookean sphere, k = P·R0/(μH) = 2(λ⁻¹ − λ⁻⁷): 80 mmHg → λ = 1.07256.
    let p = 80.0 * MMHG;
    let k = p * R0 / (MU * H);
    let exact = invert(k, 1.38, |l| sphere_w1(l, |_| 0.5));
    assert!((exact - 1.07256).abs() < 5e-5, "{exact}");
    let mut errs = Vec::new();
    for level in [3, 4, 5] {
        let r = inflate_sphere(Box::new(NeoHookean { mu: MU }), R0, H, level, p);
        assert!(r.outcome.converged, "{:?}", r.outcome.reason);
        let e = rel_err(r.lambda, exact);
        eprintln!(
            "NH sphere level {level}: h {:.3} mm, λ {:.6} vs {exact:.6}, rel err {e:.2e}, spread {:.1e}, {} it",
            r.mean_edge_mm, r.lambda, r.spread, r.outcome.iterations
        );
        errs.push(e);
    }
    assert!(errs[2] < 0.005, "{errs:?}");
    assert!(
        errs[0] / errs[1] > 3.0 && errs[1] / errs[2] > 3.0,
        "not O(h²): {errs:?}"
    );
}

/// The stagnation rule hands a phase over only when it stalls: a Newton
/// that makes progress (here 1.29-fold inflation, residual falling) ends
/// where it ends without the rule, to the bit, and a rule no step can
/// meet stops the phase after its n steps, saying so.
#[test]
fn stagnation_stops_only_a_newton_that_stalls() {
    let p = 80.0 * MMHG;
    let nh = || Box::new(NeoHookean { mu: MU });
    let free = inflate_cylinder_with(nh(), R0, H, 40, p, |_| {});
    let ruled = inflate_cylinder_with(nh(), R0, H, 40, p, |o| o.stagnation = Some((3, 0.9)));
    assert!(free.outcome.converged && ruled.outcome.converged);
    assert_eq!(free.lambda.to_bits(), ruled.lambda.to_bits());
    assert_eq!(free.outcome.iterations, ruled.outcome.iterations);
    assert!(free.outcome.iterations > 3, "{}", free.outcome.iterations);
    let stopped =
        inflate_cylinder_with(nh(), R0, H, 40, p, |o| o.stagnation = Some((2, 0.0))).outcome;
    assert!(!stopped.converged);
    assert_eq!(stopped.stopped_by, super::solve::Stopped::IterationLimit);
    assert_eq!(stopped.iterations, 2);
    assert!(
        stopped.reason.starts_with("stagnated: 2 steps"),
        "{}",
        stopped.reason
    );
}

/// The held-back rule stops a Newton only after n accepted steps in a row
/// that were cut to f of Newton's or less: with f = 0 no step
/// qualifies and the solve ends where it ends without the rule, to the
/// bit; with f = 1 every accepted step does and it stops after n, saying
/// so, its state kept. Continuation (`ptc`) ignores it.
#[test]
fn held_back_stops_only_a_newton_whose_steps_are_cut() {
    let p = 80.0 * MMHG;
    let nh = || Box::new(NeoHookean { mu: MU });
    let free = inflate_cylinder_with(nh(), R0, H, 40, p, |_| {});
    let never = inflate_cylinder_with(nh(), R0, H, 40, p, |o| o.held_back = Some((1, 0.0)));
    assert!(free.outcome.converged && never.outcome.converged);
    assert_eq!(free.lambda.to_bits(), never.lambda.to_bits());
    assert_eq!(free.outcome.iterations, never.outcome.iterations);
    assert!(free.outcome.iterations > 3, "{}", free.outcome.iterations);
    let stopped =
        inflate_cylinder_with(nh(), R0, H, 40, p, |o| o.held_back = Some((3, 1.0))).outcome;
    assert!(!stopped.converged);
    assert_eq!(stopped.stopped_by, super::solve::Stopped::IterationLimit);
    assert_eq!(stopped.iterations, 3);
    assert!(
        stopped.reason.starts_with("held back: 3 steps"),
        "{}",
        stopped.reason
    );
    assert!(stopped.residual_n < stopped.initial_residual_n);
    assert_unmet_rule_changes_nothing(|o| o.held_back = Some((1, 1.0)));
}

/// The neo-Hookean cylinder inflated at 80 mmHg by continuation that
/// starts at the shift's floor, its options then changed by `rule` (the
/// hand-over rules' tests).
fn inflate_from_the_floor(rule: impl FnOnce(&mut super::solve::NewtonOptions)) -> Inflation {
    inflate_cylinder_with(
        Box::new(NeoHookean { mu: MU }),
        R0,
        H,
        40,
        80.0 * MMHG,
        |o| {
            o.ptc = true;
            o.initial_shift = 1e-12;
            rule(o);
        },
    )
}

/// A rule `rule` sets that no step of the solve meets changes nothing, to
/// the bit, against the same solve without it (which converges in more
/// than three iterations, so a rule had steps to act on).
fn assert_unmet_rule_changes_nothing(rule: impl FnOnce(&mut super::solve::NewtonOptions)) {
    let free = inflate_from_the_floor(|_| {});
    assert!(free.outcome.converged, "{}", free.outcome.reason);
    assert!(free.outcome.iterations > 3, "{}", free.outcome.iterations);
    let ruled = inflate_from_the_floor(rule);
    assert_eq!(free.lambda.to_bits(), ruled.lambda.to_bits());
    assert_eq!(free.outcome.iterations, ruled.outcome.iterations);
}

/// `o` handed over after exactly two steps, both full, saying `why`.
fn assert_handed_over_after_two_full_steps(o: &super::solve::Outcome, why: &str) {
    assert_eq!(
        o.stopped_by,
        super::solve::Stopped::HandedOver,
        "{}",
        o.reason
    );
    assert!(!o.converged);
    assert!(o.reason.starts_with(why), "{}", o.reason);
    assert_eq!(o.iterations, 2);
    assert!(o.history.iter().all(|r| r.step == 1.0));
}

/// The creep rule hands a continuation over only after `steps` full steps
/// in a row at the shift's floor that each lowered the residual by less
/// than `ratio`: a rule no step can meet (a step that lowers the residual
/// yet leaves it above where it was) changes nothing, to the bit; one every
/// such step meets hands over after exactly `steps` of them.
#[test]
fn creep_hands_over_only_a_continuation_that_creeps() {
    use super::solve::Creep;
    assert_unmet_rule_changes_nothing(|o| {
        o.creep = Some(Creep {
            below: 1.0,
            ratio: 1.0,
            steps: 1,
        })
    });
    let always = Creep {
        below: 1.0,
        ratio: 0.0,
        steps: 2,
    };
    let o = inflate_from_the_floor(|o| o.creep = Some(always)).outcome;
    assert_handed_over_after_two_full_steps(&o, "creeping: 2 full steps");
    // Each of them lowered the residual.
    assert!(
        o.residual_n < o.history[1].residual_n && o.history[1].residual_n < o.initial_residual_n
    );
}

/// The plateau rule hands a continuation over only after `steps` full
/// steps in a row at the shift's floor whose best residual stayed above
/// `1 − gain` times the one they started from: a rule that needs more
/// steps than the solve takes changes nothing, to the bit; one every run of
/// such steps meets hands over after exactly `steps` of them.
#[test]
fn plateau_hands_over_only_a_continuation_on_a_plateau() {
    use super::solve::Plateau;
    assert_unmet_rule_changes_nothing(|o| {
        o.plateau = Some(Plateau {
            steps: 1000,
            gain: 1.0,
        })
    });
    let always = Plateau {
        steps: 2,
        gain: 1.0,
    };
    let o = inflate_from_the_floor(|o| o.plateau = Some(always)).outcome;
    assert_handed_over_after_two_full_steps(&o, "plateau: 2 full steps");
}

#[test]
fn neo_hookean_cylinder_matches_the_table() {
    let p = 80.0 * MMHG;
    let k = p * R0 / (MU * H);
    let exact = invert(k, 3.0, cylinder_nh);
    assert!((exact - 1.29085).abs() < 2e-4, "{exact}");
    let r = inflate_cylinder(Box::new(NeoHookean { mu: MU }), R0, H, 160, p);
    assert!(r.outcome.converged, "{:?}", r.outcome.reason);
    let e = rel_err(r.lambda, exact);
    eprintln!(
        "NH cylinder: h {:.3} mm λ {:.6} vs {exact:.6} rel err {e:.2e} spread {:.1e}",
        r.mean_edge_mm, r.lambda, r.spread
    );
    assert!(e < 0.005);
}

#[test]
fn svk_sphere_and_cylinder_match_closed_forms() {
    let (young, nu) = (1.0, 0.45);
    let p = 0.1 * young * H / R0;
    let exact = invert(0.1, 2.0, |l| sphere_svk(l, nu));
    assert!((exact - 1.02788).abs() < 1e-5);
    let r = inflate_sphere(
        Box::new(StVenantKirchhoff { young, poisson: nu }),
        R0,
        H,
        5,
        p,
    );
    assert!(r.outcome.converged, "{:?}", r.outcome.reason);
    let e = rel_err(r.lambda, exact);
    eprintln!("SVK sphere λ {:.6} vs {exact:.6} rel err {e:.2e}", r.lambda);
    assert!(e < 0.005);
    let exact = invert(0.1, 2.0, |l| cylinder_svk(l, nu));
    assert!((exact - 1.07680).abs() < 1e-5);
    let r = inflate_cylinder(
        Box::new(StVenantKirchhoff { young, poisson: nu }),
        R0,
        H,
        160,
        p,
    );
    assert!(r.outcome.converged, "{:?}", r.outcome.reason);
    let e = rel_err(r.lambda, exact);
    eprintln!(
        "SVK cylinder λ {:.6} vs {exact:.6} rel err {e:.2e}",
        r.lambda
    );
    assert!(e < 0.005);
}

#[test]
fn gent_and_goh_spheres_match_closed_forms() {
    use super::material::{Gent, Goh};
    let p = 80.0 * MMHG;
    let k = p * R0 / (MU * H);
    let jm = 2.3;
    let exact = invert(k, 1.6, |l| {
        2.0 * jm * (1.0 / l - l.powi(-7)) / (jm - 2.0 * l * l - l.powi(-4) + 3.0)
    });
    assert!((exact - 1.07022).abs() < 5e-5, "{exact}");
    let r = inflate_sphere(Box::new(Gent { mu: MU, jm }), R0, H, 5, p);
    assert!(r.outcome.converged, "{:?}", r.outcome.reason);
    let e = rel_err(r.lambda, exact);
    eprintln!(
        "Gent sphere λ {:.6} vs {exact:.6} rel err {e:.2e}",
        r.lambda
    );
    assert!(e < 0.005);
    // GOH with κ = 1/3 is isotropic: W = μ/2 s + 2ψ(I₁/3) whatever the fibres.
    let goh = Goh {
        mu: MU,
        k1: 0.2,
        k2: 50.0,
        kappa: 1.0 / 3.0,
    };
    let w1 = |i1: f64| 0.5 * MU + 2.0 * goh.psi((i1 / 3.0 - 1.0).max(0.0)).1 / 3.0;
    let exact = invert(p * R0 / H, 1.3, |l| sphere_w1(l, w1));
    let r = inflate_sphere(Box::new(goh), R0, H, 5, p);
    assert!(r.outcome.converged, "{:?}", r.outcome.reason);
    let e = rel_err(r.lambda, exact);
    eprintln!(
        "GOH κ=1/3 sphere λ {:.6} vs {exact:.6} rel err {e:.2e}",
        r.lambda
    );
    assert!(e < 0.005);
}

#[test]
fn gent_cylinder_matches_the_table() {
    use super::material::Gent;
    let p = 80.0 * MMHG;
    let k = p * R0 / (MU * H);
    let exact = invert(k, 1.6, |l| cylinder_gent(l, 2.3));
    assert!((exact - 1.24601).abs() < 2e-4, "{exact}");
    let r = inflate_cylinder(Box::new(Gent { mu: MU, jm: 2.3 }), R0, H, 160, p);
    assert!(r.outcome.converged, "{:?}", r.outcome.reason);
    let e = rel_err(r.lambda, exact);
    eprintln!(
        "Gent cylinder λ {:.6} vs {exact:.6} rel err {e:.2e}",
        r.lambda
    );
    assert!(e < 0.005);
}

/// The assembled tangent is the derivative of the assembled residual: an
/// open cylinder patch (clamped bottom ring, free top edge) under follower
/// pressure, with penalty planes, neo-Hookean, at a perturbed state.
#[test]
fn assembled_tangent_is_the_derivative_of_the_residual() {
    use super::contact::planes::Plane;
    use super::element::{RefTri, V3};
    use super::material::NeoHookean;
    use super::sparse::{Dofs, Pattern};
    use super::system::{PressureMode, System};
    use super::terms::PlaneContact;
    let (x0, tris) = super::shapes::cylinder(5.0, 3.0, 24, 5);
    let fixed: Vec<[bool; 3]> = x0.iter().map(|p| [p.z < -1.49; 3]).collect();
    let refs: Vec<RefTri> = tris
        .iter()
        .map(|t| RefTri::new(t.map(|i| x0[i as usize]), 0.4, None).unwrap())
        .collect();
    let mut rng = coapt_base::rng::SplitMix64::new(11);
    let x: Vec<V3> = x0
        .iter()
        .zip(&fixed)
        .map(|(p, f)| {
            if f[0] {
                *p
            } else {
                p + V3::new(
                    rng.range(-0.2, 0.2),
                    rng.range(-0.2, 0.2),
                    rng.range(-0.2, 0.2),
                )
            }
        })
        .collect();
    let plane = Plane::new(V3::new(0.0, 4.8, 0.0), V3::new(0.0, -1.0, 0.0), 0.012, 0.5).unwrap();
    let all: Vec<u32> = (0..x.len() as u32).collect();
    let mut sys = System {
        refs,
        tris: tris.clone(),
        materials: vec![Box::new(NeoHookean { mu: 0.3 })],
        tri_material: vec![0; tris.len()],
        dofs: Dofs::new(&fixed),
        fixed,
        tri_pressure: vec![-0.0107; tris.len()],
        pressure_scale: 1.0,
        pressure_mode: PressureMode::Follower,
        terms: vec![Box::new(PlaneContact::new(vec![(plane, all)], &x, &tris))],
        project: false,
        pressure_tangent: true,
        watch: None,
    };
    for t in sys.terms.iter_mut() {
        t.update(&x);
    }
    assert!(
        x.iter().any(|p| plane.distance(p) < plane.eta2),
        "the plane must be active somewhere"
    );
    let pat = Pattern::new(x.len(), &sys.dofs, &sys.couplings());
    let mut vals = vec![0.0; pat.nnz()];
    sys.tangent(&x, &pat, &mut vals).unwrap();
    let v: Vec<f64> = (0..sys.dofs.n_eq).map(|_| rng.range(-1.0, 1.0)).collect();
    let kv = pat.mul(&vals, &v);
    let eps = 1e-6;
    let rp = sys.pack(&sys.residual(&sys.step(&x, &v, eps)).unwrap());
    let rm = sys.pack(&sys.residual(&sys.step(&x, &v, -eps)).unwrap());
    let fd: Vec<f64> = rp
        .iter()
        .zip(&rm)
        .map(|(a, b)| -(a - b) / (2.0 * eps))
        .collect();
    let err = kv
        .iter()
        .zip(&fd)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt();
    let scale = fd.iter().map(|a| a * a).sum::<f64>().sqrt();
    assert!(
        err <= 1e-6 * scale,
        "tangent vs FD: {err:.3e} of {scale:.3e}"
    );
}

#[test]
fn hencky_clamped_disc_within_two_percent() {
    use super::shapes::disc;
    // The disc mesh is a proper, consistently oriented triangulation.
    let (v, f, rim) = disc(10.0, 1.0);
    let m = coapt_geom::TriMesh::new(v.iter().map(|p| (*p).into()).collect(), f.clone());
    m.sanity_check().unwrap();
    let area: f64 = f
        .iter()
        .map(|t| {
            0.5 * (v[t[1] as usize] - v[t[0] as usize])
                .cross(&(v[t[2] as usize] - v[t[0] as usize]))
                .z
        })
        .sum();
    assert!(
        area > 0.98 * std::f64::consts::PI * 100.0 && area < std::f64::consts::PI * 100.0,
        "{area}"
    );
    assert_eq!(rim.iter().filter(|&&r| r).count(), 60);
    // Hencky's clamped membrane: a = 10 mm, h = 0.5 mm, E = 3μ = 1 MPa, ν = 0.5,
    // q = 1 kPa → w0 = 0.59488·a·(qa/Eh)^(1/3) = 1.61 mm.
    let (a, h, q): (f64, f64, f64) = (10.0, 0.5, 0.001);
    let w0 = 0.59488 * a * (q * a / (1.0 * h)).cbrt();
    let (w, o) = hencky(Box::new(NeoHookean { mu: 1.0 / 3.0 }), a, h, q, 0.4);
    assert!(o.converged, "{}", o.reason);
    eprintln!(
        "Hencky NH: w0 {w:.4} vs {w0:.4} ({:+.2} %), {} it",
        100.0 * (w - w0) / w0,
        o.iterations
    );
    // Hencky's law is linear plane stress; the incompressible neo-Hookean
    // membrane stiffens and thins differently at these 2–3 % strains.
    assert!((w - w0).abs() < 0.04 * w0);
    let (w, o) = hencky(
        Box::new(StVenantKirchhoff {
            young: 1.0,
            poisson: 0.5,
        }),
        a,
        h,
        q,
        0.4,
    );
    assert!(o.converged, "{}", o.reason);
    eprintln!(
        "Hencky SVK ν=0.5: w0 {w:.4} vs {w0:.4} ({:+.2} %)",
        100.0 * (w - w0) / w0
    );
    assert!((w - w0).abs() < 0.02 * w0);
    // ν = 0 with St.V-K: c_w = 0.71832.
    let w0 = 0.71832 * a * (q * a / (1.0 * h)).cbrt();
    let (w, o) = hencky(
        Box::new(StVenantKirchhoff {
            young: 1.0,
            poisson: 0.0,
        }),
        a,
        h,
        q,
        0.4,
    );
    assert!(o.converged, "{}", o.reason);
    eprintln!(
        "Hencky SVK ν=0: w0 {w:.4} vs {w0:.4} ({:+.2} %)",
        100.0 * (w - w0) / w0
    );
    assert!((w - w0).abs() < 0.02 * w0);
}

#[test]
fn the_step_cap_grows_while_full_capped_steps_are_taken() {
    // The Hencky disc's centre has to rise from the start's 0.5 mm to
    // 1.6 mm. At a fixed 0.05 mm cap that is at least 22 steps; the cap
    // doubles (to at most four times the first) while full capped steps
    // are taken, and the answer is the one an unconstrained start gives.
    let (a, h, q): (f64, f64, f64) = (10.0, 0.5, 0.001);
    let mat = || Box::new(NeoHookean { mu: 1.0 / 3.0 });
    let (w_free, _) = hencky(mat(), a, h, q, 0.8);
    let (w, o) = hencky_capped(mat(), a, h, q, 0.8, 0.05);
    assert!(o.converged, "{}", o.reason);
    let rise = w - 0.05 * a;
    assert!(rise > 1.0, "{rise}");
    assert!(
        (o.iterations as f64) < 0.75 * rise / 0.05,
        "{} iterations for a {rise:.2} mm rise at a 0.05 mm first cap",
        o.iterations
    );
    assert!(
        (o.iterations as f64) >= rise / (super::solve::MAX_STEP_GROWTH * 0.05),
        "the cap grew past its bound: {} iterations",
        o.iterations
    );
    assert!((w - w_free).abs() < 1e-6, "{w} vs {w_free}");
}
