//! The edge–edge pairs: segment distance against brute force, the pair
//! barrier against finite differences (mollified or not), its CCD, and an
//! edge pushed across another edge held by nothing but the edge pair.

use super::barrier::BarrierParams;
use super::barrier_tests::{flat, rv, unflat};
use super::edge_barrier::*;
use super::leaflet_barrier::LeafletBarrier;
use crate::element::V3;
use crate::system::Term;
use coapt_base::rng::SplitMix64;
use coapt_geom::bvh::Bvh;
use coapt_geom::segment_distance::{SegRegion, segment_segment};
use coapt_geom::tri_tri;

fn region_class(r: SegRegion) -> u8 {
    match r {
        SegRegion::Interior => 0,
        SegRegion::PointEdge(_) => 1,
        SegRegion::PointPoint(..) => 2,
    }
}

/// min over (s, t) ∈ [0, 1]² of |a(s) − b(t)| by a 201² grid, then four
/// zooms around the best node (the squared distance is convex, so its
/// minimum stays in the zoomed window).
fn brute(q: &[V3; 4]) -> f64 {
    let at = |s: f64, t: f64| ((q[0] + (q[1] - q[0]) * s) - (q[2] + (q[3] - q[2]) * t)).norm();
    let (mut lo_s, mut lo_t, mut w) = (0.0, 0.0, 1.0);
    let n = 200;
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let (mut bs, mut bt) = (0.0, 0.0);
        for i in 0..=n {
            for j in 0..=n {
                let s = (lo_s + w * i as f64 / n as f64).clamp(0.0, 1.0);
                let t = (lo_t + w * j as f64 / n as f64).clamp(0.0, 1.0);
                let d = at(s, t);
                if d < best {
                    (best, bs, bt) = (d, s, t);
                }
            }
        }
        w *= 4.0 / n as f64;
        lo_s = bs - 0.5 * w;
        lo_t = bt - 0.5 * w;
    }
    best
}

#[test]
fn segment_distance_matches_brute_force_in_every_region() {
    let mut r = SplitMix64::new(5);
    let mut seen = [0usize; 3];
    for k in 0..300 {
        let a0 = rv(&mut r, 1.0);
        let mut q = [a0, a0 + rv(&mut r, 1.0), rv(&mut r, 1.0), V3::zeros()];
        q[3] = q[2] + rv(&mut r, 1.0);
        if k % 10 == 0 {
            // Exactly parallel, overlapping or not.
            q[3] = q[2] + (q[1] - q[0]) * r.range(-1.5, 1.5);
        }
        let pr = segment_segment(&q[0], &q[1], &q[2], &q[3]);
        let b = brute(&q);
        assert!(pr.dist <= b + 1e-12, "{k}: {} > brute {b}", pr.dist);
        assert!(
            b - pr.dist < 1e-9,
            "{k}: {} vs brute {b} {:?}",
            pr.dist,
            pr.region
        );
        // The reported closest points are at that distance.
        let p = q[0] + (q[1] - q[0]) * pr.s;
        let o = q[2] + (q[3] - q[2]) * pr.t;
        assert!(((p - o).norm() - pr.dist).abs() < 1e-12);
        seen[region_class(pr.region) as usize] += 1;
    }
    assert!(seen.iter().all(|&n| n >= 30), "{seen:?}");
}

/// A pair at s ∈ (0.05, 0.95) d̂ in region class `want`, clear of region
/// borders (the differences must not straddle one); `parallel`: nearly
/// parallel edges with c/ε ∈ (0.05, 0.95), where the mollifier acts.
fn random_pair(r: &mut SplitMix64, xi: f64, dhat: f64, want: u8, parallel: bool) -> ([V3; 4], f64) {
    loop {
        let a0 = rv(r, 1.0);
        let e1 = rv(r, 1.0);
        if e1.norm() < 0.3 {
            continue;
        }
        let e2 = if parallel {
            e1 * r.range(-1.2, 1.2) + rv(r, 0.05 * e1.norm())
        } else {
            rv(r, 1.0)
        };
        if e2.norm() < 0.3 {
            continue;
        }
        let n = e1.cross(&e2);
        let off = if n.norm() > 1e-9 {
            n.normalize()
        } else {
            continue;
        };
        let b0 = a0 + e1 * r.range(-0.3, 1.3) - e2 * r.range(-0.3, 1.3)
            + (off + rv(r, 0.5)) * (xi + dhat * r.range(0.05, 0.95));
        let q = [a0, a0 + e1, b0, b0 + e2];
        let eps = mollifier_eps(e1.norm_squared(), e2.norm_squared());
        let c = n.norm_squared();
        if parallel != (c < eps) || (parallel && !(c > 0.05 * eps && c < 0.95 * eps)) {
            continue;
        }
        let pr = proximity(&q);
        let s = pr.dist - xi;
        if !(s > 0.05 * dhat && s < 0.95 * dhat) || region_class(pr.region) != want {
            continue;
        }
        let h = 1e-4;
        let same = (0..12).all(|k| {
            [h, -h].iter().all(|&d| {
                let mut v = flat(&q);
                v[k] += d;
                proximity(&unflat(&v)).region == pr.region
            })
        });
        if same {
            return (q, eps);
        }
    }
}

/// Gradient = FD of the energy, Hessian = FD of the gradient (relative
/// error ≤ 1e-6) in each region, with and without the mollifier acting.
#[test]
fn edge_pair_gradient_and_hessian_match_finite_differences() {
    let mut r = SplitMix64::new(29);
    let prm = BarrierParams::from_pressure(0.25, 0.0107);
    let xi = 0.5;
    for parallel in [false, true] {
        for region in 0..3u8 {
            if parallel && region == 0 {
                // Nearly parallel segments meet inside both only when they
                // cross in projection: built below by hand.
                continue;
            }
            let (mut worst_g, mut worst_h) = (0.0f64, 0.0f64);
            for _ in 0..40 {
                let (q, eps) = random_pair(&mut r, xi, prm.dhat, region, parallel);
                check_fd(&q, xi, eps, &prm, &mut worst_g, &mut worst_h);
            }
            eprintln!(
                "parallel {parallel} region {region}: FD gradient {worst_g:.1e}, Hessian {worst_h:.1e}"
            );
            assert!(worst_g < 1e-6 && worst_h < 1e-6, "{parallel} {region}");
        }
    }
    // Nearly parallel, crossing in projection: the interior region under
    // the mollifier (angle 1°, c/ε ≈ 0.3).
    let (mut worst_g, mut worst_h) = (0.0f64, 0.0f64);
    for k in 0..10 {
        let th = 0.017 + 0.0004 * k as f64;
        let q = [
            V3::new(-0.5, 0.0, 0.0),
            V3::new(0.5, 0.0, 0.0),
            V3::new(-0.5 * th.cos(), -0.5 * th.sin(), xi + 0.1),
            V3::new(0.5 * th.cos(), 0.5 * th.sin(), xi + 0.1),
        ];
        let pr = proximity(&q);
        assert_eq!(pr.region, SegRegion::Interior);
        let eps = mollifier_eps(1.0, 1.0);
        let c = (q[1] - q[0]).cross(&(q[3] - q[2])).norm_squared();
        assert!(c > 0.05 * eps && c < 0.95 * eps, "{}", c / eps);
        check_fd(&q, xi, eps, &prm, &mut worst_g, &mut worst_h);
    }
    eprintln!("parallel crossing: FD gradient {worst_g:.1e}, Hessian {worst_h:.1e}");
    assert!(worst_g < 1e-6 && worst_h < 1e-6);
}

fn check_fd(
    q: &[V3; 4],
    xi: f64,
    eps: f64,
    prm: &BarrierParams,
    worst_g: &mut f64,
    worst_h: &mut f64,
) {
    let w = 0.2;
    let (_, g, h) = pair_eval(q, xi, w, eps, prm, true).unwrap();
    let h = h.unwrap();
    let gn = g.iter().map(|v| v.norm()).fold(0.0, f64::max);
    let hn = h.abs().max();
    assert!(gn > 0.0);
    let step = 1e-6;
    for k in 0..12 {
        let (mut vp, mut vm) = (flat(q), flat(q));
        vp[k] += step;
        vm[k] -= step;
        let (ep, gp, _) = pair_eval(&unflat(&vp), xi, w, eps, prm, false).unwrap();
        let (em, gm, _) = pair_eval(&unflat(&vm), xi, w, eps, prm, false).unwrap();
        *worst_g = worst_g.max(((ep - em) / (2.0 * step) - g[k / 3][k % 3]).abs() / gn);
        for j in 0..12 {
            let fdh = (gp[j / 3][j % 3] - gm[j / 3][j % 3]) / (2.0 * step);
            *worst_h = worst_h.max((fdh - h[(j, k)]).abs() / hn);
        }
    }
    assert!((h - h.transpose()).abs().max() <= 1e-12 * hn);
    let gn_h = pair_gauss_newton(q, xi, w, eps, prm).unwrap();
    let ev = gn_h.symmetric_eigen().eigenvalues;
    assert!(ev.iter().all(|&l| l >= -1e-12 * hn), "{ev:?}");
    // Forces balance and have no moment (a function of the shape only).
    let f: V3 = g.iter().sum();
    let m: V3 = (0..4).map(|k| q[k].cross(&g[k])).sum();
    assert!(f.norm() < 1e-12 * gn && m.norm() < 1e-11 * gn * 3.0);
}

/// The mollified energy and its gradient go to zero as the edges turn
/// parallel (C¹ there: the closest points jump, the product does not).
#[test]
fn mollifier_makes_parallel_edges_smooth() {
    let prm = BarrierParams::from_pressure(0.25, 0.0107);
    let xi = 0.5;
    let eps = mollifier_eps(1.0, 1.0);
    let at = |th: f64| {
        let q = [
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(0.3, -0.2, xi + 0.1),
            V3::new(0.3 + th.cos(), -0.2 + th.sin(), xi + 0.1),
        ];
        let (e, g, _) = pair_eval(&q, xi, 0.2, eps, &prm, false).unwrap();
        (e, g.iter().map(|v| v.norm()).fold(0.0, f64::max))
    };
    assert_eq!(at(0.0), (0.0, 0.0));
    let (e1, g1) = at(1e-3);
    let (e2, g2) = at(1e-4);
    let (e_full, _) = at(0.2);
    assert!(e_full > 0.0 && e1 < 1e-3 * e_full && e2 < 1e-2 * e1);
    assert!(g2 < 0.2 * g1 && g1 > 0.0, "{g1} {g2}");
}

/// Two edges driven straight through each other (and random moves):
/// stopped with the distance above ξ all along the allowed fraction.
#[test]
fn edge_ccd_stops_crossing_edges_before_the_offset() {
    let xi = 0.3;
    let q = [
        V3::new(-1.0, 0.0, 1.0),
        V3::new(1.0, 0.0, 1.0),
        V3::new(0.0, -1.0, -1.0),
        V3::new(0.0, 1.0, -1.0),
    ];
    let dq = [V3::z() * -2.0, V3::z() * -2.0, V3::z() * 2.0, V3::z() * 2.0];
    let t = toi(&q, &dq, xi, 0.1, 60);
    let left = 2.0 - 4.0 * t - xi;
    assert!(
        t > 0.0 && t < 1.0 && left >= 0.1 * (2.0 - xi) - 1e-12,
        "{t} {left}"
    );
    let mut r = SplitMix64::new(31);
    let mut limited = 0;
    for _ in 0..400 {
        let q = [
            rv(&mut r, 1.0),
            rv(&mut r, 1.0),
            rv(&mut r, 1.0),
            rv(&mut r, 1.0),
        ];
        if proximity(&q).dist <= xi + 1e-3 {
            continue;
        }
        let dq = [0, 1, 2, 3].map(|_| rv(&mut r, 1.5));
        let t = toi(&q, &dq, xi, 0.1, 60);
        assert!((0.0..=1.0).contains(&t));
        limited += usize::from(t < 1.0);
        for k in 0..=2000 {
            let u = t * k as f64 / 2000.0;
            let y = [0, 1, 2, 3].map(|j| q[j] + dq[j] * u);
            assert!(proximity(&y).dist > xi, "crossed at {u} < {t}");
        }
    }
    assert!(limited > 20, "{limited}");
}

/// Two vertical sheets at right angles, the upper one's lower free edge
/// pushed down onto the lower one's upper free edge, crossing it in plan.
/// Every node is at least h/2 from the other sheet's plane, so no
/// node–triangle pair comes within reach: only the edge pair can hold it
/// (the configuration the sample stalled on). Newton converges where the
/// pair's force κ w (−b′(s)) carries the push, nothing crosses, and the
/// result is the same on one and two threads.
#[test]
fn an_edge_pushed_onto_an_edge_is_held_by_the_edge_pair() {
    use crate::element::RefTri;
    use crate::material::NeoHookean;
    use crate::solve::{self, NewtonOptions, Stop};
    use crate::sparse::Dofs;
    use crate::system::{PressureMode, System};

    let (xi, dhat, p) = (0.05, 0.05, 0.0107);
    let prm = BarrierParams::from_pressure(dhat, p);
    // Upper sheet in the plane y = 0, x ∈ {−1.5 … 1.5}, z ∈ {z0, z0 + 1};
    // lower sheet in the plane x = 0, y ∈ {−1.5 … 1.5}, z ∈ {−1, 0}.
    // Built apart (offsets stay ξ), solved from inside the margin: a
    // rigid drop strains nothing, so the pair must act from the start.
    let (z_built, z0) = (xi + 3.0 * dhat, xi + 0.8 * dhat);
    let mut x = vec![];
    for j in 0..2 {
        for i in 0..4 {
            x.push(V3::new(i as f64 - 1.5, 0.0, z_built + j as f64));
        }
    }
    for j in 0..2 {
        for i in 0..4 {
            x.push(V3::new(0.0, i as f64 - 1.5, j as f64 - 1.0));
        }
    }
    let mut tris = vec![];
    for base in [0u32, 8] {
        for i in 0..3u32 {
            tris.push([base + i, base + i + 1, base + i + 5]);
            tris.push([base + i, base + i + 5, base + i + 4]);
        }
    }
    let body: Vec<u16> = (0..tris.len()).map(|t| u16::from(t >= 6)).collect();
    // The upper sheet moves along z only; the lower one is held.
    let fixed: Vec<[bool; 3]> = (0..16).map(|i| [true, true, i >= 8]).collect();
    let node_fixed: Vec<bool> = (0..16).map(|i| i >= 8).collect();
    let refs: Vec<RefTri> = tris
        .iter()
        .map(|t| RefTri::new(t.map(|i| x[i as usize]), 0.5, None).unwrap())
        .collect();
    let push = 1e-3; // N per node of the upper sheet, downwards
    let solve_at = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let term = LeafletBarrier::new(&x, &tris, &body, &node_fixed, prm, xi, 0.2);
            assert!(term.offsets().iter().all(|&o| o == xi));
            let mut sys = System {
                refs: refs.clone(),
                tris: tris.clone(),
                materials: vec![Box::new(NeoHookean { mu: 0.3 })],
                tri_material: vec![0; tris.len()],
                dofs: Dofs::new(&fixed),
                fixed: fixed.clone(),
                tri_pressure: vec![0.0; tris.len()],
                pressure_scale: 1.0,
                pressure_mode: PressureMode::Follower,
                terms: vec![Box::new(term), Box::new(Push { n: 8, f: push })],
                project: false,
                pressure_tangent: true,
                watch: None,
            };
            let mut y = x.clone();
            y[..8].iter_mut().for_each(|q| q.z += z0 - z_built);
            let o = solve::newton(
                &mut sys,
                &mut y,
                &NewtonOptions {
                    stop: Stop {
                        abs_n: 1e-12,
                        rel: 1e-12,
                        max_iterations: 100,
                        max_seconds: 60.0,
                        step_mm: 0.0,
                        step_residual_n: 0.0,
                    },
                    max_step_mm: 0.05,
                    ..NewtonOptions::default()
                },
            );
            assert!(o.converged, "{}", o.reason);
            // The tangent assembles (couplings cover the edge pair).
            let mut c = vec![];
            sys.terms[0].couplings(&mut c);
            assert!(!c.is_empty());
            y
        })
    };
    let y = solve_at(1);
    // The pair's force carries the whole push: κ w (−b′(s)) = 8 f, w the
    // mean of the two free edges' weights (a third of one triangle each).
    let w = 0.5 / 3.0;
    let total = 8.0 * push;
    let (mut lo, mut hi) = (0.0f64, dhat);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        let f = prm.kappa * w * -super::barrier::barrier(mid, dhat).1;
        if f > total {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let s = 0.5 * (lo + hi);
    assert!((y[1].z - y[2].z).abs() < 1e-12);
    let gap = 0.5 * (y[1].z + y[2].z);
    assert!((gap - (xi + s)).abs() < 1e-8, "{gap} vs {}", xi + s);
    // Nodes stay at least h/2 from the other sheet's plane: no node pair.
    assert!(y[..8].iter().all(|q| q.x.abs() >= 0.5));
    let bvh = Bvh::build(&y, &tris);
    assert!(tri_tri::intersecting_pairs(&y, &tris, &body, &bvh).is_empty());
    assert_eq!(y, solve_at(2));
}

/// A constant downward force on the first `n` nodes (a potential).
struct Push {
    n: usize,
    f: f64,
}

impl Term for Push {
    fn name(&self) -> &'static str {
        "push"
    }
    fn energy(&self, x: &[V3]) -> Option<f64> {
        Some(x[..self.n].iter().map(|q| self.f * q.z).sum())
    }
    fn add_force(&self, _x: &[V3], f: &mut [V3]) {
        for g in &mut f[..self.n] {
            g.z -= self.f;
        }
    }
}
