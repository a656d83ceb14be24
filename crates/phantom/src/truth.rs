//! The truth record (truth.json): everything a later stage is scored against.

use std::collections::BTreeMap;

use serde::Serialize;

use super::anatomy::{Anatomy, Extras, SINUS_NAMES};
use super::centreline::CentrelineDescription;
use super::lumen::RadiusProfile;
use coapt_geom::{Point3, ValveFrame};

#[derive(Debug, Clone, Serialize)]
pub struct SinusRadius {
    pub sinus: usize,
    pub name: String,
    /// Commissure labels bounding the sinus.
    pub between: [String; 2],
    pub centre_angle_deg: f64,
    pub max_radius_mm: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Radii {
    /// At the VAJ plane (s = 0), where the cross-section is circular.
    pub annulus_mean_mm: f64,
    pub annulus_min_mm: f64,
    pub annulus_max_mm: f64,
    /// At the bottom of the LVOT, where the ellipticity is fully developed.
    pub lvot_min_mm: f64,
    pub lvot_max_mm: f64,
    pub sinus: Vec<SinusRadius>,
    pub stj_mm: f64,
    pub ascending_mm: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct CoronaryTruth {
    pub name: String,
    pub sinus: String,
    /// Where the artery's centreline crosses the analytic wall.
    pub ostium_mm: [f64; 3],
    pub ostium_height_mm: f64,
    pub radius_mm: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Truth {
    pub preset: String,
    pub seed: u64,
    pub frame: String,
    pub dims: [usize; 3],
    pub spacing_mm: [f64; 3],
    /// Voxel index → LPS mm, row-major 4×4.
    pub affine: [[f64; 4]; 4],
    pub noise_hu: f64,
    /// Aortic blood HU actually painted (40 without contrast).
    pub blood_hu: f64,
    pub contrast: bool,
    pub calcium: bool,
    pub tilt_deg: f64,
    pub tilt_azimuth_deg: f64,
    pub valve_frame: ValveFrame,
    pub commissures_mm: [[f64; 3]; 3],
    pub nadirs_mm: [[f64; 3]; 3],
    pub commissure_angles_deg: [f64; 3],
    pub h_stj_mm: f64,
    pub h_comm_mm: f64,
    pub radii: Radii,
    pub coronaries: Vec<CoronaryTruth>,
    pub centreline: CentrelineDescription,
    pub radius_profile: RadiusProfile,
    /// Height of the top cap (plane z = top face of the volume).
    pub top_cap_z_mm: f64,
    pub top_cap_s_mm: f64,
    pub lumen_volume_mm3: f64,
    pub truth_mask_voxels: usize,
    pub truth_mask_volume_mm3: f64,
    /// Area of the closed truth surface, caps included.
    pub truth_surface_area_mm2: f64,
    /// Area of its wall part only (region 0).
    pub truth_wall_area_mm2: f64,
    pub truth_surface_volume_mm3: f64,
    pub truth_surface_vertices: usize,
    /// Volume of calcium inside the truth region (removed from the mask);
    /// 0 without calcium.
    pub calcium_in_lumen_mm3: f64,
    pub pa_aorta_lumen_gap_mm: f64,
    pub pa_radius_mm: f64,
    /// Tissue gap between the left atrium and the aortic lumen.
    pub la_aorta_gap_mm: f64,
    /// Tissue layers in painting order (later layers cover earlier ones).
    pub layers: Vec<String>,
    pub definitions: BTreeMap<String, String>,
    /// Only with a turned root: the turn about its axis (counter-clockwise
    /// seen from the aorta; 0: the right-coronary sinus faces anterior).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub root_rotation_deg: Option<f64>,
    /// Only with a tilted annulus: its tilt and both planes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub annulus_tilt_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub annulus_plane: Option<PlaneTruth>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub commissure_plane: Option<PlaneTruth>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub arch: Option<ArchTruth>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub native_cusps: Option<CuspsTruth>,
}

/// A plane: a point on it and its unit normal (towards the aorta).
#[derive(Debug, Clone, Serialize)]
pub struct PlaneTruth {
    pub point_mm: [f64; 3],
    pub normal: [f64; 3],
}

#[derive(Debug, Clone, Serialize)]
pub struct ArchTruth {
    /// The truth region (mask, surface, volume) ends at the plane z = this.
    pub truth_region_end_z_mm: f64,
    /// The ascending lumen hands over to the arch tube at this z.
    pub join_z_mm: f64,
    pub arch_top_lumen_z_mm: f64,
    /// Horizontal distance between the ascending and descending axes.
    pub span_mm: f64,
    /// Rise of the arch centreline above the join.
    pub height_mm: f64,
    pub radius_start_mm: f64,
    pub radius_end_mm: f64,
    pub descending_centre_xy_mm: [f64; 2],
    pub descending_radius_mm: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct CuspsTruth {
    pub thickness_mm: f64,
    /// Valve-frame heights (along the axis above the annulus centre).
    pub centre_height_mm: f64,
    pub free_edge_height_mm: f64,
    pub hu: f64,
}

pub fn arr(p: &Point3) -> [f64; 3] {
    [p.x, p.y, p.z]
}

pub fn definitions(extras: &Extras) -> BTreeMap<String, String> {
    let mut extra = Vec::new();
    if extras.annulus_tilt_rad != 0.0 {
        extra.push((
            "annulus_plane",
            "The VAJ plane of the truth region is tilted: it passes through the annulus centre with normal annulus_plane.normal, at annulus_tilt_deg to the commissure plane (normal = valve axis). The nadirs lie on it; truth_mask and truth_surface start at it. The root profile is stretched per angle from this plane to the STJ.",
        ));
    }
    if extras.arch {
        extra.push((
            "arch",
            "Ascending aorta, arch and descending aorta are one lumen in the CT; the truth region (mask, surface, lumen volume) is only the root and ascending aorta, from the VAJ plane up to the plane z = arch.truth_region_end_z_mm (the top cap, top_cap_z_mm), below the arch.",
        ));
    }
    if extras.native_cusps {
        extra.push((
            "native_cusps",
            "Closed native cusps painted as thin soft-tissue sheets (bellies from the hinge line to a central point, three radial coaptation sheets up to the free edge). They lie inside the lumen and are part of truth_mask: the mask is the region inside the wall, not the blood only.",
        ));
    }
    [
        (
            "truth_mask",
            "Voxels whose centre lies strictly inside the analytic aortic lumen tube, at or above the VAJ plane (valve-frame height >= 0), and outside every calcium blob; coronaries, LV, LVOT below the VAJ, PA and LA are excluded.",
        ),
        (
            "truth_surface",
            "Closed triangulation of the truth region: the analytic wall from the VAJ plane up to the top cap (plane z = top face of the volume), with flat caps; region 0 wall, 1 VAJ cap, 2 top cap; calcium is not cut out.",
        ),
        (
            "valve_frame",
            "Origin at the annulus (VAJ) centre, axis the unit centreline tangent there pointing from the LV into the aorta, e1 perpendicular to the axis towards commissure C1.",
        ),
        (
            "commissure",
            "Point on the analytic wall, at height h_comm above the VAJ plane, where two sinus lobes meet (the sinus bulge is zero there).",
        ),
        (
            "nadir",
            "Point on the analytic wall in the VAJ plane (height 0) at the angle of a sinus centre: the lowest point of that leaflet's attachment line.",
        ),
        (
            "lumen_volume_mm3",
            "Volume of the tube between the VAJ plane and the top cap, the integral of r(s, theta)^2 / 2 over theta and arc length s (exact for this tube), computed by Gauss-Legendre quadrature; calcium is not subtracted.",
        ),
        (
            "sinus",
            "Sinus k lies between commissures Ck and C(k+1) (C4 = C1), counter-clockwise about the valve axis seen from the aorta.",
        ),
    ]
    .into_iter()
    .chain(extra)
    .map(|(k, v)| (k.to_string(), v.to_string()))
    .collect()
}

/// Radii summary from the profile.
pub fn radii(an: &Anatomy) -> Radii {
    let p = &an.lumen.profile;
    const N: usize = 3600;
    // At s = 0, or along a tilted annulus at its own arc length per angle.
    let sample = |s: f64| -> (f64, f64, f64) {
        let v: Vec<f64> = (0..N)
            .map(|j| {
                let th = std::f64::consts::TAU * j as f64 / N as f64;
                let s = if s == 0.0 { p.annulus_s(th).0 } else { s };
                p.eval(s, th).r
            })
            .collect();
        (
            v.iter().sum::<f64>() / N as f64,
            v.iter().copied().fold(f64::INFINITY, f64::min),
            v.iter().copied().fold(0.0, f64::max),
        )
    };
    let (mean, min, max) = sample(0.0);
    let (_, lmin, lmax) = sample(-an.lumen.lvot_length_mm);
    let sinus = (0..3)
        .map(|k| SinusRadius {
            sinus: k + 1,
            name: SINUS_NAMES[k].to_string(),
            between: [format!("C{}", k + 1), format!("C{}", (k + 1) % 3 + 1)],
            centre_angle_deg: p.sinus_centre(k).to_degrees(),
            max_radius_mm: p.sinus_max(k),
        })
        .collect();
    Radii {
        annulus_mean_mm: mean,
        annulus_min_mm: min,
        annulus_max_mm: max,
        lvot_min_mm: lmin,
        lvot_max_mm: lmax,
        sinus,
        stj_mm: p.r_stj_mm,
        ascending_mm: p.r_ascending_mm,
    }
}
