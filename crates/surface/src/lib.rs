//! The `surface` stage: the aortic lumen mask → a closed, outward-oriented
//! wall mesh in LPS mm with caps labelled.
//!
//! [`marching_cubes::extract`] is the crack-free, flying-edges style
//! extractor (case table in [`tables`]); [`surface_from_mask`] is the stage's
//! library function: optional Gaussian pre-blur, extraction, the largest
//! component, Taubin smoothing ([`smooth`]), cap labels ([`regions`]) and
//! optional isotropic remeshing that keeps the labels ([`remesh`]).

pub mod blur;
pub mod components;
mod huge_pages;
pub mod marching_cubes;
pub mod regions;
pub mod remesh;
pub mod smooth;
pub mod stage;
pub mod stage_params;
pub mod tables;

#[cfg(test)]
mod tests;

use std::time::Instant;

use serde::Serialize;

use coapt_base::{Error, Result};
use coapt_geom::{DataArray, DataValues, Frame, TriMesh, Volume};
pub use marching_cubes::{Isosurface, extract};
pub use remesh::{RemeshParams, RemeshReport};
pub use smooth::Taubin;

/// Parameters of [`surface_from_mask`].
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceParams {
    /// Iso level on the (blurred) mask; inside is value > iso.
    pub iso: f64,
    /// Gaussian pre-blur of the binary mask, mm; 0 = none.
    pub blur_sigma_mm: f64,
    pub taubin: Taubin,
    /// Keep only the largest connected component.
    pub largest_only: bool,
    /// Isotropic remeshing after smoothing and labelling; `None`: off.
    pub remesh: Option<RemeshParams>,
}

impl Default for SurfaceParams {
    fn default() -> Self {
        SurfaceParams {
            iso: 0.5,
            blur_sigma_mm: 0.0,
            taubin: Taubin::default(),
            largest_only: true,
            remesh: None,
        }
    }
}

/// What `surface.json` records.
#[derive(Debug, Clone, Serialize)]
pub struct SurfaceReport {
    pub vertices: usize,
    pub triangles: usize,
    pub raw_vertices: usize,
    pub raw_triangles: usize,
    pub components_dropped: usize,
    pub euler_characteristic: i64,
    pub area_mm2: f64,
    pub enclosed_volume_mm3: f64,
    pub raw_volume_mm3: f64,
    /// (smoothed − raw) / raw volume of the kept component, percent.
    pub smoothing_volume_change_pct: f64,
    pub cap_triangles: [usize; 2],
    /// Present when the surface was remeshed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub remesh: Option<RemeshReport>,
    pub timing_s: Timings,
}

#[derive(Debug, Clone, Default, Serialize)]
pub struct Timings {
    pub blur: f64,
    pub marching_cubes: f64,
    pub component: f64,
    pub smoothing: f64,
    pub regions: f64,
    pub remesh: f64,
}

/// Mask → labelled wall mesh. Fails (stage failure) on an empty mask.
pub fn surface_from_mask(
    mask: &Volume<u8>,
    params: &SurfaceParams,
) -> Result<(TriMesh, SurfaceReport)> {
    let mut tm = Timings::default();
    let t = Instant::now();
    let iso = if params.blur_sigma_mm > 0.0 {
        let blurred = blur::blurred(mask, params.blur_sigma_mm)?;
        tm.blur = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let iso = blurred.map(|v| extract(&v, params.iso)).unwrap_or_default();
        tm.marching_cubes = t.elapsed().as_secs_f64();
        iso
    } else {
        let iso = extract(mask, params.iso);
        tm.marching_cubes = t.elapsed().as_secs_f64();
        iso
    };
    if iso.triangles.is_empty() {
        return Err(Error::failed(
            "surface",
            format!(
                "the mask has no voxel above {} (empty segmentation?)",
                params.iso
            ),
        ));
    }
    let (raw_vertices, raw_triangles) = (iso.vertices.len(), iso.triangles.len());

    let t = Instant::now();
    let mut mesh = TriMesh::new(iso.vertices, iso.triangles);
    mesh.frame = Frame::Lps;
    let (mut mesh, kept, dropped) = if params.largest_only {
        let (_, count) = mesh.triangle_components();
        let (m, kept) = components::largest_component(&mesh);
        (m, kept, count - 1)
    } else {
        let n = mesh.vertices.len() as u32;
        (mesh, (0..n).collect(), 0)
    };
    let on_border: Vec<bool> = kept.iter().map(|&v| iso.on_border[v as usize]).collect();
    tm.component = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let raw_volume = mesh.signed_volume();
    smooth::taubin(&mut mesh, &params.taubin);
    let smoothed_volume = mesh.signed_volume();
    tm.smoothing = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let sp = mask.spacing();
    let h = (sp[0] * sp[1] * sp[2]).cbrt();
    let mut region = regions::label(&mesh, &on_border, h);
    tm.regions = t.elapsed().as_secs_f64();

    let mut remesh_report = None;
    if let Some(rp) = &params.remesh {
        let t = Instant::now();
        let (m, r, rep) = remesh::remesh(&mesh, &region, rp)?;
        check_remeshed(&mesh, &m)?;
        (mesh, region) = (m, r);
        remesh_report = Some(rep);
        tm.remesh = t.elapsed().as_secs_f64();
    }
    let volume = mesh.signed_volume();
    let caps = [
        region.iter().filter(|&&r| r == regions::CUT_CAP).count(),
        region.iter().filter(|&&r| r == regions::BORDER_CAP).count(),
    ];
    mesh.cell_data.insert(DataArray::new(
        "region",
        1,
        DataValues::I32(region.into_iter().map(i32::from).collect()),
    ));
    mesh.field_data.insert(DataArray::string("units", "mm"));

    let topo = mesh.topology();
    let report = SurfaceReport {
        vertices: mesh.vertices.len(),
        triangles: mesh.triangles.len(),
        raw_vertices,
        raw_triangles,
        components_dropped: dropped,
        euler_characteristic: topo.euler_characteristic,
        area_mm2: mesh.total_area(),
        enclosed_volume_mm3: volume,
        raw_volume_mm3: raw_volume,
        smoothing_volume_change_pct: 100.0 * (smoothed_volume - raw_volume) / raw_volume,
        cap_triangles: caps,
        remesh: remesh_report,
        timing_s: tm,
    };
    Ok((mesh, report))
}

/// The remeshed surface must be as closed and of the same topology as its input.
fn check_remeshed(before: &TriMesh, after: &TriMesh) -> Result<()> {
    let fail =
        |what: String| Error::failed("surface", format!("remeshing broke the surface: {what}"));
    after.sanity_check().map_err(|e| fail(e.to_string()))?;
    let (a, b) = (before.topology(), after.topology());
    if b.boundary_edges != 0 || b.euler_characteristic != a.euler_characteristic {
        return Err(fail(format!(
            "{} open edges, Euler characteristic {} (was {})",
            b.boundary_edges, b.euler_characteristic, a.euler_characteristic
        )));
    }
    Ok(())
}
