//! The clinical preset and the options it switches on: arch and descending
//! aorta, closed native cusps, tilted annulus, 1.5 mm voxels.

use std::sync::OnceLock;

use super::*;
use coapt_geom::Vector3;
use lumen::LVOT_TURN_MM;
use shapes::Sdf;

const SEED: u64 = 3;

fn clinical() -> &'static Phantom {
    static P: OnceLock<Phantom> = OnceLock::new();
    P.get_or_init(|| generate(&PhantomParams::new(Preset::Clinical, SEED), &|_| {}).unwrap())
}

use super::tests::anatomy_of;

/// Trilinear CT value at a world point.
fn sample_ct(ct: &Volume<i16>, p: &Point3) -> f64 {
    let x = ct.world_to_index(p);
    let d = ct.dims();
    let base = x.map(f64::floor);
    let mut v = 0.0;
    for corner in 0..8 {
        let mut w = 1.0;
        let mut idx = [0usize; 3];
        for a in 0..3 {
            let up = (corner >> a) & 1 == 1;
            let f = x[a] - base[a];
            w *= if up { f } else { 1.0 - f };
            let i = base[a] as i64 + up as i64;
            idx[a] = i.clamp(0, d[a] as i64 - 1) as usize;
        }
        v += w * ct.as_slice()[ct.linear_index(idx[0], idx[1], idx[2])] as f64;
    }
    v
}

fn voxel_at<T: Copy>(v: &Volume<T>, p: &Point3) -> T {
    let x = v.world_to_index(p).map(|c| c.round() as usize);
    v.as_slice()[v.linear_index(x[0], x[1], x[2])]
}

fn plane_normal(p: &[Point3; 3]) -> Vector3 {
    (p[1] - p[0]).cross(&(p[2] - p[0])).normalize()
}

#[test]
fn clinical_grid_is_1_5_mm_and_holds_the_arch() {
    let ph = clinical();
    assert_eq!(ph.ct.spacing(), [1.5, 1.5, 1.5]);
    assert_eq!(ph.truth.spacing_mm, [1.5, 1.5, 1.5]);
    let an = anatomy_of(&PhantomParams::new(Preset::Clinical, SEED));
    let arch = an.arch.as_ref().expect("the clinical preset has an arch");
    let d = ph.ct.dims();
    let top_face = ph.ct.index_to_world([0.0, 0.0, d[2] as f64 - 0.5]).z;
    assert!(
        arch.z_top_lumen < top_face - 3.0,
        "arch top {} vs top face {top_face}",
        arch.z_top_lumen
    );
    // The arch's apex and the DA well below the root are bright blood.
    let blood = ph.truth.blood_hu;
    let top = Point3::new(
        0.5 * (arch_start_xy(&an)[0] + an.da.cx),
        0.5 * (arch_start_xy(&an)[1] + an.da.cy),
        arch.z_join + arch.height_mm,
    );
    let hu = sample_ct(&ph.ct, &top);
    assert!(hu > 0.8 * blood, "arch apex {top} at {hu} HU");
    // Above the arch lumen, tissue (not blood).
    let above = top + Vector3::z() * (0.5 * (arch.r_start_mm + arch.r_end_mm) + 4.0);
    assert!(sample_ct(&ph.ct, &above) < 0.5 * blood);
    let da_low = Point3::new(an.da.cx, an.da.cy, an.lumen.centreline.origin.z);
    let hu = sample_ct(&ph.ct, &da_low);
    assert!(hu > 0.8 * blood, "DA at the annulus level: {hu} HU");
    // The DA's calibre is 0.8 of the ascending aorta's.
    assert!((an.da.rx / an.lumen.profile.r_ascending_mm - 0.8).abs() < 1e-12);
}

fn arch_start_xy(an: &anatomy::Anatomy) -> [f64; 2] {
    let cl = &an.lumen.centreline;
    let p = cl
        .station(cl.s_at_z_vertical(an.arch.as_ref().unwrap().z_join))
        .point;
    [p.x, p.y]
}

#[test]
fn clinical_truth_mask_is_one_component_with_sections_where_the_truth_says() {
    let ph = clinical();
    let m = &ph.truth_mask;
    let [ni, nj, nk] = m.dims();
    let at = |i: usize, j: usize, k: usize| m.as_slice()[m.linear_index(i, j, k)] != 0;
    // 6-connected components by flood fill.
    let mut seen = vec![false; ni * nj * nk];
    let mut components = 0;
    for k in 0..nk {
        for j in 0..nj {
            for i in 0..ni {
                if !at(i, j, k) || seen[m.linear_index(i, j, k)] {
                    continue;
                }
                components += 1;
                let mut stack = vec![[i, j, k]];
                seen[m.linear_index(i, j, k)] = true;
                while let Some([a, b, c]) = stack.pop() {
                    let n = [
                        [a.wrapping_sub(1), b, c],
                        [a + 1, b, c],
                        [a, b.wrapping_sub(1), c],
                        [a, b + 1, c],
                        [a, b, c.wrapping_sub(1)],
                        [a, b, c + 1],
                    ];
                    for [x, y, z] in n {
                        if x < ni && y < nj && z < nk && at(x, y, z) {
                            let l = m.linear_index(x, y, z);
                            if !seen[l] {
                                seen[l] = true;
                                stack.push([x, y, z]);
                            }
                        }
                    }
                }
            }
        }
    }
    assert_eq!(components, 1);

    // Axial sections of the vertical ascending piece: centroid on the
    // centreline, area π r², nothing above the truth's end plane.
    let t = &ph.truth;
    let arch = t.arch.as_ref().unwrap();
    let an = anatomy_of(&PhantomParams::new(Preset::Clinical, SEED));
    let cl = &an.lumen.centreline;
    let z_arc_end = cl.station(cl.s2()).point.z;
    let mut checked = 0;
    for k in 0..nk {
        let z = m.index_to_world([0.0, 0.0, k as f64]).z;
        let (mut n, mut sx, mut sy) = (0usize, 0.0, 0.0);
        for j in 0..nj {
            for i in 0..ni {
                if at(i, j, k) {
                    let p = m.index_to_world([i as f64, j as f64, k as f64]);
                    n += 1;
                    sx += p.x;
                    sy += p.y;
                }
            }
        }
        if z > arch.truth_region_end_z_mm {
            assert_eq!(n, 0, "mask voxels at z {z} above the truth end plane");
            continue;
        }
        if z < z_arc_end + 2.0 || z > arch.truth_region_end_z_mm - 2.0 {
            continue;
        }
        let s = cl.s_at_z_vertical(z);
        let c = cl.station(s).point;
        let r = an.lumen.profile.eval(s, 0.0).r;
        let area = n as f64 * 1.5 * 1.5;
        let (cx, cy) = (sx / n as f64, sy / n as f64);
        assert!(
            (cx - c.x).hypot(cy - c.y) < 0.3,
            "z {z}: centroid off by {} mm",
            (cx - c.x).hypot(cy - c.y)
        );
        let exact = std::f64::consts::PI * r * r;
        assert!(
            (area - exact).abs() / exact < 0.04,
            "z {z}: area {area} vs {exact}"
        );
        checked += 1;
    }
    assert!(checked >= 5, "{checked} sections checked");
    // The slab right below the end plane is in the mask.
    assert!((arch.truth_region_end_z_mm - t.top_cap_z_mm).abs() < 1e-12);
}

#[test]
fn clinical_truth_surface_volume_and_mask_match_the_tilted_analytic_volume() {
    let ph = clinical();
    let t = &ph.truth;
    let m = &ph.truth_surface;
    let topo = m.topology();
    assert_eq!(topo.boundary_edges, 0);
    assert_eq!(topo.euler_characteristic, 2);
    let v = m.signed_volume();
    assert!(
        (v - t.lumen_volume_mm3).abs() / t.lumen_volume_mm3 < 0.005,
        "surface {v} vs analytic {}",
        t.lumen_volume_mm3
    );
    // 1.5 mm voxels: the mask's partial-volume error is a few per cent.
    assert!(
        (t.truth_mask_volume_mm3 - t.lumen_volume_mm3).abs() / t.lumen_volume_mm3 < 0.05,
        "mask {} vs analytic {}",
        t.truth_mask_volume_mm3,
        t.lumen_volume_mm3
    );
}

#[test]
fn clinical_landmarks_lie_on_the_truth_surface_within_a_voxel() {
    let ph = clinical();
    let m = &ph.truth_surface;
    for label in ["C1", "C2", "C3", "N1", "N2", "N3"] {
        let p = ph.landmarks.get(label).unwrap();
        let d = (0..m.triangles.len())
            .map(|t| {
                let [a, b, c] = m.corners(t);
                (coapt_geom::closest_point::closest_point(
                    &p.coords, &a.coords, &b.coords, &c.coords,
                )
                .point
                    - p.coords)
                    .norm()
            })
            .fold(f64::INFINITY, f64::min);
        assert!(d < 0.1, "{label} is {d} mm from the truth surface");
        // And on the mask's boundary: its 3×3×3 voxel neighbourhood holds
        // both mask and background voxels.
        let mask = &ph.truth_mask;
        let x = mask.world_to_index(&p).map(|c| c.round() as usize);
        let mut seen = [false; 2];
        for k in x[2] - 1..=x[2] + 1 {
            for j in x[1] - 1..=x[1] + 1 {
                for i in x[0] - 1..=x[0] + 1 {
                    seen[mask.as_slice()[mask.linear_index(i, j, k)] as usize] = true;
                }
            }
        }
        assert!(seen[0] && seen[1], "{label} is not on the mask boundary");
    }
}

#[test]
fn annulus_tilt_is_the_requested_angle_between_nadir_and_commissure_planes() {
    for deg in [0.0, 10.0, 20.0, 35.0] {
        let mut p = PhantomParams::new(Preset::Sample, 5);
        p.annulus_tilt_rad = f64::to_radians(deg);
        let ph = generate(&p, &|_| {}).unwrap();
        let lm = |l: &str| ph.landmarks.get(l).unwrap();
        let c = [lm("C1"), lm("C2"), lm("C3")];
        let n = [lm("N1"), lm("N2"), lm("N3")];
        let angle = |a: Vector3, b: Vector3| a.dot(&b).abs().min(1.0).acos().to_degrees();
        let nc = plane_normal(&c);
        let measured = angle(plane_normal(&n), nc);
        assert!(
            (measured - deg).abs() < 0.5,
            "landmarks: {measured} vs {deg}"
        );
        // Independently, from the truth surface's VAJ cap (region 1): a plane
        // fitted to its vertices has the same tilt.
        let m = &ph.truth_surface;
        let region = match &m.cell_data.get("region").unwrap().values {
            coapt_geom::DataValues::I32(v) => v.clone(),
            _ => panic!("region is Int32"),
        };
        let mut pts = Vec::new();
        for (t, tri) in m.triangles.iter().enumerate() {
            if region[t] == 1 {
                pts.extend(tri.iter().map(|&v| m.vertices[v as usize]));
            }
        }
        let centre = pts.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / pts.len() as f64;
        let mut cov = coapt_geom::Matrix3::zeros();
        for p in &pts {
            let d = p.coords - centre;
            cov += d * d.transpose();
        }
        let eig = cov.symmetric_eigen();
        let (imin, _) =
            eig.eigenvalues
                .iter()
                .enumerate()
                .fold(
                    (0, f64::INFINITY),
                    |b, (i, &v)| if v < b.1 { (i, v) } else { b },
                );
        let cap_normal: Vector3 = eig.eigenvectors.column(imin).into();
        let measured = angle(cap_normal, nc);
        assert!((measured - deg).abs() < 0.5, "VAJ cap: {measured} vs {deg}");
        // The mask starts at that plane: no voxel below it.
        let normal = plane_normal(&n);
        let normal = if normal.dot(&nc) < 0.0 {
            -normal
        } else {
            normal
        };
        let mask = &ph.truth_mask;
        let [ni, nj, nk] = mask.dims();
        for k in 0..nk {
            for j in 0..nj {
                for i in 0..ni {
                    if mask.as_slice()[mask.linear_index(i, j, k)] != 0 {
                        let q = mask.index_to_world([i as f64, j as f64, k as f64]);
                        assert!(
                            (q - n[0]).dot(&normal) > -1e-9,
                            "mask voxel below the nadir plane"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn tilted_lvot_stands_square_to_the_annulus_and_joins_the_root_c1() {
    let an = anatomy_of(&PhantomParams::new(Preset::Clinical, SEED));
    let lumen = &an.lumen;
    let p = &lumen.profile;
    assert!(p.annulus_tilt_rad > 0.3);
    let (sa, ca) = p.annulus_tilt_rad.sin_cos();
    let st = lumen.centreline.station(0.0);
    let low = st.e1 * p.annulus_low_angle_rad.cos() + st.e2 * p.annulus_low_angle_rad.sin();
    let normal = lumen.annulus_normal();
    for k in 0..12 {
        let th = -3.0 + 0.53 * k as f64;
        let s_plane = p.annulus_s(th).0;
        // C¹ where the LVOT meets the root at the plane.
        let (below, above) = (p.eval(s_plane - 1e-7, th), p.eval(s_plane + 1e-7, th));
        assert!((below.r - above.r).abs() < 1e-6, "r jumps at θ {th}");
        assert!(
            (below.dr_ds - above.dr_ds).abs() < 1e-5,
            "dr/ds jumps at θ {th}"
        );
        assert!((below.dr_dtheta - above.dr_dtheta).abs() < 1e-5);
        for depth in [0.5, 3.0, 8.0, 14.0] {
            let s = s_plane - depth;
            // The derivatives are those of r.
            let r = p.eval(s, th);
            let e = 1e-6;
            let ds = (p.eval(s + e, th).r - p.eval(s - e, th).r) / (2.0 * e);
            let dt = (p.eval(s, th + e).r - p.eval(s, th - e).r) / (2.0 * e);
            assert!((ds - r.dr_ds).abs() < 1e-6, "dr/ds {ds} vs {}", r.dr_ds);
            assert!(
                (dt - r.dr_dtheta).abs() < 1e-6,
                "dr/dθ {dt} vs {}",
                r.dr_dtheta
            );
        }
        // Past the turn the wall is a cylinder along the annulus plane's
        // normal: a wall point moved down that normal stays on the wall.
        let w = lumen.wall_point(s_plane - 10.0, th);
        let moved = w - normal * 4.0;
        let l = lumen.local(&moved);
        let r = p.eval(l.station.s, l.theta).r;
        assert!((l.rho - r).abs() < 1e-8, "off the wall by {}", l.rho - r);
        // And the sweep direction is the normal, not the valve axis.
        assert!((normal - (st.tangent * ca + low * sa)).norm() < 1e-12);
    }
    // The LVOT's end lies shifted off the valve axis, inside the LV.
    let end = lumen.lvot_centre(lumen.lvot_length_mm);
    let off = (end - st.point).cross(&st.tangent).norm();
    let expected = p.annulus_tilt_rad.tan() * (lumen.lvot_length_mm - 0.5 * LVOT_TURN_MM);
    assert!(
        (off - expected).abs() < 1e-9,
        "LVOT end {off} mm off the axis"
    );
    assert!(an.lv.eval(&end).0 < 0.0);
}

#[test]
fn native_cusps_darken_the_root_and_stay_in_the_truth_mask() {
    let mut with = PhantomParams::new(Preset::Clinical, SEED);
    with.noise_hu = 0.0;
    let mut without = with.clone();
    without.native_cusps = false;
    let a = generate(&with, &|_| {}).unwrap();
    let b = generate(&without, &|_| {}).unwrap();
    let an = anatomy_of(&with);
    let cusps = an.cusps.unwrap();
    let prof = &an.lumen.profile;
    let cl = &an.lumen.centreline;
    let blood = with.blood_hu;
    // Across each coaptation sheet, halfway out and mid coaptation height.
    let h = 0.5 * (cusps.h_centre_mm + cusps.h_free_mm);
    let st = cl.station(h);
    for &cj in &prof.commissure_angles_rad {
        let u = st.e1 * cj.cos() + st.e2 * cj.sin();
        let perp = st.tangent.cross(&u);
        let centre = st.point + u * (0.5 * prof.eval(h, cj).r);
        let line = |ph: &Phantom| -> Vec<(f64, Point3)> {
            (-8..=8)
                .map(|i| {
                    let q = centre + perp * (0.5 * i as f64);
                    (sample_ct(&ph.ct, &q), q)
                })
                .collect()
        };
        let (la, lb) = (line(&a), line(&b));
        let (min_a, q_min) =
            la.iter().fold(
                (f64::INFINITY, centre),
                |m, &(v, q)| {
                    if v < m.0 { (v, q) } else { m }
                },
            );
        let min_b = lb.iter().map(|x| x.0).fold(f64::INFINITY, f64::min);
        assert!(
            min_a < blood - 120.0,
            "commissure {cj}: cusp dip only to {min_a} HU (blood {blood})"
        );
        assert!(
            min_b > blood - 60.0,
            "without cusps the line dips to {min_b}"
        );
        assert!(la[0].0 > blood - 60.0 && la[16].0 > blood - 60.0);
        assert_eq!(voxel_at(&a.truth_mask, &q_min), 1, "cusp not in the mask");
    }
    // The mask does not depend on the cusps at all.
    assert_eq!(a.truth_mask.as_slice(), b.truth_mask.as_slice());
}

#[test]
fn clinical_blood_and_noise_are_the_real_ct_values() {
    let ph = clinical();
    assert_eq!(ph.truth.blood_hu, CLINICAL_BLOOD_HU);
    assert_eq!(ph.truth.noise_hu, CLINICAL_NOISE_HU);
    // Measured like the real CT: 5×5×5 cubes at the ascending lumen centre.
    let an = anatomy_of(&PhantomParams::new(Preset::Clinical, SEED));
    let cl = &an.lumen.centreline;
    let arch = an.arch.as_ref().unwrap();
    let mut stds = Vec::new();
    for dz in [12.0, 18.0, 24.0] {
        let z = arch.z_truth_end - dz;
        let c = cl.station(cl.s_at_z_vertical(z)).point;
        let x = ph.ct.world_to_index(&c).map(|v| v.round() as usize);
        let mut v = Vec::new();
        for k in x[2] - 2..=x[2] + 2 {
            for j in x[1] - 2..=x[1] + 2 {
                for i in x[0] - 2..=x[0] + 2 {
                    v.push(ph.ct.as_slice()[ph.ct.linear_index(i, j, k)] as f64);
                }
            }
        }
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let s = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
        assert!(
            (m - CLINICAL_BLOOD_HU).abs() < 0.06 * CLINICAL_BLOOD_HU,
            "mean {m}"
        );
        stds.push(s);
    }
    let s = stds.iter().sum::<f64>() / 3.0;
    assert!((s - CLINICAL_NOISE_HU).abs() < 6.0, "noise {s} HU");
}

#[test]
fn arch_needs_room_and_old_presets_have_none() {
    let p = PhantomParams::new(Preset::Sample, 1);
    assert!(!p.arch && !p.native_cusps && p.annulus_tilt_rad == 0.0);
    let ph = generate(&p, &|_| {}).unwrap();
    assert!(ph.truth.arch.is_none() && ph.truth.native_cusps.is_none());
    // The sample's 112 mm of z cannot hold root, ascending aorta and arch.
    let mut p = PhantomParams::new(Preset::Sample, 1);
    p.arch = true;
    let e = generate(&p, &|_| {}).unwrap_err().to_string();
    assert!(e.contains("arch") && e.contains("field of view"), "{e}");
    let mut p = PhantomParams::new(Preset::Clinical, 1);
    p.annulus_tilt_rad = 40f64.to_radians();
    assert!(
        p.validate()
            .unwrap_err()
            .to_string()
            .contains("annulus tilt")
    );
}
