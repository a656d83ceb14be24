//! The wall barrier: forces = −gradient and tangent = ∂(−f)/∂x by central
//! differences on a cylinder and on a mesh wall (faces, edges and
//! vertices), PSD projection, collision-free steps, start offsets, and a
//! clamped patch blown onto the wall that stays inside it only with the
//! term.

use std::sync::Arc;

use nalgebra::DMatrix;

use super::*;
use crate::element::RefTri;
use crate::material::NeoHookean;
use crate::shapes;
use crate::solve::{NewtonOptions, newton};
use crate::system::{PressureMode, System};
use coapt_base::units::MMHG_IN_MPA;

const T: f64 = 0.5;
const DHAT: f64 = 0.25;
const R: f64 = 10.0;

fn params() -> BarrierParams {
    BarrierParams::from_pressure(DHAT, 2.0 * 80.0 * MMHG_IN_MPA)
}

/// Deterministic uniform numbers in [0, 1).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `n` separate triangles of 0.125 mm² near the axis (far from the wall:
/// full offsets), for node areas.
fn far_start(n_tris: usize) -> (Vec<V3>, Vec<[u32; 3]>) {
    let mut x = vec![];
    let mut tris = vec![];
    for j in 0..n_tris {
        let z = j as f64 * 0.1;
        let k = x.len() as u32;
        x.push(V3::new(0.0, 0.0, z));
        x.push(V3::new(0.5, 0.0, z));
        x.push(V3::new(0.0, 0.5, z));
        tris.push([k, k + 1, k + 2]);
    }
    (x, tris)
}

fn cylinder_shape() -> Wall {
    Wall::Cylinder {
        origin: V3::zeros(),
        dir: V3::z(),
        radius: R,
    }
}

/// A coarse cylinder mesh (z in [−3, 3]): nodes near it meet faces, the
/// edges between them and, beyond its end, its rim edges and vertices.
fn mesh_shape() -> Wall {
    let (x, tris) = shapes::cylinder(R, 6.0, 24, 5);
    Wall::mesh(x, tris)
}

fn geometry(shape: Wall, n_tris: usize) -> Arc<WallGeometry> {
    let (x, tris) = far_start(n_tris);
    let free = vec![true; x.len()];
    Arc::new(WallGeometry::new(
        shape,
        &x,
        &tris,
        &free,
        params(),
        0.5 * T,
    ))
}

/// Positions for `n` nodes with every node's least s in (0.05, 0.95) d̂
/// (drawn near the inside of the cylinder and, for the mesh, beyond its
/// rim), except the last, which is out of reach.
fn near_wall(geo: &WallGeometry, n: usize, seed: u64) -> Vec<V3> {
    let mut rng = Lcg(seed);
    let mut x = vec![];
    while x.len() < n - 1 {
        let i = x.len();
        let th = std::f64::consts::TAU * rng.next();
        let beyond = i % 3 == 2;
        let z = if beyond {
            3.0 + 0.3 * rng.next()
        } else {
            -2.5 + 5.0 * rng.next()
        };
        let r = R - 0.5 * T - 0.5 * rng.next();
        let p = V3::new(r * th.cos(), r * th.sin(), z);
        let (s, _) = geo.node_gap(i, &p, 1.0);
        if s > 0.05 * DHAT && s < 0.95 * DHAT {
            x.push(p);
        }
    }
    x.push(V3::new(1.0, 2.0, 0.5));
    x
}

fn energy(term: &WallBarrier, x: &[V3]) -> f64 {
    term.energy(x).expect("a potential")
}

fn force(term: &WallBarrier, x: &[V3]) -> Vec<V3> {
    let mut f = vec![V3::zeros(); x.len()];
    term.add_force(x, &mut f);
    f
}

fn tangent(term: &WallBarrier, x: &[V3]) -> DMatrix<f64> {
    crate::system::dense_tangent(term, x)
}

fn moved(x: &[V3], i: usize, c: usize, h: f64) -> Vec<V3> {
    let mut y = x.to_vec();
    y[i][c] += h;
    y
}

/// Largest |a − b| over the largest |b|.
fn rel(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()))
        / scale
}

fn check_derivatives(shape: Wall, seed: u64) {
    let n_tris = 6;
    let geo = geometry(shape, n_tris);
    let x = near_wall(&geo, 3 * n_tris, seed);
    let mut term = WallBarrier::new(geo);
    let n = x.len();
    // Force = −∂E/∂x.
    let h = 1e-6;
    let f = force(&term, &x);
    let mut fd = vec![];
    let mut an = vec![];
    for i in 0..n {
        for c in 0..3 {
            let d = (energy(&term, &moved(&x, i, c, h)) - energy(&term, &moved(&x, i, c, -h)))
                / (2.0 * h);
            fd.push(-d);
            an.push(f[i][c]);
        }
    }
    assert!(an.iter().any(|v| v.abs() > 0.0), "no force at all");
    assert_eq!(an[3 * (n - 1)..], [0.0; 3], "the far node feels the wall");
    let e = rel(&fd, &an);
    eprintln!("force vs −∂E/∂x: relative error {e:.2e}");
    assert!(e <= 1e-6, "force vs −∂E/∂x: relative error {e:.2e}");
    // Tangent = −∂f/∂x, exact and symmetric.
    let k = tangent(&term, &x);
    let mut fd = vec![];
    let mut an = vec![];
    for j in 0..3 * n {
        let (i, c) = (j / 3, j % 3);
        let fp = force(&term, &moved(&x, i, c, h));
        let fm = force(&term, &moved(&x, i, c, -h));
        for r in 0..3 * n {
            fd.push(-(fp[r / 3][r % 3] - fm[r / 3][r % 3]) / (2.0 * h));
            an.push(k[(r, j)]);
        }
    }
    let e = rel(&fd, &an);
    eprintln!("tangent vs −∂f/∂x: relative error {e:.2e}");
    assert!(e <= 1e-6, "tangent vs −∂f/∂x: relative error {e:.2e}");
    assert!((&k - k.transpose()).amax() <= 1e-12 * k.amax());
    // The projected tangent is PSD, and equals the exact one along ∇d.
    term.set_projected(true);
    let kp = tangent(&term, &x);
    let ev = kp.clone().symmetric_eigen().eigenvalues;
    let lo = ev.iter().fold(f64::INFINITY, |m, &v| m.min(v));
    assert!(
        lo >= -1e-12 * kp.amax(),
        "projected tangent: eigenvalue {lo:.3e}"
    );
    assert!(kp.amax() > 0.0);
}

#[test]
fn cylinder_forces_and_tangent_match_finite_differences() {
    check_derivatives(cylinder_shape(), 7);
}

#[test]
fn mesh_forces_and_tangent_match_finite_differences() {
    // Near faces, across the edges between faces and beyond the rim
    // (edge and vertex regions).
    for seed in [1, 2, 3] {
        check_derivatives(mesh_shape(), seed);
    }
    // The draw met every kind of closest feature.
    let geo = geometry(mesh_shape(), 6);
    let x = near_wall(&geo, 18, 1);
    let Wall::Mesh {
        x: wx, tris: wt, ..
    } = mesh_shape()
    else {
        unreachable!()
    };
    let mut kinds = [false; 3];
    for p in &x[..17] {
        for t in &wt {
            let v = t.map(|k| wx[k as usize]);
            let c = closest_point(p, &v[0], &v[1], &v[2]);
            if (c.point - p).norm() < 0.5 * T + DHAT {
                kinds[match c.feature {
                    Feature::Face => 0,
                    Feature::Edge(_) => 1,
                    Feature::Vertex(_) => 2,
                }] = true;
            }
        }
    }
    assert_eq!(kinds, [true; 3]);
}

#[test]
fn the_cylinder_exact_tangent_is_psd_and_its_own_projection() {
    let geo = geometry(cylinder_shape(), 4);
    let x = near_wall(&geo, 12, 11);
    let mut term = WallBarrier::new(geo);
    let k = tangent(&term, &x);
    term.set_projected(true);
    let kp = tangent(&term, &x);
    assert_eq!(k, kp);
}

/// Every step `max_step` allows keeps each node's s at or above KEEP × its
/// start; a step away from the wall is never cut.
fn check_steps(shape: Wall) {
    let geo = geometry(shape, 6);
    let x = near_wall(&geo, 18, 5);
    let term = WallBarrier::new(geo.clone());
    let mut rng = Lcg(99);
    let mut cut = 0;
    for _ in 0..40 {
        // Outward, 0.2 to 2 mm: through the wall unless cut.
        let dx: Vec<V3> = x
            .iter()
            .map(|p| {
                let out = V3::new(p.x, p.y, 0.0).normalize();
                let jitter = V3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
                (out + jitter * 0.6) * (0.2 + 1.8 * rng.next())
            })
            .collect();
        let t = term.max_step(&x, &dx);
        assert!(t > 0.0 && t <= 1.0);
        cut += (t < 1.0) as usize;
        for frac in [0.25, 0.5, 0.75, 1.0] {
            let y: Vec<V3> = x.iter().zip(&dx).map(|(p, d)| p + d * (t * frac)).collect();
            assert!(term.admissible(&y));
            for i in 0..x.len() {
                let s0 = geo.node_gap(i, &x[i], 3.0).0;
                let s = geo.node_gap(i, &y[i], 3.0).0;
                assert!(s >= KEEP * s0 * (1.0 - 1e-9), "node {i}: s {s} from {s0}");
            }
        }
    }
    assert!(cut >= 30, "only {cut} of 40 outward steps were cut");
    let inward: Vec<V3> = x.iter().map(|p| -V3::new(p.x, p.y, 0.0) * 0.05).collect();
    assert_eq!(term.max_step(&x, &inward), 1.0);
}

#[test]
fn steps_never_carry_a_node_through_the_cylinder() {
    check_steps(cylinder_shape());
}

#[test]
fn steps_never_carry_a_node_through_the_mesh() {
    check_steps(mesh_shape());
}

#[test]
fn nodes_starting_near_or_beyond_the_wall_get_narrowed_margins_or_none() {
    for shape in [cylinder_shape(), mesh_shape()] {
        // Three separate triangles: far, near the wall, across it (the
        // first two outvote the third on the mesh's lumen side).
        let mut x = vec![];
        let mut tris = vec![];
        for (j, r) in [7.0, R - 0.1, R + 0.1].into_iter().enumerate() {
            let k = x.len() as u32;
            // On a radial line at a face's middle: the mesh's distance is
            // the cylinder's there, up to the chord's sag.
            let th = std::f64::consts::PI / 24.0 + 0.0 * j as f64;
            let z = j as f64 * 0.9 - 0.9;
            let dir = V3::new(th.cos(), th.sin(), 0.0);
            x.push(dir * r + V3::new(0.0, 0.0, z));
            x.push(dir * (r - 0.01) + V3::new(0.0, 0.0, z + 0.3));
            x.push(dir * (r - 0.01) + V3::new(0.0, 0.0, z - 0.3));
            tris.push([k, k + 1, k + 2]);
        }
        let mut free = vec![true; x.len()];
        free[1] = false;
        let geo = WallGeometry::new(shape, &x, &tris, &free, params(), 0.5 * T);
        assert!(geo.acts()[0] && !geo.acts()[1] && geo.acts()[2]);
        assert_eq!(geo.offsets()[0], 0.5 * T);
        // 0.1 mm from the wall (about: a mesh sags by R(1 − cos 7.5°)):
        // offset and margin are half the start distance each.
        let d0 = geo.offsets()[3] * 2.0;
        assert!((d0 - 0.1).abs() < 0.1, "{d0}");
        assert!((geo.margins()[3] - 0.5 * d0).abs() < 1e-12);
        assert_eq!(geo.margins()[0], DHAT);
        assert!(!geo.acts()[6] && !geo.acts()[7] && !geo.acts()[8]);
        let term = WallBarrier::new(Arc::new(geo));
        // Admissible, and no node feels the wall at the start.
        assert!(term.admissible(&x));
        assert!(force(&term, &x).iter().all(|f| *f == V3::zeros()));
        assert!(term.contact_mask(&x).unwrap().iter().all(|&m| m == 0));
        // Moved a quarter of its start distance towards the wall: pushed
        // back, marked; at its offset: inadmissible.
        let out = x[3].xy().normalize();
        let mut y = x.clone();
        y[3] += V3::new(out.x, out.y, 0.0) * (0.25 * d0);
        let f = force(&term, &y);
        assert!(f[3].dot(&V3::new(out.x, out.y, 0.0)) < 0.0);
        let m = term.contact_mask(&y).unwrap();
        assert_eq!(m[3], WALL_BIT);
        assert_eq!(m[0] | m[6], 0);
        y[3] += V3::new(out.x, out.y, 0.0) * (0.3 * d0);
        assert!(!term.admissible(&y));
        let s = term.geometry().summary(&x);
        assert_eq!((s.exempt_nodes, s.started_within_margin), (3, 3));
    }
}

/// A clamped disc (radius 3 mm, neo-Hookean μ 0.1 MPa, 0.5 mm) facing the
/// wall of a 12 mm cylinder with its centre 0.4 mm inside R − t/2, blown
/// outward at 80 mmHg: its free bulge (Hencky, about 1.2 mm) would cross
/// the wall; with the wall barrier no node comes closer than t/2.
fn blow_patch_onto(wall: Option<Wall>) -> (Vec<V3>, bool, Vec<u8>) {
    let a = 3.0;
    let (uv, tris, rim) = shapes::disc(a, 0.3);
    let c = 11.2;
    // (u, v, w) → (c + w, u, v): a cyclic permutation keeps the
    // orientation, so the disc's +z normal (the load) points out, +x.
    let place = |p: &V3, w: f64| V3::new(c + w, p.x, p.y);
    let x0: Vec<V3> = uv.iter().map(|p| place(p, 0.0)).collect();
    let mut x: Vec<V3> = uv
        .iter()
        .map(|p| place(p, 0.05 * a * (1.0 - p.xy().norm_squared() / (a * a))))
        .collect();
    let fixed: Vec<[bool; 3]> = rim.iter().map(|&r| [r; 3]).collect();
    let refs = tris
        .iter()
        .map(|t| RefTri::new(t.map(|i| x0[i as usize]), T, None).unwrap())
        .collect();
    let p = 80.0 * MMHG_IN_MPA;
    let mut terms: Vec<Box<dyn Term>> = vec![];
    if let Some(shape) = wall {
        let free: Vec<bool> = rim.iter().map(|r| !r).collect();
        let prm = BarrierParams::from_pressure(DHAT, 2.0 * p);
        terms.push(Box::new(WallBarrier::new(Arc::new(WallGeometry::new(
            shape,
            &x,
            &tris,
            &free,
            prm,
            0.5 * T,
        )))));
    }
    let mut sys = System {
        tris: tris.clone(),
        refs,
        materials: vec![Box::new(NeoHookean { mu: 0.1 })],
        tri_material: vec![0; tris.len()],
        dofs: Dofs::new(&fixed),
        fixed,
        tri_pressure: vec![p; tris.len()],
        pressure_scale: 1.0,
        pressure_mode: PressureMode::Volume { origin: [0.0; 3] },
        terms,
        project: true,
        pressure_tangent: true,
        watch: None,
    };
    let mut opt = NewtonOptions::default();
    opt.stop.abs_n = 1e-9;
    opt.stop.rel = 1e-9;
    opt.max_step_mm = 0.2;
    let o = newton(&mut sys, &mut x, &opt);
    let mask = sys
        .terms
        .first()
        .and_then(|t| t.contact_mask(&x))
        .unwrap_or_default();
    eprintln!(
        "patch: converged {} in {} its ({}), residual {:.2e} N",
        o.converged, o.iterations, o.reason, o.residual_n
    );
    (x, o.converged, mask)
}

#[test]
fn a_patch_blown_outward_stays_off_the_cylinder_wall_only_with_the_term() {
    let big = 12.0;
    let r = |x: &[V3]| x.iter().map(|p| p.xy().norm()).fold(0.0, f64::max);
    let (free, ok, _) = blow_patch_onto(None);
    assert!(ok);
    assert!(r(&free) > big, "free bulge to r = {}", r(&free));
    let shape = Wall::Cylinder {
        origin: V3::zeros(),
        dir: V3::z(),
        radius: big,
    };
    let (held, ok, mask) = blow_patch_onto(Some(shape));
    assert!(ok);
    let rmax = r(&held);
    eprintln!(
        "cylinder wall: largest r {rmax:.4} mm (R − t/2 = {})",
        big - 0.5 * T
    );
    assert!(rmax < big - 0.5 * T, "{rmax}");
    // Pressed on: the centre rests within the margin, about d̂/2 off.
    assert!(rmax > big - 0.5 * T - DHAT, "{rmax}");
    assert!(mask.iter().filter(|&&m| m == WALL_BIT).count() > 10);
}

#[test]
fn a_patch_blown_outward_stays_off_the_mesh_wall() {
    let big = 12.0;
    let (wx, wt) = shapes::cylinder(big, 10.0, 240, 38);
    let shape = Wall::mesh(wx.clone(), wt.clone());
    let (held, ok, mask) = blow_patch_onto(Some(shape));
    assert!(ok);
    // Every node inside and at least t/2 from every wall triangle.
    let mut least = f64::INFINITY;
    for p in &held {
        assert!(p.xy().norm() < big);
        for t in &wt {
            let v = t.map(|k| wx[k as usize]);
            least = least.min((closest_point(p, &v[0], &v[1], &v[2]).point - p).norm());
        }
    }
    eprintln!("mesh wall: least distance {least:.4} mm");
    assert!(least > 0.5 * T && least < 0.5 * T + DHAT, "{least}");
    assert!(mask.iter().filter(|&&m| m == WALL_BIT).count() > 10);
}

/// The peer leaflet (seed 001's template sutured to a 12 mm cylinder,
/// h 1 mm, neo-Hookean with bending) under a reversed load of 80 mmHg:
/// pushed out of the lumen, through the wall without the term; with
/// `wall_contact` it lies on the cylinder through its suture line, no free
/// node beyond R − t/2.
#[test]
fn a_leaflet_pushed_outward_lies_on_the_cylinder_wall() {
    use crate::closure::close_on;
    use crate::config;
    use crate::peer::{R as RC, config_text_with, leaflet as ozaki_cylinder};
    let (l, axis) = ozaki_cylinder(1.0).unwrap();
    let text = config_text_with("neo-hookean", "newton", 120.0, true)
        .replace("contact = \"planes\"", "contact = \"none\"");
    let mut cfg = config::parse(&text).unwrap();
    cfg.pressure = -cfg.pressure;
    // Over the nodes that act: those not on or beyond the wall at the
    // start (after suturing, the row next to the suture line lies on the
    // wall's tangent planes, outside the cylinder).
    let acting = |x0: &[V3]| -> Vec<bool> {
        (0..x0.len())
            .map(|i| l.boundary[i] != 1 && x0[i].xy().norm() < RC)
            .collect()
    };
    let rmax_of = |x: &[V3], act: &[bool]| {
        (0..x.len())
            .filter(|&i| act[i])
            .map(|i| x[i].xy().norm())
            .fold(0.0, f64::max)
    };
    let wall = crate::model::sutured_wall(&l, &axis);
    let free = close_on(&l, &cfg, Some(axis), Some(&wall), None).unwrap();
    let act = acting(&free.suturing.as_ref().unwrap().x);
    let rmax = |x: &[V3]| rmax_of(x, &act);
    eprintln!(
        "reversed, no wall: converged {} in {} its, largest r {:.3} mm ({})",
        free.outcome.converged,
        free.outcome.iterations,
        rmax(&free.x),
        free.outcome.reason
    );
    assert!(rmax(&free.x) > RC, "{}", rmax(&free.x));
    cfg.wall_contact = true;
    let held = close_on(&l, &cfg, Some(axis), Some(&wall), free.suturing.as_ref()).unwrap();
    let w = held.wall_contact.as_ref().unwrap();
    eprintln!(
        "reversed, wall: converged {} in {} its, largest r {:.4} mm ({}); {w:?}",
        held.outcome.converged,
        held.outcome.iterations,
        rmax(&held.x),
        held.outcome.reason
    );
    assert!(held.outcome.converged, "{}", held.outcome.reason);
    // Every acting node keeps min(t/2, d₀/2) from the wall, d₀ its start
    // distance: t/2 wherever it started at least a thickness away.
    let x0 = &free.suturing.as_ref().unwrap().x;
    let mut full = 0.0f64;
    for i in (0..l.x.len()).filter(|&i| act[i]) {
        let d0 = RC - x0[i].xy().norm();
        let d = RC - held.x[i].xy().norm();
        assert!(d > (0.5 * T).min(0.5 * d0), "node {i}: {d} from {d0}");
        if d0 >= T {
            full = full.max(held.x[i].xy().norm());
        }
    }
    assert!(full < RC - 0.5 * T && full > RC - 0.5 * T - DHAT, "{full}");
    // The exempt row (started on the tangent planes, outside): how far out
    // it ends, for the record.
    let out = (0..l.x.len())
        .filter(|&i| l.boundary[i] != 1 && !act[i])
        .map(|i| held.x[i].xy().norm() - RC)
        .fold(f64::NEG_INFINITY, f64::max);
    eprintln!("exempt nodes end at most {out:.4} mm outside the wall");
    assert_eq!(w.wall, "cylinder");
    assert!(w.nodes_touching > 10, "{w:?}");
    assert!(w.min_distance_full_offset_mm.unwrap() >= 0.5 * T);
    let marked = held.contact.iter().filter(|&&m| m & WALL_BIT != 0).count();
    assert_eq!(marked, w.nodes_touching);
}
