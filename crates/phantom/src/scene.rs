//! Tissue layers, painted in order: each later layer covers the earlier ones
//! by its partial-volume coverage.
//!
//! Order: body (fat, soft tissue) → lungs → paraspinal tissue → mediastinal
//! fat → myocardium → vessel walls → blood pools → bone → calcium. Walls are
//! painted *before* the blood, as a dilation of the lumen, so the blood of a
//! coronary ostium or of the LVOT overwrites them: the wall stays a shell
//! and the coronaries stay connected to the sinus lumen, as in a real scan.

use std::cell::Cell;
use std::sync::Arc;

use super::anatomy::{Anatomy, DISC_MM, LV_BLEND_MM};
use super::cusps;
use super::shapes::{Aabb, Sdf, Tube, ZCylinder, smooth_union, union};
use coapt_geom::{Point3, Vector3};

/// Tissue attenuation (HU).
pub const AIR_HU: f64 = -1000.0;
const LUNG_HU: f64 = -850.0;
const FAT_HU: f64 = -100.0;
const SOFT_TISSUE_HU: f64 = 40.0;
const MYOCARDIUM_ENHANCED_HU: f64 = 110.0;
const MYOCARDIUM_PLAIN_HU: f64 = 45.0;
const WALL_HU: f64 = 60.0;
/// Blood without contrast agent.
pub const BLOOD_PLAIN_HU: f64 = 40.0;
const DISC_HU: f64 = 90.0;
const CANAL_HU: f64 = 20.0;
const CALCIUM_HU: f64 = 900.0;
/// Native cusp tissue (fibrous leaflet, no contrast).
pub const CUSP_HU: f64 = 80.0;
/// Posterior arch: cortical bone thinner than the bodies' shell, so darker.
const ARCH_FRACTION_OF_CORTICAL: f64 = 0.7;

/// Per-structure contrast factors relative to the aortic blood.
const LV_FACTOR: f64 = 0.95;
const PA_FACTOR: f64 = 0.85;
const LA_FACTOR: f64 = 0.95;
const CORONARY_FACTOR: f64 = 0.95;

/// Thicknesses and offsets (mm).
const AORTIC_WALL_MM: f64 = 1.8;
const PA_WALL_MM: f64 = 1.5;
const DA_WALL_MM: f64 = 1.8;
const CORTEX_MM: f64 = 1.5;
const SUBCUTANEOUS_FAT_MM: f64 = 12.0;
/// Body outline (elliptic, semi-axes in x and y).
const BODY_SEMI: [f64; 2] = [165.0, 120.0];
/// Sternum cross-section semi-axes.
const STERNUM_SEMI: [f64; 2] = [15.0, 7.0];
/// Mediastinal fat margins around each structure.
const FAT_AROUND_AORTA_MM: f64 = 9.0;
const FAT_AROUND_LV_MM: f64 = 14.0;
const FAT_AROUND_VESSELS_MM: f64 = 6.0;
const FAT_BLEND_MM: f64 = 8.0;
/// The aortic wall starts this far below the annulus (the LVOT below it is
/// surrounded by myocardium instead).
const WALL_START_BELOW_VAJ_MM: f64 = 3.0;

/// Beyond this distance shapes may return a lower bound of their distance
/// instead of the distance (cheap far-field): it exceeds every layer's
/// offset + blend width + voxel extent, so no coverage depends on it.
const FAR_MM: f64 = 25.0;
/// Bounding boxes reach this far past a shape, beyond the widest partial-volume
/// ramp (half a voxel diagonal), so culling never clips a boundary voxel.
const AABB_MARGIN_MM: f64 = 2.0;

/// A voxel centre and a lazily computed aortic-lumen distance, which several
/// layers and the truth mask share.
pub struct Probe<'a> {
    pub p: Point3,
    anatomy: &'a Anatomy,
    lumen: Cell<Option<(f64, Vector3)>>,
}

impl<'a> Probe<'a> {
    pub fn new(p: Point3, anatomy: &'a Anatomy) -> Self {
        Probe {
            p,
            anatomy,
            lumen: Cell::new(None),
        }
    }

    pub fn lumen(&self) -> (f64, Vector3) {
        if let Some(v) = self.lumen.get() {
            return v;
        }
        let lumen = &self.anatomy.lumen;
        let lb = lumen.centreline.distance_lower_bound(&self.p) - lumen.r_max_mm;
        let v = if lb > FAR_MM {
            (lb, Vector3::z())
        } else {
            lumen.sdf(&self.p)
        };
        self.lumen.set(Some(v));
        v
    }

    /// Lumen capped `below` mm under the annulus plane.
    fn lumen_capped(&self, below: f64) -> (f64, Vector3) {
        let a = self.anatomy.lumen.centreline.axis;
        let cap = -below - self.anatomy.lumen.height(&self.p);
        let l = self.lumen();
        let l = if cap > l.0 { (cap, -a) } else { l };
        match &self.anatomy.arch {
            // The ascending lumen ends at the join; the arch tube goes on.
            Some(arch) if self.p.z - arch.z_join > l.0 => (self.p.z - arch.z_join, Vector3::z()),
            _ => l,
        }
    }

    /// `lumen_capped` joined with the arch tube, if any.
    fn aorta_capped(&self, below: f64) -> (f64, Vector3) {
        let l = self.lumen_capped(below);
        match &self.anatomy.arch {
            Some(arch) => union(l, arch.tube.eval_within(&self.p, FAR_MM)),
            None => l,
        }
    }
}

pub type ShapeFn = Box<dyn Fn(&Probe) -> (f64, Vector3) + Send + Sync>;
pub type HuFn = Box<dyn Fn(&Point3) -> f64 + Send + Sync>;

pub struct Layer {
    /// A sheet of this thickness: `shape` is then its distance minus half
    /// the thickness, and coverage is the slab's overlap with the voxel
    /// (the half-space ramp would overstate a sheet thinner than a voxel).
    pub thin_mm: Option<f64>,
    pub name: String,
    pub shape: ShapeFn,
    pub hu: HuFn,
    pub aabb: Aabb,
}

pub struct Scene {
    pub anatomy: Arc<Anatomy>,
    pub layers: Vec<Layer>,
    /// Box where the truth mask can be non-zero.
    pub truth_aabb: Aabb,
}

fn constant(v: f64) -> HuFn {
    Box::new(move |_| v)
}

/// A layer of constant HU filling an elliptic cylinder along z.
fn cylinder_layer(name: impl Into<String>, c: ZCylinder, hu: f64) -> Layer {
    Layer {
        thin_mm: None,
        name: name.into(),
        aabb: c.aabb().grow(AABB_MARGIN_MM),
        shape: Box::new(move |pr| c.eval(&pr.p)),
        hu: constant(hu),
    }
}

fn offset(s: (f64, Vector3), by: f64) -> (f64, Vector3) {
    (s.0 - by, s.1)
}

fn tubes_sdf(tubes: &[Tube], p: &Point3) -> (f64, Vector3) {
    tubes
        .iter()
        .map(|t| t.eval_within(p, FAR_MM))
        .fold((f64::INFINITY, Vector3::z()), union)
}

fn tubes_aabb(tubes: &[Tube]) -> Aabb {
    tubes.iter().fold(Aabb::empty(), |b, t| b.union(&t.aabb()))
}

/// Scene options that change tissue values, not geometry.
#[derive(Debug, Clone, Copy)]
pub struct Contrast {
    pub enabled: bool,
    pub blood_hu: f64,
    pub calcium: bool,
}

impl Scene {
    /// Layers for the anatomy; `z_range` bounds the per-vertebra layers.
    pub fn new(anatomy: Arc<Anatomy>, contrast: Contrast, z_range: (f64, f64)) -> Scene {
        let an = &anatomy;
        let mut layers: Vec<Layer> = Vec::new();
        let arch_aabb = an.arch.as_ref().map_or(Aabb::empty(), |a| a.tube.aabb());

        layers.extend(body_and_lungs(an));
        layers.push(mediastinal_fat(&anatomy, &arch_aabb));
        layers.push(myocardium(&anatomy, contrast));
        layers.extend(vessel_walls(&anatomy, &arch_aabb));
        layers.extend(blood_pools(&anatomy, contrast, &arch_aabb));

        layers.extend(native_cusps(&anatomy));

        layers.extend(bones(an, z_range));

        if contrast.calcium {
            layers.extend(calcium(an));
        }
        let truth_aabb = an.lumen.aabb(-1.0, 400.0).grow(1.0);
        Scene {
            anatomy,
            layers,
            truth_aabb,
        }
    }
}

/// Mediastinal fat around the heart and the great vessels.
fn mediastinal_fat(anatomy: &Arc<Anatomy>, arch_aabb: &Aabb) -> Layer {
    let an: &Anatomy = anatomy;
    let lvot = an.lumen.lvot_length_mm;
    let a = anatomy.clone();
    let aabb = an
        .lumen
        .aabb(-lvot - 10.0, 400.0)
        .grow(FAT_AROUND_AORTA_MM + FAT_BLEND_MM)
        .union(&an.lv.aabb().grow(FAT_AROUND_LV_MM + FAT_BLEND_MM))
        .union(&tubes_aabb(&an.pa).grow(FAT_AROUND_VESSELS_MM + FAT_BLEND_MM))
        .union(&an.la.aabb().grow(FAT_AROUND_VESSELS_MM + FAT_BLEND_MM))
        .union(&an.da.aabb().grow(FAT_AROUND_VESSELS_MM + FAT_BLEND_MM))
        .union(&arch_aabb.grow(FAT_AROUND_AORTA_MM + FAT_BLEND_MM));
    Layer {
        thin_mm: None,
        name: "mediastinal_fat".into(),
        shape: Box::new(move |pr| {
            let p = &pr.p;
            let mut d = offset(pr.aorta_capped(lvot + 10.0), FAT_AROUND_AORTA_MM);
            d = smooth_union(d, offset(a.lv.eval(p), FAT_AROUND_LV_MM), FAT_BLEND_MM);
            d = smooth_union(
                d,
                offset(tubes_sdf(&a.pa, p), FAT_AROUND_VESSELS_MM),
                FAT_BLEND_MM,
            );
            d = smooth_union(d, offset(a.la.eval(p), FAT_AROUND_VESSELS_MM), FAT_BLEND_MM);
            smooth_union(d, offset(a.da.eval(p), FAT_AROUND_VESSELS_MM), FAT_BLEND_MM)
        }),
        hu: constant(FAT_HU),
        aabb,
    }
}

/// The myocardium: the LV's shell, reaching up around the LVOT.
fn myocardium(anatomy: &Arc<Anatomy>, contrast: Contrast) -> Layer {
    let an: &Anatomy = anatomy;
    let lvot = an.lumen.lvot_length_mm;
    // Outer radius of the basal myocardium around the LVOT, where its
    // flat top lies below the VAJ, and the rounding of its rim.
    const LVOT_MYOCARDIUM_MM: f64 = 9.0;
    const MYO_TOP_BELOW_VAJ_MM: f64 = 1.0;
    const ROUNDING_MM: f64 = 3.0;
    const BELOW_LVOT_MM: f64 = 8.0;
    let cl = &an.lumen.centreline;
    let top = MYO_TOP_BELOW_VAJ_MM + ROUNDING_MM;
    let basal = Tube::new(
        vec![
            an.lumen.lvot_centre(lvot + BELOW_LVOT_MM),
            an.lumen.lvot_centre(top),
        ],
        vec![an.lumen.profile.r_annulus_mm + LVOT_MYOCARDIUM_MM - ROUNDING_MM],
    );
    // Capsule trimmed flat, then dilated: a cylinder with a rounded rim.
    let axis = cl.axis;
    let a = anatomy.clone();
    let aabb = an.myocardium.aabb().union(&basal.aabb()).grow(LV_BLEND_MM);
    Layer {
        thin_mm: None,
        name: "myocardium".into(),
        shape: Box::new(move |pr| {
            let p = &pr.p;
            let mut b = basal.eval(p);
            let cap = (p - a.lumen.centreline.origin).dot(&axis) + top;
            if cap > b.0 {
                b = (cap, axis);
            }
            smooth_union(a.myocardium.eval(p), offset(b, ROUNDING_MM), LV_BLEND_MM)
        }),
        hu: constant(if contrast.enabled {
            MYOCARDIUM_ENHANCED_HU
        } else {
            MYOCARDIUM_PLAIN_HU
        }),
        aabb,
    }
}

/// The vessel walls: the lumens dilated (the blood is painted over them).
fn vessel_walls(anatomy: &Arc<Anatomy>, arch_aabb: &Aabb) -> Vec<Layer> {
    let an: &Anatomy = anatomy;
    let mut layers: Vec<Layer> = Vec::new();
    let aabb = an
        .lumen
        .aabb(-WALL_START_BELOW_VAJ_MM - 5.0, 400.0)
        .union(&arch_aabb)
        .grow(AORTIC_WALL_MM + 1.0);
    layers.push(Layer {
        thin_mm: None,
        name: "aortic_wall".into(),
        shape: Box::new(move |pr| offset(pr.aorta_capped(WALL_START_BELOW_VAJ_MM), AORTIC_WALL_MM)),
        hu: constant(WALL_HU),
        aabb,
    });
    let a = anatomy.clone();
    layers.push(Layer {
        thin_mm: None,
        name: "pa_wall".into(),
        shape: Box::new(move |pr| offset(tubes_sdf(&a.pa, &pr.p), PA_WALL_MM)),
        hu: constant(WALL_HU),
        aabb: tubes_aabb(&an.pa).grow(PA_WALL_MM + 1.0),
    });
    let da = an.da.clone();
    layers.push(Layer {
        thin_mm: None,
        name: "da_wall".into(),
        shape: Box::new(move |pr| offset(da.eval(&pr.p), DA_WALL_MM)),
        hu: constant(WALL_HU),
        aabb: an.da.aabb().grow(DA_WALL_MM + 1.0),
    });
    layers
}

/// The blood pools: the aortic lumen joined to the LV cavity, the
/// coronaries, the PA, the LA and the descending aorta.
fn blood_pools(anatomy: &Arc<Anatomy>, contrast: Contrast, arch_aabb: &Aabb) -> Vec<Layer> {
    let an: &Anatomy = anatomy;
    let lvot = an.lumen.lvot_length_mm;
    let mut layers: Vec<Layer> = Vec::new();
    // Blood value at a point for a structure with contrast factor f.
    let blood = {
        let a = anatomy.clone();
        move |f: f64| -> HuFn {
            let a = a.clone();
            if contrast.enabled {
                Box::new(move |p: &Point3| contrast.blood_hu * f * a.blood_field(p))
            } else {
                constant(BLOOD_PLAIN_HU)
            }
        }
    };
    // Aortic lumen + LVOT, joined smoothly to the LV cavity.
    let a = anatomy.clone();
    let a2 = anatomy.clone();
    let field = blood(1.0);
    layers.push(Layer {
        thin_mm: None,
        name: "aorta_lv_blood".into(),
        shape: Box::new(move |pr| {
            smooth_union(pr.aorta_capped(lvot), a.lv.eval(&pr.p), LV_BLEND_MM)
        }),
        // The LV is slightly less enhanced: blend along the axis from
        // the annulus down to the end of the LVOT.
        hu: Box::new(move |p| {
            let h = a2.lumen.height(p);
            let t = (-h / lvot).clamp(0.0, 1.0);
            field(p) * (1.0 - t * (1.0 - LV_FACTOR))
        }),
        aabb: an
            .lumen
            .aabb(-lvot - 2.0, 400.0)
            .union(&an.lv.aabb())
            .union(&arch_aabb)
            .grow(LV_BLEND_MM),
    });
    for c in &an.coronaries {
        let tubes = c.tubes.clone();
        let aabb = tubes_aabb(&tubes).grow(1.0);
        layers.push(Layer {
            thin_mm: None,
            name: format!("coronary_{}", c.name),
            shape: Box::new(move |pr| tubes_sdf(&tubes, &pr.p)),
            hu: blood(CORONARY_FACTOR),
            aabb,
        });
    }
    let a = anatomy.clone();
    layers.push(Layer {
        thin_mm: None,
        name: "pa_blood".into(),
        shape: Box::new(move |pr| tubes_sdf(&a.pa, &pr.p)),
        hu: blood(PA_FACTOR),
        aabb: tubes_aabb(&an.pa).grow(1.0),
    });
    let la = an.la.clone();
    layers.push(Layer {
        thin_mm: None,
        name: "la_blood".into(),
        shape: Box::new(move |pr| la.eval(&pr.p)),
        hu: blood(LA_FACTOR),
        aabb: an.la.aabb().grow(1.0),
    });
    let da = an.da.clone();
    layers.push(Layer {
        thin_mm: None,
        name: "da_blood".into(),
        shape: Box::new(move |pr| da.eval(&pr.p)),
        hu: blood(1.0),
        aabb: an.da.aabb().grow(1.0),
    });
    layers
}

/// The native cusps, closed, over the blood (when the anatomy has them).
fn native_cusps(anatomy: &Arc<Anatomy>) -> Option<Layer> {
    let an: &Anatomy = anatomy;
    let c = an.cusps?;
    let a = anatomy.clone();
    let aabb = an
        .lumen
        .aabb(-an.lumen.lvot_length_mm.min(15.0), an.h_comm_mm + 2.0)
        .grow(1.0);
    Some(Layer {
        thin_mm: Some(c.thickness_mm),
        name: "native_cusps".into(),
        shape: Box::new(move |pr| {
            let (d, n) = cusps::sheet_distance(&a, &c, &pr.p);
            (d - 0.5 * c.thickness_mm, n)
        }),
        hu: constant(CUSP_HU),
        aabb,
    })
}

/// The body (subcutaneous fat, then soft tissue), the lungs either side of
/// the mediastinum and the paraspinal muscles.
fn body_and_lungs(an: &Anatomy) -> Vec<Layer> {
    let mut layers = Vec::new();
    let o = an.lumen.centreline.origin;
    let [bx, by] = an.body_centre;
    for (name, shrink, hu) in [
        ("body_fat", 0.0, FAT_HU),
        ("body_soft", SUBCUTANEOUS_FAT_MM, SOFT_TISSUE_HU),
    ] {
        let c = ZCylinder::endless(bx, by, BODY_SEMI[0] - shrink, BODY_SEMI[1] - shrink);
        layers.push(cylinder_layer(name, c, hu));
    }

    // --- Lungs, both sides of the mediastinum ---------------------------
    // Centres (x L, y P from the annulus) and semi-axes: tall ellipsoids
    // whose medial parts the mediastinal layers paint over.
    const LUNG_SEMI: [f64; 3] = [60.0, 85.0, 220.0];
    for (name, dx, dy) in [("lung_right", -85.0, 25.0), ("lung_left", 80.0, 30.0)] {
        let e = super::shapes::Ellipsoid {
            centre: Point3::new(o.x + dx, o.y + dy, o.z),
            rot: coapt_geom::Matrix3::identity(),
            semi: Vector3::new(LUNG_SEMI[0], LUNG_SEMI[1], LUNG_SEMI[2]),
        };
        let aabb = e.aabb().grow(AABB_MARGIN_MM);
        layers.push(Layer {
            thin_mm: None,
            name: name.into(),
            shape: Box::new(move |pr| e.eval(&pr.p)),
            hu: constant(LUNG_HU),
            aabb,
        });
    }
    {
        const PARASPINAL_RADIUS_MM: f64 = 32.0;
        // Centred a little behind the vertebral body (paraspinal muscles).
        const PARASPINAL_BEHIND_BODY_MM: f64 = 10.0;
        let c = ZCylinder::endless(
            an.spine_centre[0],
            an.spine_centre[1] + PARASPINAL_BEHIND_BODY_MM,
            PARASPINAL_RADIUS_MM,
            PARASPINAL_RADIUS_MM,
        );
        layers.push(cylinder_layer("paraspinal", c, SOFT_TISSUE_HU));
    }
    layers
}

/// Bone: the sternum, the vertebral column (bodies and discs within
/// `z_range`, the scan's extent) and the posterior arch over the canal.
fn bones(an: &Anatomy, z_range: (f64, f64)) -> Vec<Layer> {
    let mut layers = Vec::new();
    let [sx, sy] = an.sternum_centre;
    for (name, shrink, hu) in [
        ("sternum_cortex", 0.0, an.cortical_hu),
        ("sternum_marrow", CORTEX_MM, an.cancellous_hu),
    ] {
        let c = ZCylinder::endless(sx, sy, STERNUM_SEMI[0] - shrink, STERNUM_SEMI[1] - shrink);
        layers.push(cylinder_layer(name, c, hu));
    }
    let [vx, vy] = an.spine_centre;
    let rv = an.vertebra_radius_mm;
    let column = ZCylinder::endless(vx, vy, rv, rv);
    layers.push(cylinder_layer("discs", column, DISC_HU));
    let period = an.vertebra_period_mm;
    let first = ((z_range.0 - an.vertebra_phase_mm) / period).floor() as i64 - 1;
    let last = ((z_range.1 - an.vertebra_phase_mm) / period).ceil() as i64 + 1;
    for k in first..=last {
        let z0 = an.vertebra_phase_mm + k as f64 * period + 0.5 * DISC_MM;
        let z1 = z0 + period - DISC_MM;
        for (part, shrink, hu) in [
            ("cortex", 0.0, an.cortical_hu),
            ("body", CORTEX_MM, an.cancellous_hu),
        ] {
            let c = ZCylinder {
                cx: vx,
                cy: vy,
                rx: rv - shrink,
                ry: rv - shrink,
                z_lo: z0 + shrink,
                z_hi: z1 - shrink,
            };
            layers.push(cylinder_layer(format!("vertebra_{k}_{part}"), c, hu));
        }
    }
    const CANAL_RADIUS_MM: f64 = 8.0;
    const ARCH_RADIUS_MM: f64 = 12.0;
    let canal_y = vy + rv + CANAL_RADIUS_MM + 1.0;
    for (name, r, hu) in [
        (
            "posterior_arch",
            ARCH_RADIUS_MM,
            an.cortical_hu * ARCH_FRACTION_OF_CORTICAL,
        ),
        ("spinal_canal", CANAL_RADIUS_MM, CANAL_HU),
    ] {
        let c = ZCylinder::endless(vx, canal_y, r, r);
        layers.push(cylinder_layer(name, c, hu));
    }
    layers
}

/// The annular calcium blobs.
fn calcium(an: &Anatomy) -> Vec<Layer> {
    an.calcium
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let e = e.clone();
            let aabb = e.aabb().grow(AABB_MARGIN_MM);
            Layer {
                thin_mm: None,
                name: format!("calcium_{i}"),
                shape: Box::new(move |pr| e.eval(&pr.p)),
                hu: constant(CALCIUM_HU),
                aabb,
            }
        })
        .collect()
}
