//! Segmentation of the aortic root and ascending aorta from a ceCTA.
//!
//! Steps (each timed in the report):
//! 1. [`track`]: Hough circleness ([`hough`]) finds the ascending aorta on
//!    the top slice and follows it toward the root; the blood-pool HU and the
//!    threshold come from the found lumen.
//! 2. [`roi`]: crop to a box around the tracked aorta, the lumen followed
//!    past the track on a coarse grid ([`reach`]) and the landmarks, affine
//!    kept exact; everything heavy runs on the crop.
//! 3. Smooth, threshold, flood fill from the seed; [`edt`] distances; the
//!    isoperimetric distance tree ([`idt`]) orders the voxels and the
//!    steepest-rise rule stops the region before it leaks into the LV.
//! 4. [`morphology`]: opening with a ball, seed component, holes filled;
//!    [`vaj`]: the LV separated at the ventriculo-aortic junction.

pub mod anchor;
pub mod blood_pool;
pub mod debug_png;
pub mod edt;
pub mod euler;
pub mod filter;
pub mod hough;
pub mod idt;
pub mod morphology;
pub mod reach;
pub mod roi;
pub mod root_fill;
pub mod stage;
pub mod stage_params;
pub mod track;
pub mod vaj;
pub mod vaj_floor;

#[cfg(test)]
mod tests;

use std::time::Instant;

use serde::Serialize;

use coapt_base::{Error, Result};
use coapt_geom::{Landmarks, Point3, Vector3, Volume, resample};
use hough::HoughParams;
use track::{TrackPoint, median};

/// Tunables (defaults justified in docs/segment.md and the report).
#[derive(Debug, Clone, Copy)]
pub struct SegmentParams {
    pub hough: HoughParams,
    /// Gaussian smoothing before the threshold (noise), mm.
    pub smooth_mm: f64,
    /// Opening ball radius, mm (coronaries have r ≈ 1.5–2 mm).
    pub open_mm: f64,
    /// Least blood-pool HU of a contrast CT.
    pub contrast_min_hu: f64,
    /// IDT stop rule.
    pub rule: StopRule,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopRule {
    SteepestRise,
    IsoperimetricMin,
}

impl Default for SegmentParams {
    fn default() -> Self {
        SegmentParams {
            hough: HoughParams::default(),
            smooth_mm: 0.5,
            open_mm: 2.5,
            contrast_min_hu: 150.0,
            rule: StopRule::SteepestRise,
        }
    }
}

/// What happened, for `segment.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub seed_mm: [f64; 3],
    pub seed_radius_mm: f64,
    pub seed_circleness: f64,
    pub candidates: Vec<track::Candidate>,
    pub tracked_slices: usize,
    pub tracked_length_mm: f64,
    pub track: Vec<TrackPoint>,
    pub blood_hu: f64,
    pub noise_hu: f64,
    pub wall_hu: f64,
    pub threshold_hu: f64,
    pub roi: roi::RoiReport,
    /// The lumen followed on a coarse grid past the track (sets the ROI).
    pub reach: Option<reach::Reach>,
    pub idt: IdtReport,
    pub vaj: VajReport,
    /// The mask's Euler characteristic (1: a ball; each tunnel one less)
    /// and the trim that removed tunnels above the root.
    pub topology: Topology,
    /// The mask against a tube of the tracked radius (the leak check).
    pub tube: TubeCheck,
    /// The native cusps' space closed into the root, when the VAJ is known.
    pub root_fill: Option<root_fill::RootFill>,
    pub volumes_ml: Volumes,
    pub landmarks_check: Option<String>,
    pub timings_s: Vec<(String, f64)>,
}

#[derive(Debug, Clone, Serialize)]
pub struct IdtReport {
    pub region_voxels: usize,
    pub rule: StopRule,
    pub k_steepest_rise: Option<usize>,
    pub k_isoperimetric_min: Option<usize>,
    pub k_chosen: usize,
    pub why: String,
    /// The sweep's lattice cut (faces) against the volume swept (ml),
    /// sampled every 0.5 ml: the curve the stop rule reads.
    pub cut_curve: Vec<(f64, u32)>,
}

#[derive(Debug, Clone, Serialize)]
pub struct VajReport {
    pub method: String,
    pub plane: Option<vaj::Plane>,
    pub profile: Option<vaj::Profile>,
    pub removed_ml: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Volumes {
    pub threshold_region: f64,
    pub idt_region: f64,
    pub opened: f64,
    pub final_mask: f64,
}

pub struct Segmentation {
    /// uint8 0/1 on the cropped grid (its own exact affine).
    pub mask: Volume<u8>,
    /// The CT on the axis-aligned LPS grid the segmentation ran on.
    pub work: Volume<i16>,
    pub report: Report,
    /// Circleness of the top slice (for debug images).
    pub top_circleness: hough::CircleMap,
    pub top_k: usize,
}

/// Finest and coarsest spacing of the work grid (mm): scans at 1.5–2 mm are
/// sampled at half their spacing so the filters, the opening ball and the
/// Hough edges have voxels to work with; a scan finer than 0.5 mm is
/// sampled at 0.5 mm. At 0.3 mm (the real CT resampled) the Hough
/// circleness of the root's section, then summed over 3×3 pixels, fell to
/// 0.33 (0.63 at 0.75 mm), tracking stopped after its first circle, and
/// the wall ring sampled inside the lumen put the threshold at 370 HU
/// instead of 300: the lumen shrank by about 1 mm, the commissures with it;
/// the stage also peaked at 2.8 GB (1.1 GB at 0.5 mm). The circleness
/// window now reaches as far in mm on any grid (`hough.rs`); the floor
/// stays for the time and memory.
const WORK_MAX_SPACING_MM: f64 = 1.0;
const WORK_MIN_SPACING_MM: f64 = 0.5;
/// The work box around the landmarks (mm): the root and LVOT below, the
/// ascending aorta up to the arch above.
const LANDMARK_BOX_MM: (f64, f64, f64) = (60.0, 60.0, 110.0);
/// How far up the commissure axis the region of interest holds the aorta
/// (mm; the box adds its landmark margin): the STJ lies 0–5 mm above the
/// commissures, and the report measures up to 40 mm above it.
const ASCENDING_ABOVE_MM: f64 = 40.0;
/// Height above the highest commissure (mm, head–feet) where the region of
/// interest ends when the commissures are known (`bench segment` scores
/// below it).
pub const ASCENDING_TOP_MM: f64 = 60.0;
/// Without commissure landmarks they are taken this far above the VAJ
/// plane (mm, head–feet): adult commissures stand 15–22 mm above the
/// annulus.
const COMMISSURES_ABOVE_VAJ_MM: f64 = 20.0;
/// A point this far up the VAJ plane's normal from its centre is in the
/// root (mm): the kept voxel nearest to it holds the part that stays.
const ROOT_PROBE_MM: f64 = 5.0;
/// How far the lumen is followed from the commissures' anchor (mm of path):
/// the ascending aorta is 50–90 mm long before the arch.
const ANCHORED_REACH_MM: f64 = 90.0;
/// Most voxels of a work grid (i16): 1 GiB.
const WORK_MAX_VOXELS: usize = 1 << 29;

/// The CT on an axis-aligned LPS grid (k toward the head), around the
/// commissures when they are known: every step after this one reasons in
/// axial slices and millimetres, whatever the scan's orientation.
fn work_volume(ct: &Volume<i16>, commissures: Option<&[Point3; 3]>) -> Result<Volume<i16>> {
    let (lo, hi) = match commissures {
        Some(c) => {
            let (b, above) = (LANDMARK_BOX_MM.0, LANDMARK_BOX_MM.2);
            let min = |a: usize| c.iter().map(|p| p[a]).fold(f64::INFINITY, f64::min);
            let max = |a: usize| c.iter().map(|p| p[a]).fold(f64::NEG_INFINITY, f64::max);
            (
                Point3::new(min(0) - b, min(1) - b, min(2) - LANDMARK_BOX_MM.1),
                Point3::new(max(0) + b, max(1) + b, max(2) + above),
            )
        }
        None => (
            Point3::from([f64::NEG_INFINITY; 3]),
            Point3::from([f64::INFINITY; 3]),
        ),
    };
    let grid = resample::LpsGrid::covering(ct, lo, hi, WORK_MAX_SPACING_MM, WORK_MIN_SPACING_MM)
        .ok_or_else(|| {
            Error::failed(
                "segment",
                "the commissure landmarks C1–C3 lie outside the CT's field of view: are they from this scan?",
            )
        })?;
    if grid.len() > WORK_MAX_VOXELS {
        return Err(Error::failed(
            "segment",
            format!(
                "the region to segment would be {}×{}×{} voxels at {:.2} mm, more than {WORK_MAX_VOXELS}: crop the CT to the chest or give the commissure landmarks",
                grid.dims[0], grid.dims[1], grid.dims[2], grid.spacing[0]
            ),
        ));
    }
    resample::resample_i16(ct, &grid, AIR_HU)
}

/// Where the native cusps may lie: from the VAJ plane to just above the
/// commissures (or 25 mm without them), within 1.6 root radii of the line
/// from the annulus centre to the commissures' centre (the sinuses bulge to
/// about 1.3 times the commissure radius).
fn root_slab(
    pl: &vaj::Plane,
    commissures: &[Point3],
    nadirs: Option<&[Point3]>,
    track_r: Option<f64>,
) -> root_fill::RootSlab {
    let base = Point3::from(pl.point_mm);
    let normal = coapt_geom::Vector3::from(pl.normal);
    let circle = |v: &[Point3]| {
        <[Point3; 3]>::try_from(v)
            .ok()
            .and_then(|c| anchor::circumcircle(&c))
    };
    let annulus = nadirs.and_then(circle);
    let axis_point = annulus.map_or(base, |a| a.0);
    let (top, axis, r) = match circle(commissures) {
        Some((cc, _, rc)) => (
            commissures
                .iter()
                .map(|c| pl.height(c))
                .fold(f64::NEG_INFINITY, f64::max)
                + 3.0,
            (cc - axis_point).try_normalize(1e-9).unwrap_or(normal),
            rc.max(annulus.map_or(0.0, |a| a.2)),
        ),
        None => (25.0, normal, track_r.unwrap_or(15.0)),
    };
    root_fill::RootSlab {
        vaj: *pl,
        top_mm: top,
        axis_point_mm: [axis_point.x, axis_point.y, axis_point.z],
        axis: [axis.x, axis.y, axis.z],
        radius_mm: 1.6 * r,
    }
}

/// Most volume of the mask, in tubes of the tracked radius over its length:
/// the sinuses and the tilt add up to half to the root + ascending aorta
/// (0.86–1.43 on the real CT's crops and copies, 1.25–1.32 on sample t60);
/// the left atrium or the ventricle behind a leak add one to three times
/// more (2.6 and 2.9 on the real CT's leaking crops).
const MAX_TUBE_RATIO: f64 = 2.0;

/// Height above the highest commissure (mm, head–feet) where a mask with
/// tunnels is cut.
const TRIM_ABOVE_MM: f64 = 45.0;

#[derive(Debug, Clone, Copy, Serialize)]
pub struct Topology {
    pub euler: i64,
    pub trimmed_above_commissures_mm: Option<f64>,
    pub euler_after_trim: Option<i64>,
    /// Without commissures: the height (LPS z, mm) above which the lumen
    /// was cut, where a mask from the landmarks ends (the arch and the
    /// descending aorta of a chest CT are not the root's).
    pub cut_above_z_mm: Option<f64>,
}

/// The mask against a tube of the tracked radius, for `segment.json`.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TubeCheck {
    pub radius_mm: f64,
    pub length_mm: f64,
    pub ratio: f64,
}

/// Volume of `mask` over that of a tube of the vessel's median radius (the
/// track's circles and, without landmarks, the seed vessel's circles on the
/// other searched levels: a seed on a marginal circle where the aorta bends
/// into the arch tracked one slice of r 10.4 mm on the real CT's 1 mm copy,
/// whose good mask then read as a leak), as long as the mask's extent along
/// the aorta (from the VAJ plane toward the seed, or along the head–feet
/// axis without a plane).
fn tube_check(
    mask: &[bool],
    world: impl Fn(usize) -> Point3,
    found: &track::Found,
    seed: &Point3,
    plane: Option<&vaj::Plane>,
    vox_ml: f64,
) -> TubeCheck {
    let axis = plane
        .and_then(|p| (seed - Point3::from(p.point_mm)).try_normalize(1e-9))
        .unwrap_or_else(coapt_geom::Vector3::z);
    let (mut lo, mut hi, mut n) = (f64::INFINITY, f64::NEG_INFINITY, 0usize);
    for (v, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
        let h = world(v).coords.dot(&axis);
        lo = lo.min(h);
        hi = hi.max(h);
        n += 1;
    }
    let mut radii: Vec<f64> = found.track.iter().map(|t| t.r_mm).collect();
    radii.extend_from_slice(&found.level_radii);
    let r = median(&mut radii);
    let length = if n > 0 { hi - lo } else { 0.0 };
    let tube_ml = std::f64::consts::PI * r * r * length / 1000.0;
    TubeCheck {
        radius_mm: r,
        length_mm: length,
        ratio: if tube_ml > 0.0 {
            n as f64 * vox_ml / tube_ml
        } else {
            0.0
        },
    }
}

/// The value of the work grid outside the scan.
const AIR_HU: i16 = -1024;

/// A chest CT has air (the lungs, the room) at about −1000 HU, so one whose
/// darkest percent lies above this was most likely stored without its
/// rescale intercept (raw detector values 0–4095).
const AIR_PERCENTILE_MAX_HU: i32 = -500;

/// Why a CT in which no aorta was found may not be in Hounsfield units:
/// its first percentile, when that lies above [`AIR_PERCENTILE_MAX_HU`].
fn hu_hint(ct: &Volume<i16>) -> Option<String> {
    let mut hist = vec![0u64; 1 << 16];
    for &v in ct.as_slice() {
        hist[(i32::from(v) + 32768) as usize] += 1;
    }
    let target = ct.as_slice().len() as u64 / 100;
    let mut seen = 0;
    let p1 = hist.iter().enumerate().find_map(|(i, &h)| {
        seen += h;
        (seen > target).then_some(i as i32 - 32768)
    })?;
    (p1 > AIR_PERCENTILE_MAX_HU).then(|| {
        format!(
            "the darkest percent of the CT lies at {p1} HU and above, where a chest CT's air reads about −1000 HU: are its values Hounsfield units? (check the file's rescale slope and intercept)"
        )
    })
}

struct Clock(Instant, Vec<(String, f64)>);
impl Clock {
    fn lap(&mut self, name: &str) {
        let t = Instant::now();
        self.1.push((name.into(), (t - self.0).as_secs_f64()));
        self.0 = t;
    }
}

/// The isoperimetric distance tree on the threshold region `region`
/// (grid `dims`, spacing `sp`, seed voxel `ground`) and where its sweep
/// stops by `rule`: the voxels kept (in the sweep's order) and the report.
#[allow(clippy::too_many_arguments)]
fn idt_stop(
    region: &[bool],
    dims: [usize; 3],
    sp: [f64; 3],
    ground: usize,
    region_voxels: usize,
    roi: &Volume<u8>,
    rule: StopRule,
    clock: &mut Clock,
) -> (Vec<u32>, IdtReport) {
    let vox_ml = roi.voxel_volume() / 1000.0;
    let dt = edt::inside_distance(region, dims, sp);
    clock.lap("edt");
    let tree = idt::max_spanning_tree(region, &dt, dims, ground);
    drop(dt);
    clock.lap("spanning_tree");
    let x = idt::solve_on_tree(&tree.parent, &tree.weight);
    let order = idt::order_by_potential(&x);
    let mut sweep: Vec<u32> = order.iter().map(|&o| tree.order[o as usize]).collect();
    drop(x);
    clock.lap("tree_solve_order");
    let cut = idt::sweep_cut(region, dims, &sweep);
    let lim = idt::RiseLimits::from_ml(roi.voxel_volume());
    let k_rise = idt::steepest_rise(&cut, &lim);
    let k_min = idt::isoperimetric_min(&cut, lim.i_min);
    let (k, why) = match (rule, k_rise, k_min) {
        (StopRule::SteepestRise, Some(k), _) => (
            k,
            format!(
                "steepest rise of the cut after {:.1} ml: the sweep is about to enter a larger chamber",
                k as f64 * vox_ml
            ),
        ),
        (StopRule::IsoperimetricMin, _, Some(k)) => (
            k,
            "least isoperimetric ratio cut/k over k ≤ N/2".to_string(),
        ),
        _ => (
            sweep.len(),
            "no leak detected: the whole threshold region is kept".to_string(),
        ),
    };
    let every = ((0.5 / vox_ml).round() as usize).max(1);
    let cut_curve: Vec<(f64, u32)> = (every..=cut.len())
        .step_by(every)
        .map(|k| (k as f64 * vox_ml, cut[k - 1]))
        .collect();
    sweep.truncate(k);
    clock.lap("sweep_stop");
    let report = IdtReport {
        region_voxels,
        rule,
        k_steepest_rise: k_rise,
        k_isoperimetric_min: k_min,
        k_chosen: k,
        why,
        cut_curve,
    };
    (sweep, report)
}

/// The IDT region opened by a ball of radius `open_mm` (the coronaries
/// go), its component holding the seed voxel `ground`, holes filled.
fn open_and_fill(
    idt_region: &[bool],
    dims: [usize; 3],
    sp: [f64; 3],
    ground: usize,
    open_mm: f64,
) -> Vec<bool> {
    // On the region's bounding box only (plus the ball): the IDT region is a
    // small part of the ROI, which still holds the LV.
    let pad = [0, 1, 2].map(|a| (open_mm / sp[a]).ceil() as usize + 2);
    let sub = morphology::SubBox::around(idt_region, dims, pad);
    let sd = sub.dims();
    let local = morphology::open_ball(&sub.extract(idt_region, dims), sd, sp, open_mm);
    // Seed component and holes on the sub-box too: its padding (≥ 2 voxels,
    // or the ROI border) is background connected to everything outside it,
    // so both give the same voxels as on the whole ROI, without walking the
    // ROI's background (most of its 10–20 M voxels on the full preset).
    let local = match sub.to_inner(ground, dims) {
        Some(g) => morphology::fill_holes(&morphology::flood_fill(&local, sd, g), sd),
        None => vec![false; local.len()],
    };
    let mut opened = vec![false; idt_region.len()];
    sub.scatter(&local, &mut opened, dims);
    opened
}

/// Where the kept lumen reaches far above the root, cut it: a wall with
/// tunnels (Euler characteristic ≠ 1) [`TRIM_ABOVE_MM`] above the highest
/// commissure, and without commissures the arch and descending aorta
/// where a mask from the landmarks would end. What a cut parts from the
/// root is dropped. `world` maps a voxel of the `dims` grid to LPS mm.
fn cut_above_root(
    mut keep: Vec<bool>,
    dims: [usize; 3],
    world: impl Fn(usize) -> Point3,
    commissures3: Option<&[Point3; 3]>,
    plane: Option<&vaj::Plane>,
    ground: usize,
) -> (Vec<bool>, Topology) {
    let n = keep.len();
    // A wall with tunnels (branch vessels of the arch joined twice, seen
    // on the real CT 55–60 mm above the commissures) is not a root wall:
    // with the commissures known the lumen is cut lower, where the valve
    // and the report still have 30 mm of ascending aorta above the STJ.
    let euler_of = |m: &[bool]| {
        let sub = morphology::SubBox::around(m, dims, [1, 1, 1]);
        euler::euler_characteristic(&sub.extract(m, dims), sub.dims())
    };
    // The voxel that holds the part kept when the lumen is cut above the
    // root: the seed may lie above the cut (without landmarks it is found on
    // an axial level below the arch, 80 mm above the clinical phantom's VAJ).
    let root_voxel = |keep: &[bool], pl: &vaj::Plane| {
        let probe = Point3::from(pl.point_mm) + Vector3::from(pl.normal) * ROOT_PROBE_MM;
        (0..n).filter(|&v| keep[v]).min_by(|&a, &b| {
            (world(a) - probe)
                .norm_squared()
                .total_cmp(&(world(b) - probe).norm_squared())
                .then(a.cmp(&b))
        })
    };
    let mut topology = Topology {
        euler: euler_of(&keep),
        trimmed_above_commissures_mm: None,
        euler_after_trim: None,
        cut_above_z_mm: None,
    };
    // Without commissures they are taken 20 mm above the VAJ plane (adult
    // commissures stand 15–22 mm above the annulus).
    let commissure_top = match (commissures3, plane) {
        (Some(c), _) => Some(c.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max)),
        (None, Some(pl)) => Some(pl.point_mm[2] + COMMISSURES_ABOVE_VAJ_MM),
        (None, None) => None,
    };
    if let (Some(top), true) = (commissure_top, topology.euler != 1) {
        let from = plane
            .and_then(|pl| root_voxel(&keep, pl))
            .filter(|&v| world(v).z <= top + TRIM_ABOVE_MM)
            .unwrap_or(ground);
        for (v, kv) in keep.iter_mut().enumerate() {
            if *kv && world(v).z > top + TRIM_ABOVE_MM {
                *kv = false;
            }
        }
        keep = morphology::flood_fill(&keep, dims, from);
        topology.trimmed_above_commissures_mm = Some(TRIM_ABOVE_MM);
        topology.euler_after_trim = Some(euler_of(&keep));
    }
    // Without commissures the lumen holds all the threshold reached: on a
    // chest CT the arch and the descending aorta (clinical phantom: 132 ml,
    // where the root and ascending aorta are 43 ml), whose far side a plane
    // through the annulus also cuts, so the landmarks stage found the
    // annulus centre between the root and the descending aorta. It is cut
    // where a mask from the landmarks ends (the work box stops
    // [`ASCENDING_TOP_MM`] above the highest commissure), with the
    // commissures taken [`COMMISSURES_ABOVE_VAJ_MM`] above the VAJ, and what
    // the cut parts from the root is dropped.
    if let (None, Some(pl), Some(top)) = (commissures3, plane, commissure_top) {
        let cut = top + ASCENDING_TOP_MM;
        if let Some(root) = root_voxel(&keep, pl).filter(|&v| world(v).z < cut)
            && keep
                .iter()
                .enumerate()
                .any(|(v, &kv)| kv && world(v).z > cut)
        {
            for (v, kv) in keep.iter_mut().enumerate() {
                if *kv && world(v).z > cut {
                    *kv = false;
                }
            }
            keep = morphology::flood_fill(&keep, dims, root);
            topology.cut_above_z_mm = Some(cut);
        }
    }
    (keep, topology)
}

/// The VAJ plane: through the nadirs N1–N3 when given, else where the
/// sinus descent flattens into the LVOT along the centreline marched down
/// from the track on the opened lumen `opened` (`world`: its voxels in
/// LPS mm, each `voxel_mm3`). With C1–C3 given, a plane off their root is
/// replaced by `alone`'s (the CT segmented without landmarks, whose region
/// does not reach the ventricle through the annulus as the anchored one
/// can), else by a march down the commissures' axis. The report says
/// which, without the plane (set once the lumen is cut at it).
#[allow(clippy::too_many_arguments)]
fn vaj_plane(
    nadirs: Option<&[Point3]>,
    commissures: &[Point3],
    ct: &Volume<i16>,
    found: &track::Found,
    opened: &[bool],
    world: impl Fn(usize) -> Point3,
    voxel_mm3: f64,
    sp: [f64; 3],
    alone: impl FnOnce() -> Option<vaj::Plane>,
) -> (Option<vaj::Plane>, VajReport) {
    let mut report = VajReport {
        method: "none".into(),
        plane: None,
        profile: None,
        removed_ml: 0.0,
    };
    let plane = if let Some(nd) = nadirs.and_then(|v| <[Point3; 3]>::try_from(v).ok()) {
        report.method = "plane through the nadir landmarks N1–N3".into();
        // The nadirs' order says nothing of which side is the aorta (a
        // file may number them either way round): the normal faces the
        // commissures, or without them where the track began, in the
        // ascending aorta.
        let up: Vec<Point3> = if commissures.is_empty() {
            found
                .track
                .first()
                .map(|t| track::world(ct, t))
                .into_iter()
                .collect()
        } else {
            commissures.to_vec()
        };
        vaj::plane_from_landmarks(&nd, &up)
    } else {
        let points = || -> Vec<Point3> {
            (0..opened.len())
                .filter(|&v| opened[v])
                .map(&world)
                .collect()
        };
        let (start, dir, r0) = vaj::march_start(ct, &found.track);
        let (mut pl, mut prof) = vaj::measure(points(), voxel_mm3, start, dir, r0, sp, false);
        report.method = match pl {
            Some(_) => "where the sinus descent flattens into the LVOT, or the end of the region below it (area profile perpendicular to the marched centreline), then where the least sections below it stop narrowing (profile.floor)".into(),
            None => "none: no sinus descent was seen along the marched centreline, the region is kept as the IDT stopped it".into(),
        };
        let commissures3 = <[Point3; 3]>::try_from(commissures).ok();
        if let (Some(c), Some(p)) = (commissures3, pl) {
            if vaj::off_the_root(&p, &c) {
                if let Some(q) = alone().filter(|q| !vaj::off_the_root(q, &c)) {
                    pl = Some(q);
                    report.method = "the VAJ plane of the CT segmented without landmarks (the march along the track left the root)".into();
                } else if let Some((start, dir, r0)) = vaj::march_start_at_commissures(&c) {
                    (pl, prof) = vaj::measure(points(), voxel_mm3, start, dir, r0, sp, true);
                    report.method = "where the sinus descent flattens into the LVOT along the commissures' axis (the march along the track left the root), then where the least sections below it stop narrowing (profile.floor)".into();
                }
            }
        }
        report.profile = prof;
        pl
    };
    (plane, report)
}

/// Whether the commissures' centroid lies in the mask `keep` on the grid
/// of `roi`, in words for `segment.json` ("WARNING" when it does not).
fn commissure_check(commissures: &[Point3], roi: &Volume<u8>, keep: &[bool]) -> String {
    if commissures.is_empty() {
        return "no commissures".to_string();
    }
    let dims = roi.dims();
    let cc = Point3::from(
        commissures
            .iter()
            .fold(Vector3::zeros(), |a, p| a + p.coords)
            / 3.0,
    );
    let ii = roi.world_to_index(&cc).map(|x| x.round() as i64);
    let inside = (0..3).all(|a| ii[a] >= 0 && (ii[a] as usize) < dims[a])
        && keep[ii[0] as usize + dims[0] * (ii[1] as usize + dims[1] * ii[2] as usize)];
    if inside {
        "commissure centroid inside the mask: seed confirmed".into()
    } else {
        "WARNING: commissure centroid outside the mask".into()
    }
}

/// The first of the track's centres (on the ROI `box_` of grid `dims`)
/// whose voxel is `above` the threshold: where the lumen is grown from.
fn seed_voxel(
    ct: &Volume<i16>,
    found: &track::Found,
    box_: &roi::RoiBox,
    dims: [usize; 3],
    above: &[bool],
    threshold: f64,
) -> Result<usize> {
    let to_roi = |t: &TrackPoint| -> Option<usize> {
        let (i, j, k) = (
            t.i.round() as i64 - box_.lo[0] as i64,
            t.j.round() as i64 - box_.lo[1] as i64,
            t.k as i64 - box_.lo[2] as i64,
        );
        (i >= 0
            && j >= 0
            && k >= 0
            && (i as usize) < dims[0]
            && (j as usize) < dims[1]
            && (k as usize) < dims[2])
            .then(|| i as usize + dims[0] * (j as usize + dims[1] * k as usize))
    };
    found
        .track
        .iter()
        .filter_map(to_roi)
        .find(|&v| above[v])
        .ok_or_else(|| {
            let s = track::world(ct, &found.track[0]);
            Error::failed(
                "segment",
                format!(
                    "the tracked aortic centre is below the threshold {threshold:.0} HU on every slice ({} tracked from the seed circle r {:.1} mm, circleness {:.2}, at {:.0}, {:.0}, {:.0} mm LPS): no seed voxel; landmarks C1–C3 on the aortic root let segment start there instead",
                    found.track.len(),
                    found.track[0].r_mm,
                    found.track[0].c,
                    s.x,
                    s.y,
                    s.z
                ),
            )
        })
}

/// The box the lumen is segmented in: the track, the landmarks, the
/// ascending aorta well above the STJ, and how far the lumen reaches from
/// the track (at `threshold`, in `blood`); from the commissures, capped
/// below the arch.
fn region_of_interest(
    ct: &Volume<i16>,
    found: &track::Found,
    landmarks: Option<&Landmarks>,
    commissures3: Option<&[Point3; 3]>,
    (threshold, blood): (f64, f64),
    clock: &mut Clock,
) -> (roi::RoiBox, Option<reach::Reach>) {
    let mut lm_points: Vec<Point3> = landmarks
        .map(|l| l.points.iter().map(|(_, q)| *q).collect())
        .unwrap_or_default();
    // The ascending aorta the valve and the report need reaches well above
    // the STJ even where the axial track stops early (a tilted or
    // elliptical section): the box holds the axis that far up.
    if let Some((centre, axis, _)) = commissures3.and_then(anchor::circumcircle) {
        let up = if axis.z < 0.0 { -axis } else { axis };
        lm_points.push(centre + up * ASCENDING_ABOVE_MM);
    }
    // The lumen is followed on a coarse grid to see how far the root, the
    // LV entrance and the ascending aorta reach (an axial track stops early
    // on a tilted aorta). Anchored at the commissures it need not go far:
    // past the arch it would only add the descending aorta.
    let max_path = match commissures3 {
        Some(_) => ANCHORED_REACH_MM,
        None => reach::MAX_PATH_MM,
    };
    let reach = reach::lumen_reach(ct, &found.track, threshold, blood, max_path);
    clock.lap("lumen_reach");
    let mut box_ = roi::roi_box(ct, &found.track, found.dk, &lm_points, reach.as_ref());
    // From the commissures the lumen followed may enter the arch and its
    // branches (loops of vessels: tunnels in the wall surface); the
    // ascending aorta the valve needs ends below that height.
    if let Some(c) = commissures3 {
        let top = c.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max) + ASCENDING_TOP_MM;
        let k = ct.world_to_index(&Point3::new(c[0].x, c[0].y, top))[2].ceil();
        let k = (k.max(0.0) as usize + 1).min(box_.hi[2]);
        box_.hi[2] = k.max(box_.lo[2] + 1);
    }
    (box_, reach)
}

/// `opened` without what lies below the VAJ plane `pl` near it (far away
/// the curved aorta may pass "below" the annulus plane), and then only
/// what stays joined to `ground`.
fn below_vaj_removed(
    opened: &[bool],
    dims: [usize; 3],
    ground: usize,
    pl: &vaj::Plane,
    world: impl Fn(usize) -> Point3,
) -> Vec<bool> {
    let mut keep = opened.to_vec();
    let c = Point3::from(pl.point_mm);
    for (v, kv) in keep.iter_mut().enumerate() {
        if *kv {
            let q = world(v);
            if pl.height(&q) < 0.0 && (q - c).norm() < 45.0 {
                *kv = false;
            }
        }
    }
    morphology::flood_fill(&keep, dims, ground)
}

/// A lumen far larger than a tube of the tracked radius has leaked into a
/// neighbouring chamber: refused, never passed on.
fn refuse_a_leak(tube: &TubeCheck, final_ml: f64, nadirs_given: bool) -> Result<()> {
    if tube.ratio > MAX_TUBE_RATIO {
        // The nadirs bound the root from below; when they were given the
        // leak passed their plane, so they are what to check.
        let advice = if nadirs_given {
            "the plane through the nadirs N1–N3 given let it through: check that they lie on the annulus, at the lowest points of the cusps' hinges (a nadir placed in the ventricle moves the plane below the annulus)"
        } else {
            "give the landmarks C1–C3 and N1–N3, which bound the root, or crop the CT closer to the aorta"
        };
        return Err(Error::failed(
            "segment",
            format!(
                "the segmented lumen ({:.0} ml over {:.0} mm along the aorta) is {:.1} times the volume of a tube of the tracked radius {:.1} mm: it has leaked into a neighbouring chamber (left atrium or ventricle), and a leaked mask is not passed on; {advice}",
                final_ml, tube.length_mm, tube.ratio, tube.radius_mm
            ),
        ));
    }
    Ok(())
}

/// Segment the aortic root and ascending aorta of `ct`.
pub fn segment(
    ct: &Volume<i16>,
    landmarks: Option<&Landmarks>,
    p: &SegmentParams,
) -> Result<Segmentation> {
    let mut clock = Clock(Instant::now(), Vec::new());
    let commissures3 = landmarks
        .and_then(|l| l.require(&["C1", "C2", "C3"]).ok())
        .and_then(|v| <[Point3; 3]>::try_from(v).ok());
    let input = ct;
    let work = work_volume(ct, commissures3.as_ref())?;
    let ct = &work;
    clock.lap("work_grid");
    let found = match &commissures3 {
        Some(c) => anchor::from_commissures(ct, c, &p.hough),
        None => track::find_aorta(ct, &p.hough),
    }
    .map_err(|e| match (e, hu_hint(input)) {
        (Error::Failed { stage, problem }, Some(hint)) => {
            Error::failed(stage, format!("{problem}; {hint}"))
        }
        (e, _) => e,
    })?;
    clock.lap("hough_track");

    let pool = blood_pool::measure(ct, &found, p.contrast_min_hu)?;
    let threshold = pool.threshold;
    let seed = found.track[0];
    let seed_w = track::world(ct, &seed);
    let last = found.track.last().expect("seeded");
    let tracked_length = (track::world(ct, last) - seed_w).norm();

    let (box_, reach) = region_of_interest(
        ct,
        &found,
        landmarks,
        commissures3.as_ref(),
        (threshold, pool.blood),
        &mut clock,
    );
    // `roi_vol` carries the cropped grid (dims, exact affine); `img` its HU.
    let (roi_vol, mut img) = roi::crop_f32(ct, &box_)?;
    let dims = roi_vol.dims();
    let rsp = roi_vol.spacing();
    let n = roi_vol.len();
    clock.lap("roi_crop");
    filter::smooth3(&mut img, dims, rsp, p.smooth_mm);
    clock.lap("smooth");

    let above: Vec<bool> = img.iter().map(|&v| v as f64 >= threshold).collect();
    let ground = seed_voxel(ct, &found, &box_, dims, &above, threshold)?;
    let region = morphology::flood_fill(&above, dims, ground);
    drop(above);
    let vox_ml = roi_vol.voxel_volume() / 1000.0;
    let region_n = region.iter().filter(|&&r| r).count();
    // The IDT runs on the region's bounding box grown by one voxel: that
    // layer is background (or the ROI's border, as on the ROI), so every
    // inside distance, the tree and the cuts are those of the whole ROI, on
    // a fraction of its voxels (the ROI holds the LV and much background).
    let rbox = morphology::SubBox::around(&region, dims, [1, 1, 1]);
    let rdims = rbox.dims();
    let region_s = rbox.extract(&region, dims);
    let ground_s = rbox.to_inner(ground, dims).ok_or_else(|| {
        Error::failed(
            "segment",
            "the seed voxel fell outside its own threshold region",
        )
    })?;
    drop(region);
    clock.lap("threshold_fill");
    let (kept, idt) = idt_stop(
        &region_s, rdims, rsp, ground_s, region_n, &roi_vol, p.rule, &mut clock,
    );
    let mut idt_region = vec![false; n];
    for &v in &kept {
        idt_region[rbox.to_outer(v as usize, dims)] = true;
    }
    drop(kept);
    let idt_ml = idt.k_chosen as f64 * vox_ml;

    let opened = open_and_fill(&idt_region, dims, rsp, ground, p.open_mm);
    drop(idt_region);
    let opened_n = opened.iter().filter(|&&v| v).count();
    clock.lap("opening");

    // --- VAJ -------------------------------------------------------------------
    let world = |v: usize| {
        roi_vol.index_to_world([
            (v % dims[0]) as f64,
            ((v / dims[0]) % dims[1]) as f64,
            (v / (dims[0] * dims[1])) as f64,
        ])
    };
    let nadirs = landmarks.and_then(|l| l.require(&["N1", "N2", "N3"]).ok());
    let commissures = landmarks
        .and_then(|l| l.require(&["C1", "C2", "C3"]).ok())
        .unwrap_or_default();
    let (plane, mut vaj_report) = vaj_plane(
        nadirs.as_deref(),
        &commissures,
        ct,
        &found,
        &opened,
        world,
        roi_vol.voxel_volume(),
        rsp,
        || {
            segment(input, None, p)
                .ok()
                .and_then(|s| s.report.vaj.plane)
        },
    );
    let mut keep = match &plane {
        Some(pl) => below_vaj_removed(&opened, dims, ground, pl, world),
        None => opened.clone(),
    };
    if plane.is_some() {
        vaj_report.plane = plane;
    }
    let root_fill = plane.map(|pl| {
        let slab = root_slab(
            &pl,
            &commissures,
            nadirs.as_deref(),
            found.track.last().map(|t| t.r_mm),
        );
        let added = root_fill::fill_cusps(&mut keep, dims, rsp, world, &slab);
        root_fill::RootFill {
            slab,
            close_mm: root_fill::CLOSE_MM,
            added_ml: added as f64 * vox_ml,
        }
    });
    clock.lap("root_fill");
    let (keep, topology) = cut_above_root(
        keep,
        dims,
        world,
        commissures3.as_ref(),
        vaj_report.plane.as_ref(),
        ground,
    );
    let final_n = keep.iter().filter(|&&v| v).count();
    vaj_report.removed_ml = (opened_n.saturating_sub(final_n)) as f64 * vox_ml;
    clock.lap("vaj");
    let tube = tube_check(
        &keep,
        world,
        &found,
        &seed_w,
        vaj_report.plane.as_ref(),
        vox_ml,
    );
    refuse_a_leak(&tube, final_n as f64 * vox_ml, nadirs.is_some())?;

    let landmarks_check = landmarks.map(|_| commissure_check(&commissures, &roi_vol, &keep));
    if landmarks_check
        .as_deref()
        .is_some_and(|s| s.starts_with("WARNING"))
    {
        return Err(Error::failed(
            "segment",
            "the segmented lumen does not contain the centroid of the commissure landmarks C1–C3: the seed found on the top slice is not the aorta that holds the valve",
        ));
    }

    let mask = Volume::from_fortran_vec(
        dims,
        *roi_vol.affine(),
        keep.iter().map(|&v| v as u8).collect(),
    )?;
    clock.lap("output");
    let report = Report {
        seed_mm: [seed_w.x, seed_w.y, seed_w.z],
        seed_radius_mm: seed.r_mm,
        seed_circleness: seed.c,
        candidates: found.candidates.clone(),
        tracked_slices: found.track.len(),
        tracked_length_mm: tracked_length,
        track: found.track.clone(),
        blood_hu: pool.blood,
        noise_hu: pool.noise,
        wall_hu: pool.wall,
        threshold_hu: threshold,
        roi: box_.report(ct),
        reach,
        idt,
        vaj: vaj_report,
        root_fill,
        topology,
        tube,
        volumes_ml: Volumes {
            threshold_region: region_n as f64 * vox_ml,
            idt_region: idt_ml,
            opened: opened_n as f64 * vox_ml,
            final_mask: final_n as f64 * vox_ml,
        },
        landmarks_check,
        timings_s: clock.1,
    };
    Ok(Segmentation {
        mask,
        report,
        top_circleness: found.top_map,
        work,
        top_k: found.top_k,
    })
}
