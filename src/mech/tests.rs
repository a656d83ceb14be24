//! The mechanics against closed-form solutions (VERIFICATION.md §1–2).

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
    // VERIFICATION.md §1 table: 80 mmHg → λ = 1.07256.
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
#[ignore]
fn debug_history() {
    let p = 80.0 * MMHG;
    let t = std::time::Instant::now();
    let r = inflate_sphere(Box::new(NeoHookean { mu: MU }), R0, H, 4, p);
    for h in &r.outcome.history {
        eprintln!(
            "{} {:.3e} step {} shift {:.1e}",
            h.iteration, h.residual_n, h.step, h.shift
        );
    }
    eprintln!(
        "{} {:?} {:.2}s",
        r.lambda,
        r.outcome.reason,
        t.elapsed().as_secs_f64()
    );
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
