//! Synthetic contrast CT angiogram (ceCTA) of an aortic root with exact
//! ground truth.
//!
//! Every later stage (segmentation, surface, valve landmarks, suture paths)
//! is tested on these phantoms, so they are hard in the ways real scans are:
//! an oblique, curved root with three asymmetric sinuses; coronaries leaving
//! the sinuses; a pulmonary trunk 1.5–3 mm from the aorta (the gap barely
//! survives the blur) with its right branch behind the ascending aorta; a
//! left atrium close behind the root; an LV continuous with the LVOT; a
//! descending aorta beside a spine whose cancellous bone has contrast-like
//! HU; partial volume, scanner blur, correlated noise and int16 quantisation.
//!
//! # Frames
//! World coordinates are LPS millimetres (x → patient left, y → posterior,
//! z → superior). The CT grid is an axis-aligned axial series (i → +x,
//! j → +y, k → +z). The valve frame has its origin at the annulus (VAJ)
//! centre, its axis along the centreline tangent there (LV → aorta, tilted
//! by `tilt_rad` from +z towards right-anterior) and e1 towards commissure C1.
//!
//! # Anatomy
//! The lumen of LVOT, root and ascending aorta is a tube about a centreline
//! of three exact pieces (straight along the valve axis, a circular arc
//! turning it into +z, straight along +z through the top of the volume).
//! A point is inside when its distance ρ to its closest centreline point is
//! below r(s, θ), θ measured in the rotation-minimising frame. The radius
//! goes from the annulus radius (mildly elliptic LVOT, circular at the VAJ)
//! through three sinus lobes (zero at the commissures, per-sinus amplitude)
//! to the sinotubular junction (STJ) and the ascending aorta (circular).
//! Sinus 1 (C1–C2) is the right-coronary sinus (anterior), sinus 2 (C2–C3)
//! the left-coronary sinus (left-posterior), sinus 3 (C3–C1) the
//! non-coronary sinus (right-posterior).
//!
//! # Truth
//! * **Truth mask**: a voxel is 1 when its centre lies strictly inside the
//!   analytic lumen tube, at or above the VAJ plane (valve-frame height ≥ 0),
//!   and outside every calcium blob. Coronaries, LV, LVOT below the VAJ,
//!   pulmonary artery and left atrium are excluded by construction.
//! * **Truth surface**: the analytic wall from the VAJ plane (cap, region 1)
//!   to the top cap (region 2) in the plane of the volume's top face (top
//!   slice centre + half a voxel), wall = region 0; closed, outward normals.
//! * **Lumen volume**: ∫∫ r²/2 dθ ds between the two caps, exact for this
//!   tube (see `lumen.rs`), by Gauss–Legendre quadrature.
//! * **Landmarks**: commissures C1–C3 on the wall at height h_comm at the
//!   commissure angles; nadirs N1–N3 on the wall at height 0 at the sinus
//!   centres.
//!
//!   The calcium blobs are not cut out of the surface or the lumen volume;
//!   `calcium_in_lumen_mm3` gives their overlap with the truth region.
//! * **Options** (all off except in the `clinical` preset): with an annulus
//!   tilt the VAJ plane above is the tilted annulus plane through the
//!   annulus centre (nadirs on it, commissures still at h_comm) and the
//!   LVOT below it stands square to that plane; with an
//!   arch the truth region ends at a plane z = const 8 mm below the arch's
//!   start; native cusps lie inside the lumen and so inside the mask.
//!
//! # Imaging
//! Tissue layers are painted in order (body fat and soft tissue, lungs,
//! mediastinal fat, myocardium, vessel walls, blood pools, bone, calcium;
//! walls come before blood so the ostia stay open, see `scene.rs`), each
//! with analytic partial volume (coverage
//! clamp(0.5 − d/w, 0, 1), w the voxel extent projected on the normal),
//! blurred by a Gaussian PSF of 0.8 mm FWHM, given Gaussian noise
//! (counter-based, lightly correlated in-plane, rescaled to exactly
//! `noise_hu` std) and rounded to int16 in [−1024, 3071]. Same parameters →
//! bit-identical output whatever the thread count.

mod anatomy;
mod centreline;
mod cusps;
mod lumen;
mod render;
mod scene;
mod shapes;
pub mod stage;
pub mod stage_params;
pub mod structures;
mod truth;

use std::fmt;
use std::str::FromStr;
use std::sync::Arc;

pub use anatomy::SINUS_NAMES;
pub use centreline::{CentrelineDescription, PieceArc, PieceLine};
pub use lumen::RadiusProfile;
pub use truth::{CoronaryTruth, Radii, SinusRadius, Truth};

use coapt_base::rng::mix64;
use coapt_base::{Error, Result};
use coapt_geom::volume::affine_from_parts;
use coapt_geom::{Frame, Landmarks, Matrix3, Point3, TriMesh, ValveFrame, Volume};

/// Size of the phantom.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Preset {
    /// 112×112×112 at 0.9×0.9×1.0 mm: small enough to commit.
    Sample,
    /// 256×256×200 at 0.7×0.7×0.8 mm.
    Standard,
    /// 512×512×300 at 0.44×0.44×0.6 mm, as a real ceCTA.
    Full,
    /// 128×128×160 at 1.5 mm isotropic, like the real CT in
    /// `/work/shared/real`: arch and descending aorta in view, closed native
    /// cusps, annulus tilted 20° to the commissures, that CT's blood HU and
    /// noise.
    Clinical,
}

impl Preset {
    pub fn dims(self) -> [usize; 3] {
        match self {
            Preset::Sample => [112, 112, 112],
            Preset::Standard => [256, 256, 200],
            Preset::Full => [512, 512, 300],
            Preset::Clinical => [128, 128, 160],
        }
    }

    pub fn spacing(self) -> [f64; 3] {
        match self {
            Preset::Sample => [0.9, 0.9, 1.0],
            Preset::Standard => [0.7, 0.7, 0.8],
            Preset::Full => [0.44, 0.44, 0.6],
            Preset::Clinical => [1.5, 1.5, 1.5],
        }
    }

    /// Field of view in mm (dims × spacing).
    pub fn fov(self) -> [f64; 3] {
        let (d, s) = (self.dims(), self.spacing());
        [d[0] as f64 * s[0], d[1] as f64 * s[1], d[2] as f64 * s[2]]
    }

    /// Target edge length of the truth surface.
    /// Longest truth-surface edge wanted (the sample's is relaxed to its
    /// vertex budget).
    fn surface_edge_mm(self) -> f64 {
        match self {
            Preset::Sample => 0.4,
            Preset::Standard | Preset::Full | Preset::Clinical => 0.5,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Preset::Sample => "sample",
            Preset::Standard => "standard",
            Preset::Full => "full",
            Preset::Clinical => "clinical",
        }
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Preset {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "sample" => Ok(Preset::Sample),
            "standard" => Ok(Preset::Standard),
            "full" => Ok(Preset::Full),
            "clinical" => Ok(Preset::Clinical),
            other => Err(Error::value(format!(
                "unknown phantom preset '{other}' (expected sample, standard, full or clinical)"
            ))),
        }
    }
}

/// Parameters of [`generate`].
#[derive(Debug, Clone, PartialEq)]
pub struct PhantomParams {
    pub preset: Preset,
    pub seed: u64,
    /// Standard deviation of the image noise (HU).
    pub noise_hu: f64,
    /// Angle between the valve axis and the scanner z axis.
    pub tilt_rad: f64,
    /// Overrides the preset spacing, keeping its field of view.
    pub spacing_mm: Option<[f64; 3]>,
    /// Without contrast, blood is ≈ 40 HU (segmentation must refuse it).
    pub contrast: bool,
    /// Aortic blood attenuation with contrast (HU).
    pub blood_hu: f64,
    /// Annular calcium blobs near the nadirs.
    pub calcium: bool,
    /// Coronary arteries leaving the sinuses. Off, they are absent from the
    /// CT and the truth record; the anatomy's random draws stay the same, so
    /// everything else is the same phantom.
    pub coronaries: bool,
    /// Arch and descending aorta joined in the field of view; the truth
    /// region then ends at a plane below the arch.
    pub arch: bool,
    /// Closed native cusps (thin soft-tissue sheets) inside the root.
    pub native_cusps: bool,
    /// Tilt of the annulus (nadir) plane to the commissure plane.
    pub annulus_tilt_rad: f64,
    /// Turn of the root about its axis (0: the right-coronary sinus faces
    /// anterior, as in most patients).
    pub root_rotation_rad: f64,
}

pub const DEFAULT_NOISE_HU: f64 = 25.0;
pub const DEFAULT_TILT_DEG: f64 = 35.0;
pub const DEFAULT_BLOOD_HU: f64 = 350.0;
/// The clinical preset's blood and noise: measured in the ascending aorta of
/// `/work/shared/real/ct.nii.gz` (5×5×5-voxel cubes at the lumen centre,
/// 10–30 slices above the commissures: means 477, 492, 483 HU, standard
/// deviations 29.2, 24.6, 29.4 HU).
pub const CLINICAL_BLOOD_HU: f64 = 480.0;
pub const CLINICAL_NOISE_HU: f64 = 28.0;
/// The real CT's valve axis is 21° from z, its nadir plane 15° from the
/// commissure plane (real roots: 15–26°).
pub const CLINICAL_TILT_DEG: f64 = 21.0;
pub const CLINICAL_ANNULUS_TILT_DEG: f64 = 20.0;
/// Largest annulus tilt accepted.
pub const MAX_ANNULUS_TILT_DEG: f64 = 35.0;

impl PhantomParams {
    /// The preset's defaults: the clinical preset switches on the arch, the
    /// native cusps and a 20° annulus tilt and takes the real CT's values.
    pub fn new(preset: Preset, seed: u64) -> Self {
        let clinical = preset == Preset::Clinical;
        PhantomParams {
            preset,
            seed,
            noise_hu: if clinical {
                CLINICAL_NOISE_HU
            } else {
                DEFAULT_NOISE_HU
            },
            tilt_rad: if clinical {
                CLINICAL_TILT_DEG
            } else {
                DEFAULT_TILT_DEG
            }
            .to_radians(),
            spacing_mm: None,
            contrast: true,
            blood_hu: if clinical {
                CLINICAL_BLOOD_HU
            } else {
                DEFAULT_BLOOD_HU
            },
            calcium: false,
            coronaries: true,
            arch: clinical,
            native_cusps: clinical,
            annulus_tilt_rad: if clinical {
                CLINICAL_ANNULUS_TILT_DEG.to_radians()
            } else {
                0.0
            },
            root_rotation_rad: 0.0,
        }
    }

    pub fn validate(&self) -> Result<()> {
        let check = |name: &str, v: f64, lo: f64, hi: f64, unit: &str| {
            // A hair of slack so 60° survives the degree/radian round trip.
            let slack = 1e-9 * hi.abs().max(1.0);
            if v.is_finite() && (lo - slack..=hi + slack).contains(&v) {
                Ok(())
            } else {
                // The flag and the run-config key ([phantom] section) alike.
                Err(Error::value(format!(
                    "--{} (phantom {name}) = {} {unit} is outside [{lo}, {hi}] {unit}",
                    name.replace(' ', "-"),
                    coapt_base::units::short(v)
                )))
            }
        };
        check("noise", self.noise_hu, 0.0, 200.0, "HU")?;
        check("tilt", self.tilt_rad.to_degrees(), 0.0, 60.0, "deg")?;
        check("blood", self.blood_hu, 100.0, 800.0, "HU")?;
        check(
            "annulus tilt",
            self.annulus_tilt_rad.to_degrees(),
            0.0,
            MAX_ANNULUS_TILT_DEG,
            "deg",
        )?;
        check(
            "root rotation",
            self.root_rotation_rad.to_degrees(),
            -180.0,
            180.0,
            "deg",
        )?;
        if let Some(s) = self.spacing_mm {
            for v in s {
                check("spacing", v, 0.2, 3.0, "mm")?;
            }
        }
        let (dims, _) = self.grid_shape();
        let voxels: usize = dims.iter().product();
        if voxels > MAX_VOXELS {
            return Err(Error::value(format!(
                "phantom grid {}×{}×{} has {voxels} voxels, more than the {MAX_VOXELS} this generator \
                 holds in memory (~11 bytes each): use a coarser spacing",
                dims[0], dims[1], dims[2]
            )));
        }
        Ok(())
    }

    /// The anatomy options of these parameters.
    pub(crate) fn extras(&self) -> anatomy::Extras {
        anatomy::Extras {
            arch: self.arch,
            native_cusps: self.native_cusps,
            annulus_tilt_rad: self.annulus_tilt_rad,
            root_rotation_rad: self.root_rotation_rad,
        }
    }

    /// Grid dimensions and spacing after the optional override.
    pub fn grid_shape(&self) -> ([usize; 3], [f64; 3]) {
        match self.spacing_mm {
            None => (self.preset.dims(), self.preset.spacing()),
            Some(s) => {
                let fov = self.preset.fov();
                let d = [0, 1, 2].map(|a| ((fov[a] / s[a]).round() as usize).max(1));
                (d, s)
            }
        }
    }
}

/// A generated phantom: CT, truth mask on the same grid, landmarks, truth
/// record and truth surface.
#[derive(Debug, Clone)]
pub struct Phantom {
    pub ct: Volume<i16>,
    pub truth_mask: Volume<u8>,
    pub landmarks: Landmarks,
    pub truth: Truth,
    pub truth_surface: TriMesh,
}

/// Largest grid generated: rendering keeps ~11 bytes per voxel in memory
/// (image and noise as f32, CT as i16, mask), so this is ~4.4 GB.
pub const MAX_VOXELS: usize = 400_000_000;
/// Maximal number of truth-surface vertices of the sample (~1 MB of f64 points).
const SURFACE_VERTEX_BUDGET: f64 = 40_000.0;
/// Share of the progress bar taken by rasterisation (the rest: blur, noise).
const RASTER_SHARE: f64 = 0.7;
/// Share of the spare z field of view put below the needed range (the LV).
const SPARE_BELOW: f64 = 0.6;

/// Where the grid lies in the world, and the heights the truth is cut at.
struct Placement {
    grid: render::Grid,
    /// The grid's bottom and top faces (world z, mm).
    z_bottom_face: f64,
    z_top: f64,
    /// Where the truth region ends: the top face, or with an arch below it.
    truth_top_z: f64,
    /// Top of the ascending lumen: the arch join, or beyond the top face.
    lumen_top_z: f64,
    /// The centreline's arc length at `truth_top_z`.
    s_top: f64,
}

/// Place the grid: in z the range the anatomy needs, the spare mostly
/// below it (the LV); in x and y centred on the root and the descending
/// aorta, refused when they span more than the grid.
fn place_grid(
    an: &anatomy::Anatomy,
    needs: anatomy::FovNeeds,
    dims: [usize; 3],
    spacing: [f64; 3],
) -> Result<Placement> {
    let fov = [0, 1, 2].map(|a| dims[a] as f64 * spacing[a]);
    let cl = &an.lumen.centreline;
    let extra = fov[2] - (needs.z_top - needs.z_bottom);
    let z_bottom_face = needs.z_bottom - SPARE_BELOW * extra;
    let z_top = z_bottom_face + fov[2];
    // The truth region ends at the top face, or with an arch below it.
    let truth_top_z = z_top.min(an.lumen.truth_top_z);
    // Top of the ascending lumen: the arch join, or beyond the top face.
    let lumen_top_z = an.arch.as_ref().map_or(z_top, |a| a.z_join);
    let s_top = cl.s_at_z_vertical(truth_top_z);
    let (lo, hi) = anatomy::xy_extent(
        cl,
        &an.lumen.profile,
        an.lumen.lvot_length_mm,
        an.lumen.r_max_mm,
        lumen_top_z,
        [an.da.cx, an.da.cy],
        an.da.rx,
    );
    for a in 0..2 {
        if hi[a] - lo[a] > fov[a] {
            return Err(Error::value(format!(
                "aortic root and descending aorta span {:.0} mm along {}, the grid only {:.0} mm: use a larger preset or spacing",
                hi[a] - lo[a],
                ["x", "y"][a],
                fov[a]
            )));
        }
    }
    let origin = Point3::new(
        0.5 * (lo[0] + hi[0]) - 0.5 * (dims[0] as f64 - 1.0) * spacing[0],
        0.5 * (lo[1] + hi[1]) - 0.5 * (dims[1] as f64 - 1.0) * spacing[1],
        z_bottom_face + 0.5 * spacing[2],
    );
    let grid = render::Grid {
        dims,
        spacing,
        origin,
    };
    debug_assert!((grid.z_top() - z_top).abs() < 1e-9);
    Ok(Placement {
        grid,
        z_bottom_face,
        z_top,
        truth_top_z,
        lumen_top_z,
        s_top,
    })
}

/// The truth surface up to arc length `s_top`, on a grid fine enough for
/// the preset's edge length (the committed sample's within its vertex
/// budget).
fn truth_surface(an: &anatomy::Anatomy, preset: Preset, s_top: f64) -> TriMesh {
    // Grid spacing so that even the quad diagonals respect the edge length.
    let mut grid_mm = preset.surface_edge_mm() / std::f64::consts::SQRT_2;
    if preset == Preset::Sample {
        // The sample is committed: keep its surface within the vertex budget.
        while {
            let (n_s, n_t) = an.lumen.surface_grid(s_top, grid_mm);
            ((n_s + 1) * n_t) as f64 > SURFACE_VERTEX_BUDGET
        } {
            grid_mm *= 1.02;
        }
    }
    let mut truth_surface = an.lumen.surface(s_top, grid_mm);
    truth_surface.frame = Frame::Lps;
    truth_surface
}

/// The true commissures, on the wall at their height and angles, and
/// nadirs, on the wall where the (possibly tilted) annulus plane meets it
/// at the sinus centres.
fn truth_points(an: &anatomy::Anatomy) -> ([Point3; 3], [Point3; 3]) {
    let profile = &an.lumen.profile;
    let commissures: [Point3; 3] = [0, 1, 2].map(|k| {
        an.lumen
            .wall_point(an.h_comm_mm, profile.commissure_angles_rad[k])
    });
    let nadirs: [Point3; 3] = [0, 1, 2].map(|k| {
        let th = profile.sinus_centre(k);
        an.lumen.wall_point(profile.annulus_s(th).0, th)
    });
    (commissures, nadirs)
}

/// Generate the phantom for `params`; `progress` receives values in [0, 1].
pub fn generate(params: &PhantomParams, progress: &(dyn Fn(f64) + Sync)) -> Result<Phantom> {
    params.validate()?;
    progress(0.0);
    let (dims, spacing) = params.grid_shape();
    let fov = [0, 1, 2].map(|a| dims[a] as f64 * spacing[a]);
    let extras = params.extras();
    let (mut an, needs) = anatomy::Anatomy::new(params.seed, params.tilt_rad, fov, extras)?;
    if !params.coronaries {
        an.coronaries.clear();
    }
    let an = Arc::new(an);
    let cl = &an.lumen.centreline;

    let place = place_grid(&an, needs, dims, spacing)?;
    let Placement {
        grid,
        z_bottom_face,
        z_top,
        truth_top_z,
        lumen_top_z,
        s_top,
    } = place;
    let affine = affine_from_parts(spacing, &Matrix3::identity(), grid.origin);

    // --- Image and truth mask.
    let scene = scene::Scene::new(
        an.clone(),
        scene::Contrast {
            enabled: params.contrast,
            blood_hu: params.blood_hu,
            calcium: params.calcium,
        },
        (z_bottom_face, z_top),
    );
    let noise_seed = mix64(params.seed ^ 0x6E01_5E00_C0A7_0001);
    let raster = render::rasterise(
        &scene,
        &grid,
        noise_seed,
        params.calcium,
        progress,
        RASTER_SHARE,
    );
    let ct_values = render::finish(&raster, &grid, params.noise_hu, progress, RASTER_SHARE);
    let mask_voxels = raster.mask.iter().filter(|&&m| m != 0).count();
    let ct = Volume::from_fortran_vec(dims, affine, ct_values)?;
    let truth_mask = Volume::from_fortran_vec(dims, affine, raster.mask)?;

    let truth_surface = truth_surface(&an, params.preset, s_top);

    let (commissures, nadirs) = truth_points(&an);
    let mut landmarks = Landmarks::new(Frame::Lps);
    for (k, c) in commissures.iter().enumerate() {
        landmarks.push(format!("C{}", k + 1), *c);
    }
    for (k, n) in nadirs.iter().enumerate() {
        landmarks.push(format!("N{}", k + 1), *n);
    }
    let valve_frame = ValveFrame::new(cl.origin, cl.axis, commissures, Some(nadirs))
        .ok_or_else(|| Error::failed("phantom", "degenerate valve frame"))?;
    let profile = &an.lumen.profile;

    // --- Truth record.
    let mut aff = [[0.0; 4]; 4];
    for (r, row) in aff.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = affine[(r, c)];
        }
    }
    let calcium_in_lumen = if params.calcium {
        calcium_overlap(&an)
    } else {
        0.0
    };
    let truth = Truth {
        preset: params.preset.name().into(),
        seed: params.seed,
        frame: "LPS".into(),
        dims,
        spacing_mm: spacing,
        affine: aff,
        noise_hu: params.noise_hu,
        blood_hu: if params.contrast {
            params.blood_hu
        } else {
            scene::BLOOD_PLAIN_HU
        },
        contrast: params.contrast,
        calcium: params.calcium,
        tilt_deg: params.tilt_rad.to_degrees(),
        tilt_azimuth_deg: an.tilt_azimuth_rad.to_degrees(),
        valve_frame,
        commissures_mm: commissures.map(|p| truth::arr(&p)),
        nadirs_mm: nadirs.map(|p| truth::arr(&p)),
        commissure_angles_deg: profile.commissure_angles_rad.map(f64::to_degrees),
        h_stj_mm: profile.h_stj_mm,
        h_comm_mm: an.h_comm_mm,
        radii: truth::radii(&an),
        coronaries: an
            .coronaries
            .iter()
            .map(|c| CoronaryTruth {
                name: c.name.into(),
                sinus: SINUS_NAMES[c.sinus].into(),
                ostium_mm: truth::arr(&c.ostium),
                ostium_height_mm: c.ostium_height_mm,
                radius_mm: c.radius_mm,
            })
            .collect(),
        centreline: cl.describe(-an.lumen.lvot_length_mm),
        radius_profile: profile.clone(),
        top_cap_z_mm: truth_top_z,
        top_cap_s_mm: s_top,
        lumen_volume_mm3: an.lumen.volume(s_top),
        truth_mask_voxels: mask_voxels,
        truth_mask_volume_mm3: mask_voxels as f64 * spacing.iter().product::<f64>(),
        truth_surface_area_mm2: truth_surface.total_area(),
        truth_wall_area_mm2: wall_area(&truth_surface),
        truth_surface_volume_mm3: truth_surface.signed_volume(),
        truth_surface_vertices: truth_surface.vertices.len(),
        calcium_in_lumen_mm3: calcium_in_lumen,
        pa_aorta_lumen_gap_mm: an.pa_aorta_gap(lumen_top_z),
        pa_radius_mm: an.pa_radius_mm,
        la_aorta_gap_mm: an.la_aorta_gap(lumen_top_z),
        layers: scene.layers.iter().map(|l| l.name.clone()).collect(),
        definitions: truth::definitions(&extras),
        root_rotation_deg: (params.root_rotation_rad != 0.0)
            .then(|| params.root_rotation_rad.to_degrees()),
        annulus_tilt_deg: (params.annulus_tilt_rad != 0.0)
            .then(|| params.annulus_tilt_rad.to_degrees()),
        annulus_plane: (params.annulus_tilt_rad != 0.0).then(|| truth::PlaneTruth {
            point_mm: truth::arr(&cl.origin),
            normal: truth::arr(&Point3::from(an.lumen.annulus_normal())),
        }),
        commissure_plane: (params.annulus_tilt_rad != 0.0).then(|| truth::PlaneTruth {
            point_mm: truth::arr(&cl.station(an.h_comm_mm).point),
            normal: truth::arr(&Point3::from(cl.axis)),
        }),
        arch: an.arch.as_ref().map(|a| truth::ArchTruth {
            truth_region_end_z_mm: a.z_truth_end,
            join_z_mm: a.z_join,
            arch_top_lumen_z_mm: a.z_top_lumen,
            span_mm: a.span_mm,
            height_mm: a.height_mm,
            radius_start_mm: a.r_start_mm,
            radius_end_mm: a.r_end_mm,
            descending_centre_xy_mm: [an.da.cx, an.da.cy],
            descending_radius_mm: an.da.rx,
        }),
        native_cusps: an.cusps.map(|c| truth::CuspsTruth {
            thickness_mm: c.thickness_mm,
            centre_height_mm: c.h_centre_mm,
            free_edge_height_mm: c.h_free_mm,
            hu: scene::CUSP_HU,
        }),
    };
    progress(1.0);
    Ok(Phantom {
        ct,
        truth_mask,
        landmarks,
        truth,
        truth_surface,
    })
}

/// Area of the triangles of region 0 (the wall).
fn wall_area(mesh: &TriMesh) -> f64 {
    match mesh.cell_data.get("region").map(|a| &a.values) {
        Some(coapt_geom::DataValues::I32(r)) => (0..mesh.triangles.len())
            .filter(|&t| r[t] == 0)
            .map(|t| mesh.area(t))
            .sum(),
        _ => mesh.total_area(),
    }
}

/// Volume of calcium inside the truth region, by dense point sampling.
fn calcium_overlap(an: &anatomy::Anatomy) -> f64 {
    const STEP_MM: f64 = 0.05;
    use shapes::Sdf;
    let mut total = 0.0;
    for (i, e) in an.calcium.iter().enumerate() {
        let b = e.aabb();
        let n = [0, 1, 2].map(|a| ((b.hi[a] - b.lo[a]) / STEP_MM).ceil() as usize);
        let mut count = 0usize;
        for kz in 0..n[2] {
            for ky in 0..n[1] {
                for kx in 0..n[0] {
                    let p = b.lo
                        + coapt_geom::Vector3::new(
                            kx as f64 + 0.5,
                            ky as f64 + 0.5,
                            kz as f64 + 0.5,
                        ) * STEP_MM;
                    let inside_e = |e: &shapes::Ellipsoid| {
                        (e.rot.transpose() * (p - e.centre))
                            .component_div(&e.semi)
                            .norm_squared()
                            < 1.0
                    };
                    // Count each point once even where blobs overlap.
                    if inside_e(e)
                        && !an.calcium[..i].iter().any(inside_e)
                        && an.lumen.in_truth_range(&p)
                        && an.lumen.inside(&p)
                    {
                        count += 1;
                    }
                }
            }
        }
        total += count as f64 * STEP_MM.powi(3);
    }
    total
}

#[cfg(test)]
mod clinical_tests;
#[cfg(test)]
mod tests;
