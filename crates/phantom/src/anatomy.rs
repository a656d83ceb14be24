//! Random anatomical parameters from the seed, and the placement of every
//! structure in world LPS (x → left, y → posterior, z → superior).
//!
//! All random numbers are drawn up front in a fixed order, so a flag such as
//! `calcium` or a different preset never changes the anatomy of a seed.

use std::f64::consts::PI;

use super::centreline::Centreline;
use super::lumen::{Lumen, RadiusProfile};
use super::shapes::{Ellipsoid, Sdf, Tube, ZCylinder, basis_with_axis};
use coapt_base::rng::SplitMix64;
use coapt_base::{Error, Result};
use coapt_geom::{Matrix3, Point3, Vector3};

pub use coapt_geom::landmarks::SINUS_NAMES;

/// Nominal annulus centre in world LPS (mm): a typical scanner position of
/// the aortic valve, deliberately far from the origin.
const NOMINAL_ANNULUS: [f64; 3] = [-15.0, 20.0, -160.0];
/// Thickness of the LV myocardium around the cavity.
const MYOCARDIUM_MM: f64 = 10.0;
/// LV cavity semi-axes (short, short, long) in mm.
const LV_SEMI: [f64; 3] = [22.0, 22.0, 40.0];
/// Highest the LV cavity may reach along the valve axis. Further below the
/// VAJ than the LV–LVOT blend width, so the blend cannot move the lumen wall
/// at or above the VAJ (where it is the truth).
const LV_MAX_HEIGHT_MM: f64 = -(LV_BLEND_MM + 2.0);
/// Smooth-union blend width between LV and LVOT.
pub const LV_BLEND_MM: f64 = 6.0;
/// Left-atrium semi-axes (x, y, z) before any shrinking.
const LA_SEMI: [f64; 3] = [22.0, 13.0, 17.0];
/// Minimal clearance kept between structures that are not meant to touch.
const CLEARANCE_MM: f64 = 3.0;
/// Default DA position relative to the annulus centre (x left, y posterior).
const DA_OFFSET: [f64; 2] = [24.0, 44.0];
/// Sternum and body-outline centres relative to the annulus (x L, y P).
const STERNUM_FROM_ANNULUS: [f64; 2] = [8.0, -62.0];
const BODY_FROM_ANNULUS: [f64; 2] = [5.0, 35.0];
/// Least distance kept between the DA and the aortic lumen, beyond radii.
const MIN_DA_SEPARATION_MM: f64 = 8.0;
/// Margin kept between the must-see structures and the in-plane FOV edge.
const FOV_MARGIN_MM: f64 = 4.0;
/// Vertebral body radius and cranio-caudal period (body + disc).
const VERTEBRA_RADIUS_MM: f64 = 17.0;
const VERTEBRA_PERIOD_MM: f64 = 25.0;
pub const DISC_MM: f64 = 5.0;

/// The arch starts this far above the top of the truth region (ascending).
const ARCH_JOIN_ABOVE_TRUTH_MM: f64 = 8.0;
/// Height of the arch half-ellipse over half its span.
const ARCH_HEIGHT_RATIO: f64 = 0.9;
/// Segments of the arch tube.
const ARCH_SEGMENTS: usize = 48;
/// Descending-aorta calibre relative to the ascending (arch mode).
const DA_TO_ASCENDING: f64 = 0.8;
/// Field of view kept above the arch lumen.
const ARCH_TOP_MARGIN_MM: f64 = 6.0;
/// Native cusps: thickness, free edge below the commissures, centre height
/// as a fraction of the commissure height.
const CUSP_THICKNESS_MM: f64 = 0.8;
const CUSP_FREE_EDGE_BELOW_COMM_MM: f64 = 3.0;
const CUSP_CENTRE_FRACTION: f64 = 0.45;
const CUSP_BELLY_POWER: f64 = 1.5;
/// The annulus plane's lowest point lies this far past the left-coronary
/// sinus centre (the pattern of the real CT's nadir heights: N2 lowest, N3
/// midway, N1 highest).
const ANNULUS_LOW_PAST_SINUS2_DEG: f64 = 30.0;

/// A coronary artery: tube, ostium on the sinus wall, proximal radius.
#[derive(Debug, Clone)]
pub struct Coronary {
    pub name: &'static str,
    pub sinus: usize,
    pub tubes: Vec<Tube>,
    pub ostium: Point3,
    pub radius_mm: f64,
    pub ostium_height_mm: f64,
}

/// Options that add structures to the anatomy; all off reproduces the
/// original phantom exactly (no extra random draws from the main stream).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Extras {
    /// Arch and descending aorta joined in the field of view.
    pub arch: bool,
    /// Closed native cusps inside the root.
    pub native_cusps: bool,
    /// Tilt of the annulus (nadir) plane to the commissure plane.
    pub annulus_tilt_rad: f64,
    /// Turn of the root about its axis away from the usual orientation
    /// (the right-coronary sinus facing anterior), counter-clockwise.
    pub root_rotation_rad: f64,
}

/// The aortic arch: a tapering tube along a half-ellipse in the vertical
/// plane through the ascending and descending aortas, both vertical there.
#[derive(Debug, Clone)]
pub struct Arch {
    pub tube: Tube,
    /// Where the ascending lumen hands over to the arch (and the DA ends).
    pub z_join: f64,
    /// The truth region ends at this plane, below the join.
    pub z_truth_end: f64,
    /// Highest point of the arch lumen.
    pub z_top_lumen: f64,
    pub span_mm: f64,
    pub height_mm: f64,
    pub r_start_mm: f64,
    pub r_end_mm: f64,
}

/// Closed native cusps: bellies from the hinge line to a central
/// coaptation point, and three radial coaptation sheets (the "Y").
#[derive(Debug, Clone, Copy)]
pub struct Cusps {
    /// Height (valve frame) of the cusps' lowest common point on the axis.
    pub h_centre_mm: f64,
    /// Free edges (top of the coaptation sheets).
    pub h_free_mm: f64,
    /// Exponent of the belly profile along ρ (a bowl).
    pub belly_power: f64,
    pub thickness_mm: f64,
}

#[derive(Debug, Clone)]
pub struct Anatomy {
    pub tilt_azimuth_rad: f64,
    pub arch: Option<Arch>,
    pub cusps: Option<Cusps>,
    pub lumen: Lumen,
    pub h_comm_mm: f64,
    pub lv: Ellipsoid,
    pub myocardium: Ellipsoid,
    pub coronaries: Vec<Coronary>,
    pub pa: Vec<Tube>,
    pub pa_radius_mm: f64,
    pub la: Ellipsoid,
    pub da: ZCylinder,
    pub spine_centre: [f64; 2],
    pub vertebra_radius_mm: f64,
    pub vertebra_period_mm: f64,
    pub vertebra_phase_mm: f64,
    pub cortical_hu: f64,
    pub cancellous_hu: f64,
    pub sternum_centre: [f64; 2],
    pub body_centre: [f64; 2],
    pub calcium: Vec<Ellipsoid>,
    /// Low-frequency blood field: wave vectors (rad/mm) and phases.
    pub blood_waves: Vec<(Vector3, f64)>,
}

/// Where the field of view must reach (world mm), for grid placement.
#[derive(Debug, Clone, Copy)]
pub struct FovNeeds {
    pub z_bottom: f64,
    pub z_top: f64,
}

/// Must-see extent in x and y (world mm): root and LVOT, the ascending
/// aorta where it leaves through the top, the DA (with margins).
pub fn xy_extent(
    cl: &Centreline,
    profile: &RadiusProfile,
    lvot_len: f64,
    r_max: f64,
    z_top: f64,
    da_xy: [f64; 2],
    da_r: f64,
) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    let mut include = |x: f64, y: f64, r: f64| {
        lo[0] = lo[0].min(x - r);
        lo[1] = lo[1].min(y - r);
        hi[0] = hi[0].max(x + r);
        hi[1] = hi[1].max(y + r);
    };
    const STEPS: usize = 20;
    for i in 0..=STEPS {
        let s = -lvot_len + (profile.h_stj_mm + lvot_len) * i as f64 / STEPS as f64;
        let p = cl.station(s).point;
        include(p.x, p.y, r_max);
    }
    let s_top = s_at_z(cl, z_top);
    let top = cl.station(s_top).point;
    include(top.x, top.y, profile.eval(s_top, 0.0).r + FOV_MARGIN_MM);
    include(da_xy[0], da_xy[1], da_r + FOV_MARGIN_MM);
    (lo, hi)
}

/// Random numbers for one seed, drawn in a fixed order.
struct Draws {
    r_a: f64,
    ellipticity: f64,
    ellipse_angle: f64,
    lvot_len: f64,
    h_stj: f64,
    comm_below_stj: f64,
    stj_ratio: f64,
    asc_ratio: f64,
    stj_transition: f64,
    asc_var: f64,
    asc_wavelength: f64,
    comm_dev: [f64; 2],
    sinus_ratio: [f64; 3],
    s1_above_stj: f64,
    arc_radius: f64,
    azimuth_jitter: f64,
    e1_jitter: f64,
    origin_jitter: [f64; 3],
    apex_jitter: [f64; 2],
    ostium_frac: [f64; 2],
    ostium_angle: [f64; 2],
    coronary_radius: [f64; 2],
    pa_radius: f64,
    pa_gap: f64,
    la_gap: f64,
    da_radius: f64,
    da_offset: [f64; 2],
    vertebra_phase: f64,
    cortical_hu: f64,
    cancellous_hu: f64,
    calcium: Vec<(usize, f64, f64, f64, [f64; 3])>,
    blood_waves: Vec<(Vector3, f64)>,
}

impl Draws {
    fn new(seed: u64) -> Self {
        let mut g = SplitMix64::new(seed ^ 0x00A0_A71C_2007);
        let deg = PI / 180.0;
        let d1 = g.range(-8.0, 8.0);
        // Third spacing is 360° minus the other two: keep it within ±8° too.
        let d2 = g.range((-8.0 - d1).max(-8.0), (8.0 - d1).min(8.0));
        let mut calcium = Vec::new();
        for k in 0..3 {
            let n = 1 + (g.uniform() * 2.0) as usize;
            for _ in 0..n {
                calcium.push((
                    k,
                    g.range(0.3, 1.5),
                    g.range(-25.0, 25.0) * deg,
                    g.range(0.2, 0.6),
                    [g.range(0.5, 1.5), g.range(0.5, 1.5), g.range(0.5, 1.2)],
                ));
            }
        }
        let mut blood_waves = Vec::new();
        for _ in 0..3 {
            let dir = Vector3::new(g.normal(), g.normal(), g.normal()).normalize();
            let wavelength = g.range(80.0, 160.0);
            blood_waves.push((dir * (2.0 * PI / wavelength), g.range(0.0, 2.0 * PI)));
        }
        Draws {
            r_a: g.range(11.0, 13.0),
            ellipticity: g.range(0.04, 0.06),
            ellipse_angle: g.range(0.0, PI),
            lvot_len: g.range(15.0, 20.0),
            h_stj: g.range(17.0, 21.0),
            comm_below_stj: g.range(1.0, 2.0),
            stj_ratio: g.range(1.05, 1.2),
            asc_ratio: g.range(1.0, 1.15),
            stj_transition: g.range(8.0, 12.0),
            asc_var: g.range(-0.04, 0.04),
            asc_wavelength: g.range(50.0, 80.0),
            comm_dev: [d1 * deg, d2 * deg],
            sinus_ratio: [g.range(1.3, 1.45), g.range(1.3, 1.45), g.range(1.3, 1.45)],
            s1_above_stj: g.range(3.0, 6.0),
            arc_radius: g.range(55.0, 80.0),
            azimuth_jitter: g.range(-10.0, 10.0) * deg,
            e1_jitter: g.range(-10.0, 10.0) * deg,
            origin_jitter: [g.range(-5.0, 5.0), g.range(-5.0, 5.0), g.range(-5.0, 5.0)],
            apex_jitter: [g.range(-0.1, 0.1), g.range(-0.1, 0.1)],
            ostium_frac: [g.range(0.4, 0.6), g.range(0.4, 0.6)],
            ostium_angle: [g.range(-15.0, 15.0) * deg, g.range(-15.0, 15.0) * deg],
            coronary_radius: [g.range(1.3, 1.8), g.range(1.5, 2.0)],
            pa_radius: g.range(11.0, 14.0),
            pa_gap: g.range(1.8, 2.6),
            la_gap: g.range(3.3, 4.6),
            da_radius: g.range(10.0, 12.0),
            da_offset: [g.range(-3.0, 3.0), g.range(-3.0, 3.0)],
            vertebra_phase: g.range(0.0, VERTEBRA_PERIOD_MM),
            cortical_hu: g.range(700.0, 1000.0),
            cancellous_hu: g.range(250.0, 320.0),
            calcium,
            blood_waves,
        }
    }
}

/// Rotate `v` (⟂ `axis`) about the unit `axis` by `angle`.
fn rotate_about(v: &Vector3, axis: &Vector3, angle: f64) -> Vector3 {
    v * angle.cos() + axis.cross(v) * angle.sin() + axis * (axis.dot(v) * (1.0 - angle.cos()))
}

/// The root's radius profile for these draws: annulus, sinuses scaled to
/// their drawn peak radii, STJ and ascending aorta; the annulus tilted
/// when asked.
fn radius_profile(d: &Draws, extras: &Extras) -> RadiusProfile {
    let deg = PI / 180.0;
    let r_a = d.r_a;
    let r_stj = r_a * d.stj_ratio;
    let gaps = [120.0 * deg + d.comm_dev[0], 120.0 * deg + d.comm_dev[1]];
    let comm = [0.0, gaps[0], gaps[0] + gaps[1]];
    let mut profile = RadiusProfile {
        r_annulus_mm: r_a,
        lvot_ellipticity: d.ellipticity,
        lvot_major_angle_rad: d.ellipse_angle,
        lvot_fade_mm: 8.0,
        h_stj_mm: d.h_stj,
        r_stj_mm: r_stj,
        stj_transition_mm: d.stj_transition,
        r_ascending_mm: r_stj * d.asc_ratio,
        ascending_variation: d.asc_var,
        ascending_wavelength_mm: d.asc_wavelength,
        commissure_angles_rad: comm,
        sinus_amplitude: [0.0; 3],
        annulus_tilt_rad: 0.0,
        annulus_low_angle_rad: 0.0,
    };
    let base_peak = profile.base_root(0.4 * d.h_stj).0;
    for k in 0..3 {
        profile.sinus_amplitude[k] = d.sinus_ratio[k] * r_a / base_peak - 1.0;
    }
    if extras.annulus_tilt_rad != 0.0 {
        profile.annulus_tilt_rad = extras.annulus_tilt_rad;
        profile.annulus_low_angle_rad = profile.sinus_centre(1) + ANNULUS_LOW_PAST_SINUS2_DEG * deg;
    }
    profile
}

/// Where the root's centreline and the descending aorta sit in a field of
/// view they fit.
struct Fit {
    centreline: Centreline,
    needs: FovNeeds,
    da_xy: [f64; 2],
    da_radius: f64,
    /// Top of the ascending lumen's vertical piece (world z, mm).
    z_asc_top: f64,
}

/// Shrink the centreline's arc until the z-range the root needs fits the
/// field of view, then bring the descending aorta closer until the xy
/// extent fits as well; refuse when they cannot.
fn fit_field_of_view(
    d: &Draws,
    extras: &Extras,
    profile: &RadiusProfile,
    (origin, axis, e1): (Point3, Vector3, Vector3),
    fov: [f64; 3],
    tilt_rad: f64,
) -> Result<Fit> {
    let fov_z_mm = fov[2];
    let s1 = d.h_stj + d.s1_above_stj;
    let r_max = profile.r_max_bound();
    let lvot_len = d.lvot_len;
    let mut arc_radius = d.arc_radius;
    let min_arc = (2.0 * r_max).max(35.0);
    let mut da_xy = [
        origin.x + DA_OFFSET[0] + d.da_offset[0],
        origin.y + DA_OFFSET[1] + d.da_offset[1],
    ];
    let da_radius = if extras.arch {
        DA_TO_ASCENDING * profile.r_ascending_mm
    } else {
        d.da_radius
    };
    // Top of the ascending lumen's vertical piece: the old field-of-view
    // top, or with an arch, the join (the arch is inside the xy box of
    // the ascending aorta and the DA, so it needs no xy room of its own).
    let asc_top = |needs: &FovNeeds| {
        if extras.arch {
            needs.z_top + ARCH_JOIN_ABOVE_TRUTH_MM
        } else {
            needs.z_top
        }
    };
    let xy_fits = |cl: &Centreline, needs: &FovNeeds, da_xy: [f64; 2]| {
        let (lo, hi) = xy_extent(
            cl,
            &profile,
            lvot_len,
            r_max,
            asc_top(needs),
            da_xy,
            da_radius,
        );
        // Half a millimetre of slack so the grid placement, which uses the
        // actual top face, cannot disagree by rounding.
        [hi[0] - lo[0] - fov[0] + 0.5, hi[1] - lo[1] - fov[1] + 0.5]
    };
    // With an arch the field of view must reach over it; its height
    // depends on the span, so estimate it from the DA's start position.
    let total_z = |cl: &Centreline, needs: &FovNeeds, da_xy: [f64; 2]| {
        let top = if extras.arch {
            arch_geometry(cl, &profile, asc_top(needs), da_xy, da_radius).z_top_lumen
                + ARCH_TOP_MARGIN_MM
        } else {
            needs.z_top
        };
        top - needs.z_bottom
    };
    let (centreline, needs) = loop {
        let cl = Centreline::new(origin, axis, e1, s1, arc_radius);
        let needs = z_needs(&cl, &profile, lvot_len);
        let excess = xy_fits(&cl, &needs, da_xy);
        let fits_xy = excess[0] <= 0.0 && excess[1] <= 0.0;
        let need_z = total_z(&cl, &needs, da_xy);
        if (need_z <= fov_z_mm && fits_xy) || arc_radius <= min_arc {
            if need_z > fov_z_mm {
                return Err(Error::value(format!(
                    "the aortic root{} needs {:.0} mm of z field of view at tilt {:.0}°, the grid has {:.0} mm",
                    if extras.arch { " and arch" } else { "" },
                    need_z,
                    tilt_rad.to_degrees(),
                    fov_z_mm
                )));
            }
            break (cl, needs);
        }
        arc_radius = (arc_radius - 2.0).max(min_arc);
    };
    // Still too wide (steep tilt, small grid): bring the DA closer to the
    // root, as long as the two stay well apart.
    for _ in 0..20 {
        let excess = xy_fits(&centreline, &needs, da_xy);
        if excess[0] <= 0.0 && excess[1] <= 0.0 {
            break;
        }
        for a in 0..2 {
            if excess[a] > 0.0 {
                da_xy[a] -= excess[a] + 0.5;
            }
        }
    }
    let excess = xy_fits(&centreline, &needs, da_xy);
    let z_asc_top = asc_top(&needs);
    let top = centreline.station(s_at_z(&centreline, z_asc_top)).point;
    let root_to_da = (da_xy[0] - origin.x).hypot(da_xy[1] - origin.y);
    let top_to_da = (da_xy[0] - top.x).hypot(da_xy[1] - top.y);
    if excess[0] > 0.0
        || excess[1] > 0.0
        || root_to_da < r_max + da_radius + MIN_DA_SEPARATION_MM
        || top_to_da < profile.r_ascending_mm * 1.1 + da_radius + MIN_DA_SEPARATION_MM
        || (extras.arch && total_z(&centreline, &needs, da_xy) > fov_z_mm)
    {
        return Err(Error::value(format!(
            "aortic root and descending aorta do not fit a {:.0}×{:.0} mm field of view at tilt {:.0}°: use a larger preset or spacing",
            fov[0],
            fov[1],
            tilt_rad.to_degrees()
        )));
    }
    Ok(Fit {
        centreline,
        needs,
        da_xy,
        da_radius,
        z_asc_top,
    })
}

/// The left ventricle, an ellipsoid whose apex points anterior-left-
/// inferior and whose top stays below the root, and the myocardium
/// around it.
fn left_ventricle(
    lumen: &Lumen,
    d: &Draws,
    origin: &Point3,
    axis: &Vector3,
) -> (Ellipsoid, Ellipsoid) {
    let lvot_len = lumen.lvot_length_mm;
    // Apex: anterior-left-inferior.
    let apex_dir =
        Vector3::new(0.5 + d.apex_jitter[0], -0.45 + d.apex_jitter[1], -0.75).normalize();
    let rot = basis_with_axis(&apex_dir);
    let semi = Vector3::new(LV_SEMI[0], LV_SEMI[1], LV_SEMI[2]);
    let lvot_end = lumen.lvot_centre(lvot_len);
    // The LVOT end sits 70 % of the long semi-axis from the centre.
    let mut centre = lvot_end + apex_dir * (0.7 * LV_SEMI[2]);
    let reach = |c: &Point3| {
        let m = rot * Matrix3::from_diagonal(&semi.component_mul(&semi)) * rot.transpose();
        (c - origin).dot(axis) + (axis.dot(&(m * axis))).sqrt()
    };
    let top = reach(&centre);
    if top > LV_MAX_HEIGHT_MM {
        centre -= axis * (top - LV_MAX_HEIGHT_MM);
    }
    let lv = Ellipsoid { centre, rot, semi };
    let myocardium = Ellipsoid {
        centre,
        rot,
        semi: semi.add_scalar(MYOCARDIUM_MM),
    };
    (lv, myocardium)
}

impl Anatomy {
    /// Build the anatomy for `seed` and `tilt`; `fit` reports the z-range the
    /// field of view must cover and returns whether it fits, so the arc radius
    /// can shrink for a short field of view.
    pub fn new(
        seed: u64,
        tilt_rad: f64,
        fov: [f64; 3],
        extras: Extras,
    ) -> Result<(Self, FovNeeds)> {
        let d = Draws::new(seed);
        let deg = PI / 180.0;

        // --- Valve frame -------------------------------------------------
        let origin = Point3::new(
            NOMINAL_ANNULUS[0] + d.origin_jitter[0],
            NOMINAL_ANNULUS[1] + d.origin_jitter[1],
            NOMINAL_ANNULUS[2] + d.origin_jitter[2],
        );
        // Tilt towards right-anterior: −x is right, −y is anterior.
        let azimuth = 45.0 * deg + d.azimuth_jitter;
        let horizontal = Vector3::new(-azimuth.cos(), -azimuth.sin(), 0.0);
        let axis = Vector3::z() * tilt_rad.cos() + horizontal * tilt_rad.sin();

        let profile = radius_profile(&d, &extras);

        // e1 such that the right-coronary sinus (sinus 1) faces anterior,
        // unless the root is turned.
        let anterior = -Vector3::y();
        let d_ant = (anterior - axis * anterior.dot(&axis)).normalize();
        let e1 = rotate_about(
            &d_ant,
            &axis,
            -profile.sinus_centre(0) + d.e1_jitter + extras.root_rotation_rad,
        );

        let r_max = profile.r_max_bound();
        let lvot_len = d.lvot_len;
        let fit = fit_field_of_view(&d, &extras, &profile, (origin, axis, e1), fov, tilt_rad)?;
        let Fit {
            centreline,
            needs,
            da_xy,
            da_radius,
            z_asc_top,
        } = fit;
        let arch = extras.arch.then(|| {
            let mut a = arch_geometry(&centreline, &profile, z_asc_top, da_xy, da_radius);
            a.z_truth_end = needs.z_top;
            a
        });
        // With an arch the FOV must reach over it, not just the ascending.
        let needs = match &arch {
            Some(a) => FovNeeds {
                z_bottom: needs.z_bottom,
                z_top: a.z_top_lumen + ARCH_TOP_MARGIN_MM,
            },
            None => needs,
        };
        let lumen = Lumen {
            centreline,
            profile,
            lvot_length_mm: lvot_len,
            r_max_mm: r_max,
            truth_top_z: arch.as_ref().map_or(f64::INFINITY, |a| a.z_truth_end),
        };
        let cl = &lumen.centreline;
        let profile = &lumen.profile;

        let (lv, myocardium) = left_ventricle(&lumen, &d, &origin, &axis);

        let coronaries = coronaries(cl, profile, &d, d.r_a);

        // --- Descending aorta, spine, sternum, body ---------------------------
        let da = match &arch {
            // Ends in the arch (whose end sphere rounds it off); a finite
            // but far bottom, as the cylinder caps only with both ends finite.
            Some(a) => ZCylinder {
                cx: da_xy[0],
                cy: da_xy[1],
                rx: da_radius,
                ry: da_radius,
                z_lo: a.z_join - 1.0e4,
                z_hi: a.z_join,
            },
            None => ZCylinder::endless(da_xy[0], da_xy[1], d.da_radius, d.da_radius),
        };
        // Vertebral body posterior-right of the DA, clear of it.
        const SPINE_FROM_DA: [f64; 2] = [-16.0, 28.0];
        let spine_centre = [da.cx + SPINE_FROM_DA[0], da.cy + SPINE_FROM_DA[1]];

        let wall = wall_samples(&lumen, -lvot_len, z_asc_top);
        let pa = pulmonary_artery(&lumen, &d, &axis, r_max, &wall);
        let la = left_atrium(&origin, &wall, &d, &da, &pa);
        let calcium = calcium(&lumen, &d);

        let h_comm = d.h_stj - d.comm_below_stj;
        let cusps = extras.native_cusps.then_some(Cusps {
            h_centre_mm: CUSP_CENTRE_FRACTION * h_comm,
            h_free_mm: h_comm - CUSP_FREE_EDGE_BELOW_COMM_MM,
            belly_power: CUSP_BELLY_POWER,
            thickness_mm: CUSP_THICKNESS_MM,
        });
        let anatomy = Anatomy {
            tilt_azimuth_rad: azimuth,
            arch,
            cusps,
            h_comm_mm: d.h_stj - d.comm_below_stj,
            lv,
            myocardium,
            coronaries,
            pa,
            pa_radius_mm: d.pa_radius,
            la,
            da,
            spine_centre,
            vertebra_radius_mm: VERTEBRA_RADIUS_MM,
            vertebra_period_mm: VERTEBRA_PERIOD_MM,
            vertebra_phase_mm: d.vertebra_phase,
            cortical_hu: d.cortical_hu,
            cancellous_hu: d.cancellous_hu,
            sternum_centre: [
                origin.x + STERNUM_FROM_ANNULUS[0],
                origin.y + STERNUM_FROM_ANNULUS[1],
            ],
            body_centre: [
                origin.x + BODY_FROM_ANNULUS[0],
                origin.y + BODY_FROM_ANNULUS[1],
            ],
            calcium,
            blood_waves: d.blood_waves,
            lumen,
        };
        Ok((anatomy, needs))
    }

    /// Smallest distance between the PA lumen and the aortic lumen (exact up
    /// to the wall sampling density: the PA tube distance is Euclidean).
    pub fn pa_aorta_gap(&self, z_top: f64) -> f64 {
        let wall = wall_samples(&self.lumen, -self.lumen.lvot_length_mm, z_top);
        min_gap(&self.pa, &wall).0
    }

    /// Smallest tissue gap between the LA and the aortic lumen (the LA
    /// distance is the ellipsoid bound, accurate to a few 0.1 mm here).
    pub fn la_aorta_gap(&self, z_top: f64) -> f64 {
        let wall = wall_samples(&self.lumen, -self.lumen.lvot_length_mm, z_top);
        wall.iter()
            .map(|p| self.la.eval(p).0)
            .fold(f64::INFINITY, f64::min)
    }

    /// Low-frequency multiplicative blood field, within ±5 %.
    pub fn blood_field(&self, p: &Point3) -> f64 {
        const AMPLITUDE: f64 = 0.05;
        let q = p - self.lumen.centreline.origin;
        let s: f64 = self
            .blood_waves
            .iter()
            .map(|(k, ph)| (k.dot(&q) + ph).cos())
            .sum();
        1.0 + AMPLITUDE * s / self.blood_waves.len() as f64
    }
}

/// The z-range the field of view must cover: ≥ 20 mm of LV below the
/// annulus, the LVOT, ≥ 40 mm of ascending aorta above the STJ and ≥ 10 mm
/// of vertical tube below the top face.
fn z_needs(cl: &Centreline, profile: &RadiusProfile, lvot_len: f64) -> FovNeeds {
    const LV_BELOW_MM: f64 = 25.0;
    const ASCENDING_ABOVE_STJ_MM: f64 = 42.0;
    const VERTICAL_BELOW_TOP_MM: f64 = 12.0;
    let o = cl.origin;
    let lateral = (1.0 - cl.axis.z * cl.axis.z).max(0.0).sqrt();
    let lvot_low = o.z - lvot_len * cl.axis.z - profile.r_annulus_mm * lateral;
    let z_bottom = (o.z - LV_BELOW_MM).min(lvot_low - 2.0);
    let arc_end = cl.station(cl.s2()).point.z;
    let asc = cl
        .station(profile.h_stj_mm + ASCENDING_ABOVE_STJ_MM)
        .point
        .z;
    FovNeeds {
        z_bottom,
        z_top: (arc_end + VERTICAL_BELOW_TOP_MM).max(asc),
    }
}

/// The arch from the ascending aorta at `z_join` to the DA top at `da_xy`:
/// a half-ellipse (span between the two axes, height ARCH_HEIGHT_RATIO × half
/// span) whose ends are vertical like the vessels it joins; the radius tapers
/// linearly from the ascending to the DA calibre.
fn arch_geometry(
    cl: &Centreline,
    profile: &RadiusProfile,
    z_join: f64,
    da_xy: [f64; 2],
    da_r: f64,
) -> Arch {
    let s_join = s_at_z(cl, z_join);
    let a = cl.station(s_join).point;
    let r0 = profile.eval(s_join, 0.0).r;
    let dvec = Vector3::new(da_xy[0] - a.x, da_xy[1] - a.y, 0.0);
    let span = dvec.norm();
    let h_dir = dvec / span.max(1e-9);
    let half = 0.5 * span;
    let height = ARCH_HEIGHT_RATIO * half;
    let mid = Point3::new(a.x + 0.5 * dvec.x, a.y + 0.5 * dvec.y, z_join);
    let points: Vec<Point3> = (0..=ARCH_SEGMENTS)
        .map(|i| {
            let phi = PI * i as f64 / ARCH_SEGMENTS as f64;
            mid - h_dir * (half * phi.cos()) + Vector3::z() * (height * phi.sin())
        })
        .collect();
    let radii: Vec<f64> = (0..ARCH_SEGMENTS)
        .map(|i| r0 + (da_r - r0) * (i as f64 + 0.5) / ARCH_SEGMENTS as f64)
        .collect();
    // The lumen's top: the highest point of any segment's capsule.
    let z_top_lumen = points
        .windows(2)
        .zip(&radii)
        .map(|(w, r)| w[0].z.max(w[1].z) + r)
        .fold(f64::NEG_INFINITY, f64::max);
    Arch {
        tube: Tube::new(points, radii),
        z_join,
        z_truth_end: z_join - ARCH_JOIN_ABOVE_TRUTH_MM,
        z_top_lumen,
        span_mm: span,
        height_mm: height,
        r_start_mm: r0,
        r_end_mm: da_r,
    }
}

/// Arc length where the centreline reaches height z (z increases along s).
pub fn s_at_z(cl: &Centreline, z: f64) -> f64 {
    let (mut lo, mut hi) = (-200.0, 400.0);
    for _ in 0..100 {
        let m = 0.5 * (lo + hi);
        if cl.station(m).point.z < z {
            lo = m;
        } else {
            hi = m;
        }
    }
    0.5 * (lo + hi)
}

/// The pulmonary artery: placed, then slid until its gap to the aortic wall
/// (`wall`) is the drawn one. The pulmonary valve sits anterior-left of the
/// aortic root, a little higher; the trunk runs superior-posterior-left to
/// the bifurcation; the left PA continues left-posterior, the right PA turns
/// right and passes behind the ascending aorta. All offsets in mm (x L, y P,
/// z S).
fn pulmonary_artery(
    lumen: &Lumen,
    d: &Draws,
    axis: &Vector3,
    r_max: f64,
    wall: &[Point3],
) -> Vec<Tube> {
    const PA_VALVE_HEIGHT_MM: f64 = 8.0;
    const TRUNK_LENGTH_MM: f64 = 38.0;
    const TRUNK_BELOW_VALVE_MM: f64 = 10.0;
    const BRANCH_RADIUS_FRACTION: f64 = 0.8;
    const RPA_BELOW_BIFURCATION_MM: f64 = 4.0;
    let (cl, profile) = (&lumen.centreline, &lumen.profile);
    let pa_r = d.pa_radius;
    let branch_r = BRANCH_RADIUS_FRACTION * pa_r;
    let ant_left = Vector3::new(1.0, -1.3, 0.0).normalize();
    let d_pa = (ant_left - axis * ant_left.dot(axis)).normalize();
    let p0 = cl.station(PA_VALVE_HEIGHT_MM).point + d_pa * (r_max + d.pa_gap + pa_r);
    let trunk_dir = Vector3::new(0.35, 0.45, 0.82).normalize();
    let bif = p0 + trunk_dir * TRUNK_LENGTH_MM;
    let z_r = bif.z - RPA_BELOW_BIFURCATION_MM;
    let s_r = s_at_z(cl, z_r);
    let c_aa = cl.station(s_r).point;
    let r_aa = profile.eval(s_r, 0.0).r;
    // y of the RPA axis where it passes behind the ascending aorta.
    let behind = c_aa.y + r_aa + d.pa_gap + branch_r;
    let mut pa = vec![
        Tube::new(
            vec![
                p0 - trunk_dir * TRUNK_BELOW_VALVE_MM,
                p0,
                p0 + trunk_dir * (0.5 * TRUNK_LENGTH_MM),
                bif,
            ],
            vec![pa_r; 3],
        ),
        Tube::new(
            vec![
                bif,
                bif + Vector3::new(16.0, 16.0, -2.0),
                bif + Vector3::new(28.0, 30.0, -8.0),
            ],
            vec![branch_r; 2],
        ),
        Tube::new(
            vec![
                bif,
                Point3::new(c_aa.x + 12.0, behind, z_r),
                Point3::new(c_aa.x - 15.0, behind + 2.0, z_r - 3.0),
                Point3::new(c_aa.x - 40.0, behind + 8.0, z_r - 8.0),
            ],
            vec![branch_r; 3],
        ),
    ];
    slide_to_gap(&mut pa, wall, d.pa_gap);
    pa
}

/// The left atrium: posterior of the root (`origin`, the annulus centre),
/// slid to its tissue gap from the aortic wall, and shrunk until it keeps
/// clear of the descending aorta and the PA branches.
fn left_atrium(
    origin: &Point3,
    wall: &[Point3],
    d: &Draws,
    da: &ZCylinder,
    pa: &[Tube],
) -> Ellipsoid {
    // Start position (x L, y P, z S from the annulus); y is then solved.
    const LA_START: [f64; 3] = [-6.0, 30.0, -6.0];
    let mut la = Ellipsoid {
        centre: Point3::new(
            origin.x + LA_START[0],
            origin.y + LA_START[1],
            origin.z + LA_START[2],
        ),
        rot: Matrix3::identity(),
        semi: Vector3::new(LA_SEMI[0], LA_SEMI[1], LA_SEMI[2]),
    };
    for _ in 0..6 {
        place_la(&mut la, wall, d.la_gap);
        let clear = ellipsoid_samples(&la)
            .iter()
            .map(|p| {
                da.eval(p)
                    .0
                    .min(pa.iter().map(|t| t.eval(p).0).fold(f64::INFINITY, f64::min))
            })
            .fold(f64::INFINITY, f64::min);
        if clear >= CLEARANCE_MM {
            break;
        }
        la.semi *= 0.9;
    }
    la
}

/// Calcium blobs in the wall near the nadirs, each protruding into the
/// lumen.
fn calcium(lumen: &Lumen, d: &Draws) -> Vec<Ellipsoid> {
    let (cl, profile) = (&lumen.centreline, &lumen.profile);
    d.calcium
        .iter()
        .map(|&(k, s, dth, out, sz)| {
            let th = profile.sinus_centre(k) + dth;
            // Above the (possibly tilted) annulus at that angle.
            let s = s + profile.annulus_s(th).0;
            let st = cl.station(s);
            let u = st.e1 * th.cos() + st.e2 * th.sin();
            let r = profile.eval(s, th).r;
            // Long axis along the annulus (circumferential), short radially.
            let circ = st.tangent.cross(&u);
            Ellipsoid {
                // Centre in the wall, a fraction of the radial semi-axis
                // outside the lumen: every blob protrudes into the lumen.
                centre: st.point + u * (r + out * sz[2]),
                rot: Matrix3::from_columns(&[circ, st.tangent, u]),
                semi: Vector3::new(sz[0], sz[1], sz[2]),
            }
        })
        .collect()
}

/// Points on the analytic aortic wall, ~0.5 mm apart, up to height z_top.
fn wall_samples(lumen: &Lumen, s_lo: f64, z_top: f64) -> Vec<Point3> {
    const STEP_MM: f64 = 0.5;
    let s_hi = s_at_z(&lumen.centreline, z_top + 20.0);
    let n_s = ((s_hi - s_lo) / STEP_MM).ceil() as usize;
    let n_t = (2.0 * PI * lumen.profile.r_max_bound() / STEP_MM).ceil() as usize;
    let mut v = Vec::with_capacity((n_s + 1) * n_t);
    for i in 0..=n_s {
        let s = s_lo + (s_hi - s_lo) * i as f64 / n_s as f64;
        for j in 0..n_t {
            v.push(lumen.wall_point(s, 2.0 * PI * j as f64 / n_t as f64));
        }
    }
    v
}

/// Minimal distance from the tubes to the wall samples, with the direction
/// from the closest wall sample towards the tubes.
fn min_gap(tubes: &[Tube], wall: &[Point3]) -> (f64, Vector3) {
    let mut best = (f64::INFINITY, Vector3::z());
    for p in wall {
        for t in tubes {
            let (d, n) = t.eval(p);
            if d < best.0 {
                best = (d, -n);
            }
        }
    }
    best
}

/// Translate the tubes until their closest approach to the wall is `gap`.
fn slide_to_gap(tubes: &mut [Tube], wall: &[Point3], gap: f64) {
    for _ in 0..30 {
        let (g, dir) = min_gap(tubes, wall);
        if (g - gap).abs() < 0.01 {
            break;
        }
        // When overlapping, the direction is still outward from the wall
        // point closest to the tube axis, so stepping along it separates.
        let step = dir * (gap - g);
        for t in tubes.iter_mut() {
            t.translate(&step);
        }
    }
}

fn ellipsoid_samples(e: &Ellipsoid) -> Vec<Point3> {
    let mut v = Vec::new();
    const N: usize = 24;
    for i in 0..=N {
        let th = PI * i as f64 / N as f64;
        for j in 0..2 * N {
            let ph = PI * j as f64 / N as f64;
            let l = Vector3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos())
                .component_mul(&e.semi);
            v.push(e.centre + e.rot * l);
        }
    }
    v
}

/// Move the LA along +y (posterior) until its gap to the aortic wall is `gap`.
fn place_la(la: &mut Ellipsoid, wall: &[Point3], gap: f64) {
    let gap_of = |la: &Ellipsoid| {
        wall.iter()
            .map(|p| la.eval(p).0)
            .fold(f64::INFINITY, f64::min)
    };
    // Bisection on the y offset: the gap grows monotonically moving posterior.
    let y0 = la.centre.y;
    let (mut lo, mut hi) = (-20.0, 40.0);
    for _ in 0..40 {
        let m = 0.5 * (lo + hi);
        la.centre.y = y0 + m;
        if gap_of(la) < gap {
            lo = m;
        } else {
            hi = m;
        }
    }
    la.centre.y = y0 + hi;
}

/// The right and left coronary arteries leaving sinuses 1 and 2 at the
/// drawn ostia, along the atrioventricular groove (`r_a` + 12 mm from the
/// centreline): the RCA to the right, the LCx posterior and the LAD
/// anterior and down, each tapering to 60 % of its ostial radius.
fn coronaries(cl: &Centreline, profile: &RadiusProfile, d: &Draws, r_a: f64) -> Vec<Coronary> {
    let deg = PI / 180.0;
    let frame_point = |h: f64, th: f64, rho: f64| {
        let st = cl.station(h);
        st.point + (st.e1 * th.cos() + st.e2 * th.sin()) * rho
    };
    let groove = r_a + 12.0;
    let mut coronaries = Vec::new();
    for (c, (&name, &sinus)) in ["RCA", "LCA"].iter().zip(&[0usize, 1]).enumerate() {
        let h_o = d.ostium_frac[c] * profile.h_stj_mm;
        let psi = profile.sinus_centre(sinus) + d.ostium_angle[c];
        let r_w = profile.eval(h_o, psi).r;
        let r0 = d.coronary_radius[c];
        let ostium = frame_point(h_o, psi, r_w);
        // Start inside the sinus lumen so the artery is connected to it.
        let proximal = vec![
            frame_point(h_o, psi, r_w - 2.5),
            frame_point(h_o, psi, r_w + 4.0),
        ];
        // (height, angle offset in degrees, radius) along the AV groove;
        // the RCA runs towards the right (decreasing angle), the LCx
        // towards posterior (increasing), the LAD anterior and down.
        let paths: Vec<Vec<(f64, f64, f64)>> = if name == "RCA" {
            vec![vec![
                (h_o - 3.0, -12.0, r_w + 9.0),
                (h_o - 7.0, -30.0, groove),
                (-2.0, -55.0, groove),
                (-6.0, -80.0, groove),
                (-9.0, -105.0, groove),
                (-12.0, -130.0, groove),
            ]]
        } else {
            vec![
                vec![
                    (h_o - 2.0, 6.0, r_w + 10.0),
                    (-3.0, 25.0, groove),
                    (-7.0, 50.0, groove),
                    (-10.0, 75.0, groove),
                    (-12.0, 100.0, groove),
                ],
                vec![
                    (h_o - 2.0, 6.0, r_w + 10.0),
                    (h_o - 8.0, -20.0, groove + 4.0),
                    (h_o - 16.0, -45.0, groove + 8.0),
                    (h_o - 28.0, -65.0, groove + 12.0),
                ],
            ]
        };
        let mut tubes = Vec::new();
        for (b, path) in paths.iter().enumerate() {
            let mut pts = if b == 0 {
                proximal.clone()
            } else {
                vec![proximal[1]]
            };
            pts.extend(
                path.iter()
                    .map(|&(h, a, rho)| frame_point(h, psi + a * deg, rho)),
            );
            let n = pts.len() - 1;
            // Taper to 60 % of the ostial radius.
            let radii = (0..n)
                .map(|i| r0 * (1.0 - 0.4 * i as f64 / n as f64))
                .collect();
            tubes.push(Tube::new(pts, radii));
        }
        coronaries.push(Coronary {
            name,
            sinus,
            tubes,
            ostium,
            radius_mm: r0,
            ostium_height_mm: h_o,
        });
    }
    coronaries
}
