//! The barrier against finite differences, its CCD against sampling, and
//! two sheets pressed together against the closed form.

use super::barrier::*;
use super::leaflet_barrier::LeafletBarrier;
use super::tests::sheet;
use crate::element::V3;
use crate::system::Term;
use coapt_base::rng::SplitMix64;
use coapt_geom::closest_point::Feature;

/// A random vector with coordinates in [−s, s].
pub(super) fn rv(r: &mut SplitMix64, s: f64) -> V3 {
    V3::new(r.range(-s, s), r.range(-s, s), r.range(-s, s))
}

/// The four points of a pair as one vector of 12 coordinates.
pub(super) fn flat(q: &[V3; 4]) -> [f64; 12] {
    let mut v = [0.0; 12];
    for k in 0..4 {
        for c in 0..3 {
            v[3 * k + c] = q[k][c];
        }
    }
    v
}

pub(super) fn unflat(v: &[f64; 12]) -> [V3; 4] {
    [0, 1, 2, 3].map(|k| V3::new(v[3 * k], v[3 * k + 1], v[3 * k + 2]))
}

/// A triangle and a node at s ∈ (0.05, 0.95) d̂ in the region `want`
/// (0 face, 1 edge, 2 vertex), at least 1e-3 away from region borders.
fn random_pair(r: &mut SplitMix64, xi: f64, dhat: f64, want: u8) -> [V3; 4] {
    loop {
        let a = rv(r, 1.0);
        let b = a + rv(r, 1.0);
        let c = a + rv(r, 1.0);
        let n = (b - a).cross(&(c - a));
        if n.norm() < 0.2 {
            continue;
        }
        let w = [r.range(-0.5, 1.2), r.range(-0.5, 1.2)];
        let p = a + (b - a) * w[0] + (c - a) * w[1];
        let d = xi + dhat * r.range(0.05, 0.95);
        let dir = (n.normalize() + rv(r, 0.6)).normalize();
        let x = p + dir * d;
        let pr = proximity(&x, &a, &b, &c);
        let s = pr.dist - xi;
        if !(s > 0.05 * dhat && s < 0.95 * dhat) {
            continue;
        }
        let region = match pr.feature {
            Feature::Face => 0,
            Feature::Edge(_) => 1,
            Feature::Vertex(_) => 2,
        };
        if region != want || pr.w.iter().any(|&v| v > 0.0 && v < 1e-3) {
            continue;
        }
        // Stay clear of region borders: the two-sided differences must not
        // straddle one.
        let h = 1e-4;
        let same = (0..12).all(|k| {
            let mut v = flat(&[x, a, b, c]);
            v[k] += h;
            let q = unflat(&v);
            let f = proximity(&q[0], &q[1], &q[2], &q[3]).feature;
            v[k] -= 2.0 * h;
            let q = unflat(&v);
            f == pr.feature && proximity(&q[0], &q[1], &q[2], &q[3]).feature == pr.feature
        });
        if same {
            return [x, a, b, c];
        }
    }
}

#[test]
fn barrier_is_c2_at_the_margin_and_matches_its_derivatives() {
    let dhat = 0.3;
    let (b, b1, b2) = barrier(dhat * (1.0 - 1e-9), dhat);
    assert!(b.abs() < 1e-19 && b1.abs() < 1e-10 && b2.abs() < 1e-7);
    assert_eq!(barrier(dhat, dhat), (0.0, 0.0, 0.0));
    assert!(barrier(0.0, dhat).0.is_infinite());
    let h = 1e-6;
    for s in [0.01, 0.05, 0.1, 0.2, 0.29] {
        let (_, d1, d2) = barrier(s, dhat);
        let fd1 = (barrier(s + h, dhat).0 - barrier(s - h, dhat).0) / (2.0 * h);
        let fd2 = (barrier(s + h, dhat).1 - barrier(s - h, dhat).1) / (2.0 * h);
        assert!((fd1 - d1).abs() <= 1e-7 * d1.abs(), "{s}: {fd1} {d1}");
        assert!((fd2 - d2).abs() <= 1e-7 * d2.abs(), "{s}: {fd2} {d2}");
    }
}

/// Gradient = FD of the energy and Hessian = FD of the gradient, relative
/// error ≤ 1e-6, in each of the three regions of the closest point.
#[test]
fn pair_gradient_and_hessian_match_finite_differences_in_every_region() {
    let mut r = SplitMix64::new(17);
    let prm = BarrierParams::from_pressure(0.25, 0.0107);
    let xi = 0.5;
    for region in 0..3u8 {
        let (mut worst_g, mut worst_h) = (0.0f64, 0.0f64);
        for _ in 0..60 {
            let q = random_pair(&mut r, xi, prm.dhat, region);
            let area = r.range(0.05, 0.3);
            let (_, g, h) = pair_eval(&q, xi, area, &prm, true).unwrap();
            let h = h.unwrap();
            let gn = g.iter().map(|v| v.norm()).fold(0.0, f64::max);
            let hn = h.abs().max();
            let step = 1e-6;
            for k in 0..12 {
                let mut vp = flat(&q);
                let mut vm = flat(&q);
                vp[k] += step;
                vm[k] -= step;
                let (ep, gp, _) = pair_eval(&unflat(&vp), xi, area, &prm, false).unwrap();
                let (em, gm, _) = pair_eval(&unflat(&vm), xi, area, &prm, false).unwrap();
                let fd = (ep - em) / (2.0 * step);
                worst_g = worst_g.max((fd - g[k / 3][k % 3]).abs() / gn);
                for j in 0..12 {
                    let fdh = (gp[j / 3][j % 3] - gm[j / 3][j % 3]) / (2.0 * step);
                    worst_h = worst_h.max((fdh - h[(j, k)]).abs() / hn);
                }
            }
            assert!((h - h.transpose()).abs().max() <= 1e-12 * hn);
            // The PSD part is PSD, and the exact Hessian minus it is the
            // b′ ∇²d term: no larger than the whole.
            let gn_h = pair_gauss_newton(&q, xi, area, &prm).unwrap();
            let ev = gn_h.symmetric_eigen().eigenvalues;
            assert!(ev.iter().all(|&l| l >= -1e-12 * hn), "{ev:?}");
        }
        eprintln!("region {region}: FD gradient {worst_g:.1e}, Hessian {worst_h:.1e}");
        assert!(worst_g < 1e-6 && worst_h < 1e-6, "region {region}");
    }
}

/// Forces sum to zero (momentum) and have no moment (the energy depends on
/// a distance only).
#[test]
fn pair_forces_balance() {
    let mut r = SplitMix64::new(3);
    let prm = BarrierParams::from_pressure(0.25, 0.0107);
    for region in 0..3u8 {
        let q = random_pair(&mut r, 0.5, prm.dhat, region);
        let (_, g, _) = pair_eval(&q, 0.5, 0.2, &prm, false).unwrap();
        let f: V3 = g.iter().sum();
        let m: V3 = (0..4).map(|k| q[k].cross(&g[k])).sum();
        let s = g[0].norm();
        assert!(s > 0.0 && f.norm() < 1e-12 * s && m.norm() < 1e-11 * s * 3.0);
    }
}

/// Along the move, up to the returned fraction, the distance never falls
/// below ξ (sampled at 2000 points), and a far pair gets the whole move.
#[test]
fn ccd_never_lets_a_pair_cross() {
    let mut r = SplitMix64::new(23);
    let xi = 0.3;
    let mut limited = 0;
    for _ in 0..400 {
        let a = rv(&mut r, 1.0);
        let q = [
            a + rv(&mut r, 1.5),
            a,
            a + rv(&mut r, 1.0),
            a + rv(&mut r, 1.0),
        ];
        if proximity(&q[0], &q[1], &q[2], &q[3]).dist <= xi + 1e-3 {
            continue;
        }
        let dq = [
            rv(&mut r, 2.0),
            rv(&mut r, 0.5),
            rv(&mut r, 0.5),
            rv(&mut r, 0.5),
        ];
        let t = toi(&q, &dq, xi, 0.1, 60);
        assert!((0.0..=1.0).contains(&t));
        if t < 1.0 {
            limited += 1;
        }
        for k in 0..=2000 {
            let u = t * k as f64 / 2000.0;
            let y = [0, 1, 2, 3].map(|j| q[j] + dq[j] * u);
            assert!(
                proximity(&y[0], &y[1], &y[2], &y[3]).dist > xi,
                "crossed at {u} < {t}"
            );
        }
    }
    assert!(limited > 20, "{limited}");
    let q = [V3::new(0.0, 0.0, 5.0), V3::zeros(), V3::x(), V3::y()];
    assert_eq!(
        toi(
            &q,
            &[V3::z() * -0.5, V3::zeros(), V3::zeros(), V3::zeros()],
            0.3,
            0.1,
            60
        ),
        1.0
    );
    // Straight at the plane: stops before ξ, at most at the gap kept.
    let t = toi(
        &q,
        &[V3::z() * -10.0, V3::zeros(), V3::zeros(), V3::zeros()],
        0.3,
        0.1,
        60,
    );
    let left = 5.0 - 10.0 * t - 0.3;
    assert!(left >= 0.1 * 4.7 - 1e-12, "{t} {left}");
}

/// A sheet over one large triangle of another leaflet (every node over
/// the face interior, the big triangle's corners out of reach): each node
/// meets one triangle, so the force on the sheet is the closed form
/// κ(−b′(s)) × its area, at the design gap s = d̂/2 half the design
/// pressure (κ is set for two sheets pushing on each other).
fn sheet_over_triangle(n: usize, h: f64, z: f64) -> (Vec<V3>, Vec<[u32; 3]>, Vec<u16>) {
    let mut r = SplitMix64::new(1);
    let (mut x, mut tris) = sheet(n, h, z, 0, 0.0, &mut r);
    let m = x.len() as u32;
    x.extend([
        V3::new(-20.0, -20.0, 0.0),
        V3::new(40.0, -20.0, 0.0),
        V3::new(-20.0, 40.0, 0.0),
    ]);
    let body: Vec<u16> = tris.iter().map(|_| 0).chain([1]).collect();
    tris.push([m, m + 1, m + 2]);
    (x, tris, body)
}

#[test]
fn a_sheet_over_a_face_carries_the_closed_form_pressure() {
    let (n, h) = (9, 0.5);
    let (xi, dhat, p) = (0.5, 0.25, 80.0 * 133.322e-6);
    let prm = BarrierParams::from_pressure(dhat, p);
    for (s, want) in [(0.5 * dhat, 0.5 * p), (prm.sheet_gap(0.3 * p), 0.15 * p)] {
        // Built apart (no offset lowered), then lowered to ξ + s.
        let (x0, tris, body) = sheet_over_triangle(n, h, xi + dhat);
        let mut x = x0.clone();
        x[..n * n].iter_mut().for_each(|q| q.z = xi + s);
        let fixed = vec![false; x.len()];
        let mut term = LeafletBarrier::new(&x0, &tris, &body, &fixed, prm, xi, 1.0);
        assert!(term.offsets().iter().all(|&o| o == xi));
        term.update(&x);
        let mut f = vec![V3::zeros(); x.len()];
        term.add_force(&x, &mut f);
        let top: V3 = f[..n * n].iter().sum();
        let bottom: V3 = f[n * n..].iter().sum();
        let area = ((n - 1) as f64 * h).powi(2);
        assert!(
            (top.z - want * area).abs() < 1e-9 * want * area,
            "{} vs {}",
            top.z,
            want * area
        );
        assert!((top + bottom).norm() < 1e-12 * top.norm());
        assert!(top.x.abs() < 1e-12 * top.z && top.y.abs() < 1e-12 * top.z);
        // Swapping the leaflets' numbers changes nothing.
        let swapped: Vec<u16> = body.iter().map(|b| 1 - b).collect();
        let mut t2 = LeafletBarrier::new(&x0, &tris, &swapped, &fixed, prm, xi, 1.0);
        t2.update(&x);
        let mut f2 = vec![V3::zeros(); x.len()];
        t2.add_force(&x, &mut f2);
        assert_eq!(f, f2);
    }
}

/// The sheet pressed onto the fixed triangle by a pressure P, solved by
/// Newton with the step filter: it settles where κ(−b′(s)) = P, i.e. at
/// `sheet_gap(2P)` (κ counts two sheets), never crossing on the way.
#[test]
fn a_pressed_sheet_settles_at_the_closed_form_gap() {
    use crate::element::RefTri;
    use crate::material::NeoHookean;
    use crate::solve::{self, NewtonOptions, Stop};
    use crate::sparse::Dofs;
    use crate::system::{PressureMode, System};
    let (n, h) = (7, 0.5);
    let (xi, dhat, p) = (0.5, 0.25, 80.0 * 133.322e-6);
    let prm = BarrierParams::from_pressure(dhat, p);
    let (x0, tris, body) = sheet_over_triangle(n, h, xi + 3.0 * dhat);
    let m = n * n;
    // Built well apart (the offsets stay ξ). The sheet moves along z only
    // (a rigid translation strains nothing); the big triangle is held.
    let fixed: Vec<[bool; 3]> = (0..x0.len()).map(|i| [true, true, i >= m]).collect();
    let node_fixed: Vec<bool> = (0..x0.len()).map(|i| i >= m).collect();
    let refs: Vec<RefTri> = tris
        .iter()
        .map(|t| RefTri::new(t.map(|i| x0[i as usize]), 0.5, None).unwrap())
        .collect();
    // Sheet triangles face +z: a negative pressure pushes them down.
    let tri_pressure: Vec<f64> = body
        .iter()
        .map(|&b| if b == 0 { -p } else { 0.0 })
        .collect();
    let mut sys = System {
        refs,
        tris: tris.clone(),
        materials: vec![Box::new(NeoHookean { mu: 0.3 })],
        tri_material: vec![0; tris.len()],
        dofs: Dofs::new(&fixed),
        fixed,
        tri_pressure,
        pressure_scale: 1.0,
        pressure_mode: PressureMode::Follower,
        terms: vec![Box::new(LeafletBarrier::new(
            &x0,
            &tris,
            &body,
            &node_fixed,
            prm,
            xi,
            1.0,
        ))],
        project: false,
        pressure_tangent: true,
        watch: None,
    };
    // Start inside the margin: a flat membrane has no stiffness across
    // itself, so the barrier must hold the sheet from the first step.
    let mut x = x0.clone();
    x[..m].iter_mut().for_each(|q| q.z = xi + 0.9 * dhat);
    let o = solve::newton(
        &mut sys,
        &mut x,
        &NewtonOptions {
            stop: Stop {
                abs_n: 1e-13,
                rel: 1e-13,
                max_iterations: 100,
                max_seconds: 60.0,
                step_mm: 0.0,
                step_residual_n: 0.0,
            },
            max_step_mm: 0.5,
            ..NewtonOptions::default()
        },
    );
    assert!(o.converged, "{}", o.reason);
    let want = xi + prm.sheet_gap(2.0 * p);
    for q in &x[..m] {
        assert!((q.z - want).abs() < 1e-9, "{} vs {want}", q.z);
    }
    assert!(o.iterations < 40, "{}", o.iterations);
}
