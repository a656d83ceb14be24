//! `close.toml`: the mechanics of one closure, every quantity with its unit.
//!
//! ```toml
//! model = "neo-hookean"      # msm | svk | neo-hookean | gent | goh
//! mu = "300 kPa"             # neo-hookean, gent, goh (or young = "0.9 MPa": μ = E/3)
//! thickness = "0.5 mm"
//! pressure = "80 mmHg"
//! contact = "leaflets"       # leaflets (default) | planes | none
//! solver = "newton"          # newton | relax | combined
//! ```
//! `contact`: "leaflets" is true contact between leaflets (the barrier of
//! `contact::leaflet_barrier`, Newton only; it needs two leaflets or more,
//! and a closure that ends with a crossing triangle pair is not converged);
//! "planes" the seed 001 planes, for a lone leaflet of a symmetric valve.
//! Optional: `poisson` (svk), `jm` (gent, default 2.3), `k1`, `k2`, `kappa`
//! (goh), `msm_law` ("linear" with `young`, "seed000-isotropic",
//! "seed000-anisotropic"), `contact_margin` (the leaflet barrier's reach
//! d̂: mid-surfaces closer than thickness + d̂/2 push apart, and sheets
//! pressed at the closing pressure rest a thickness apart; default 0.5 ×
//! thickness; the barrier's stiffness follows from the pressure),
//! `plane_offset` (contact planes moved off the plane of symmetry into
//! each leaflet's side, e.g. half the thickness so pressed leaflets do
//! not cross; default "0 mm", the
//! seed's planes through the axis), `tolerance` (default
//! "1e-7 N"), `relative_tolerance` (default 1e-7), `step_tolerance`
//! (default "1e-4 mm", a hundredth of the 0.01 mm the report gives
//! heights to: a Newton that no longer lowers the residual has converged
//! when its exact correction moves no node farther than this and the
//! residual is below 1e-4 of the pressure load; "0 mm": only the residual
//! decides),
//! `max_iterations` (default 1500; the suturing pre-stage's rounds get at
//! most 300 of them), `material_source` (free text: where the material's
//! parameters come from, shown with them in the report's case header),
//! `time_limit` (default "600 s"; it bounds the whole close, suturing
//! included), `reference` ("sutured", the default of the membranes: the
//! configuration after suturing is stress-free, as in seed 001; "placed":
//! the placed template is, so suturing leaves stress; "flat", the MSM's
//! default: the flat template is, leaving the stress of both placing and
//! suturing in the leaflet; seed 000's springs rest on the flat template's
//! mesh, and on the sutured one a third of the triangles are obtuse, which
//! three edge springs cannot hold, see `material::msm`), `reference_steps`
//! (default 1; with "flat" or "placed", n > 1 closes n times while the
//! reference moves from the sutured state to the one asked for, its squared
//! edge lengths blended, `reference_blend`: a placement far from isometric
//! to the flat template starts there from residuals of 1e7 N and more),
//! `bending` (true:
//! add the bending stiffness D = E't³/12 of a
//! shell, default false), `wrinkling` (true: the neo-Hookean membrane
//! carries no compression, `material::wrinkling`; a leaflet resting on its
//! flat template is gathered onto a smaller surface, and the excess
//! wrinkles instead of buckling the mesh; default false;
//! `wrinkled_stiffness`, default 0.02: the fraction of the neo-Hookean
//! energy a wrinkled or slack triangle keeps, without which a gathered
//! mesh's slack triangles collapse), `wall_contact` (true: free leaflet nodes are kept
//! off the aortic wall, `contact::wall_barrier`; default false). With it
//! every free node's mid-surface stays at least half the thickness from
//! the wall (aorta.vtp's wall triangles, or the cylinder about the axis
//! through the suture line without a surface): a log barrier acting within
//! `contact_margin` of that, stiff enough that a leaflet pressed on the
//! wall by the closing pressure rests half the margin off it, and steps cut
//! so no node passes the wall. Nodes that start closer (next to the suture
//! line) keep at least half their start distance; nodes that start on or
//! beyond the wall are left alone. It works with every `contact` and needs
//! `solver = "newton"`. Its cost: one search of the wall's tree per free
//! node per evaluation (a node far from the wall: one failed descent), so
//! little unless many nodes lie on the wall; `closure.json` records it
//! under `wall_contact`.
//!
//! The suturing pre-stage (seed 001 Algorithm 1, [`super::suture`]) has its
//! own table; every key is optional, the defaults are the seed's except k0:
//!
//! ```toml
//! [suture]
//! mode = "auto"          # auto (unless the leaflets say they are sutured) | on | off
//! mu = "900 kPa"         # auxiliary neo-Hookean shell
//! thickness = "0.8 mm"
//! pressure = "90 mmHg"
//! k0 = "64 N/mm"         # first suturing force parameter K, doubled each round (the seed: 1; see suture::Settings::k0)
//! tolerance = 0.01       # ε_sew: stop when max sin φ_T < tolerance
//! max_rounds = 40
//! ```

use std::path::Path;

use serde::Deserialize;

use super::element::Membrane;
use super::material::{
    Gent, Goh, MassSpring, NeoHookean, StVenantKirchhoff, WrinklingNeoHookean, msm,
};
use super::suture;
use coapt_base::units::{self, Kind};
use coapt_base::{Error, Result};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Raw {
    model: String,
    thickness: String,
    pressure: String,
    mu: Option<String>,
    young: Option<String>,
    poisson: Option<f64>,
    jm: Option<f64>,
    k1: Option<String>,
    k2: Option<f64>,
    kappa: Option<f64>,
    msm_law: Option<String>,
    contact: Option<String>,
    contact_margin: Option<String>,
    contact_alpha: Option<f64>,
    plane_offset: Option<String>,
    solver: Option<String>,
    tolerance: Option<String>,
    relative_tolerance: Option<f64>,
    step_tolerance: Option<String>,
    max_iterations: Option<usize>,
    time_limit: Option<String>,
    reference: Option<String>,
    reference_steps: Option<usize>,
    bending: Option<bool>,
    wrinkling: Option<bool>,
    wrinkled_stiffness: Option<f64>,
    wall_contact: Option<bool>,
    effective_height_pressure: Option<String>,
    material_source: Option<String>,
    suture: Option<RawSuture>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSuture {
    mode: Option<String>,
    mu: Option<String>,
    thickness: Option<String>,
    pressure: Option<String>,
    k0: Option<String>,
    tolerance: Option<f64>,
    max_rounds: Option<usize>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Model {
    Msm(msm::Law),
    Svk {
        young: f64,
        poisson: f64,
    },
    NeoHookean {
        mu: f64,
    },
    Gent {
        mu: f64,
        jm: f64,
    },
    Goh {
        mu: f64,
        k1: f64,
        k2: f64,
        kappa: f64,
    },
}

impl Model {
    /// The law and its parameters for `closure.json`, moduli in kPa (the
    /// unit the seeds and close.toml give them in).
    pub fn to_json(&self) -> serde_json::Value {
        use serde_json::json;
        let kpa = |mpa: f64| mpa * 1000.0;
        let kpa3 = |e: &[f64; 3]| e.map(kpa);
        match self {
            Model::Msm(msm::Law::Linear { young }) => {
                json!({"law": "msm", "young_kpa": kpa(*young)})
            }
            Model::Msm(msm::Law::ThreeStep { e, eps }) => {
                json!({"law": "msm", "tangent_moduli_kpa": kpa3(e), "breakpoint_strains": eps})
            }
            Model::Msm(msm::Law::Anisotropic { fibre, cross, eps }) => json!({
                "law": "msm",
                "fibre_tangent_moduli_kpa": kpa3(fibre),
                "cross_tangent_moduli_kpa": kpa3(cross),
                "breakpoint_strains": eps,
            }),
            Model::Svk { young, poisson } => {
                json!({"law": "svk", "young_kpa": kpa(*young), "poisson": poisson})
            }
            Model::NeoHookean { mu } => json!({"law": "neo-hookean", "mu_kpa": kpa(*mu)}),
            Model::Gent { mu, jm } => json!({"law": "gent", "mu_kpa": kpa(*mu), "jm": jm}),
            Model::Goh { mu, k1, k2, kappa } => json!({
                "law": "goh", "mu_kpa": kpa(*mu), "k1_kpa": kpa(*k1), "k2": k2, "kappa": kappa,
            }),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactKind {
    Leaflets,
    Planes,
    None,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolverKind {
    Newton,
    Relax,
    Combined,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reference {
    Sutured,
    Placed,
    Flat,
}

/// The closure's default iteration budget. Continuation on the projected
/// tangent converges only linearly near a pure membrane's or a fine mesh's
/// equilibrium (0.96–0.99 per step): of the 28 of 100 plausible stress
/// cases (`bench stress-close --plausible --h-max 2`) that failed at the
/// old 300, 17 converge within 1500 (at 320–1393 iterations, the slowest
/// in 123 s at h 0.26 mm on one thread); those that still fail are
/// balloons, collapsed MSM triangles, and five held back by cut steps,
/// wandering or rising.
/// A closure that converges stops long before; one that does not is
/// bounded by `time_limit` as well.
pub const MAX_ITERATIONS: usize = 1500;

#[derive(Debug, Clone)]
pub struct CloseConfig {
    pub model: Model,
    pub thickness: f64,
    pub pressure: f64,
    pub contact: ContactKind,
    pub contact_margin: f64,
    /// Contact planes sit this far (mm) off the plane of symmetry, into the
    /// leaflet's side (0: the seed's planes through the axis).
    pub plane_offset: f64,
    pub solver: SolverKind,
    pub tolerance: f64,
    pub relative_tolerance: f64,
    /// Newton's correction (mm) below which a stalled exact-tangent Newton
    /// counts as converged (0: never).
    pub step_tolerance: f64,
    pub max_iterations: usize,
    pub time_limit: f64,
    pub reference: Reference,
    /// Closures in which the reference moves from the sutured state to
    /// `reference` (1: straight onto it; `reference_blend`).
    pub reference_steps: usize,
    /// Add the leaflet's bending stiffness D = E't³/12 (discrete-shell
    /// hinges) to the membrane.
    pub bending: bool,
    /// The neo-Hookean membrane carries no compression (tension field,
    /// `material::wrinkling`): `Some(c)`, c the fraction of the
    /// neo-Hookean energy kept where the sheet is wrinkled or slack.
    pub wrinkling: Option<f64>,
    /// Keep free leaflet nodes off the aortic wall (`contact::wall_barrier`).
    pub wall_contact: bool,
    /// Also close at this (low) pressure, MPa, for the effective height
    /// (the seeds measure h_E at 3 mmHg); `None`: only the closing pressure.
    pub effective_height_pressure: Option<f64>,
    /// Where the material parameters come from, as the user states it
    /// (`material_source` in close.toml); the report's case header shows it.
    pub material_source: Option<String>,
    pub suture: suture::Settings,
}

impl CloseConfig {
    pub fn membrane(&self) -> Box<dyn Membrane> {
        match &self.model {
            Model::Msm(law) => Box::new(MassSpring { law: *law }),
            Model::Svk { young, poisson } => Box::new(StVenantKirchhoff {
                young: *young,
                poisson: *poisson,
            }),
            Model::NeoHookean { mu } if self.wrinkling.is_some() => Box::new(WrinklingNeoHookean {
                mu: *mu,
                residual: self.wrinkling.unwrap_or(0.0),
            }),
            Model::NeoHookean { mu } => Box::new(NeoHookean { mu: *mu }),
            Model::Gent { mu, jm } => Box::new(Gent { mu: *mu, jm: *jm }),
            Model::Goh { mu, k1, k2, kappa } => Box::new(Goh {
                mu: *mu,
                k1: *k1,
                k2: *k2,
                kappa: *kappa,
            }),
        }
    }

    /// E/(1 − ν²) of the small-strain limit of the model (MPa): St.V-K's own
    /// E and ν; the incompressible models 4μ (E = 3μ, ν = 1/2); the linear
    /// spring network its E; the seed laws their small-strain slope.
    pub fn plane_strain_modulus(&self) -> f64 {
        match &self.model {
            Model::Svk { young, poisson } => young / (1.0 - poisson * poisson),
            Model::NeoHookean { mu } | Model::Gent { mu, .. } | Model::Goh { mu, .. } => 4.0 * mu,
            Model::Msm(msm::Law::Linear { young }) => *young,
            Model::Msm(msm::Law::ThreeStep { e, .. }) => e[0],
            Model::Msm(msm::Law::Anisotropic { fibre, cross, .. }) => 0.5 * (fibre[0] + cross[0]),
        }
    }

    pub fn model_name(&self) -> &'static str {
        self.membrane().name()
    }

    /// Canonical record for `closure.json`.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "model": self.model.to_json(),
            "material_source": self.material_source,
            "thickness_mm": self.thickness,
            "pressure_mpa": self.pressure,
            "pressure_mmhg": self.pressure / units::MMHG_IN_MPA,
            "contact": format!("{:?}", self.contact).to_lowercase(),
            "contact_margin_mm": self.contact_margin,
            "plane_offset_mm": self.plane_offset,
            "solver": format!("{:?}", self.solver).to_lowercase(),
            "tolerance_n": self.tolerance,
            "relative_tolerance": self.relative_tolerance,
            "step_tolerance_mm": self.step_tolerance,
            "max_iterations": self.max_iterations,
            "time_limit_s": self.time_limit,
            "effective_height_pressure_mmhg": self.effective_height_pressure.map(|p| p / units::MMHG_IN_MPA),
            "reference": format!("{:?}", self.reference).to_lowercase(),
            "reference_steps": self.reference_steps,
            "bending": self.bending,
            "wrinkling": self.wrinkling.is_some(),
            "wrinkled_stiffness": self.wrinkling,
            "wall_contact": self.wall_contact,
            "suture": {
                "mode": format!("{:?}", self.suture.mode).to_lowercase(),
                "mu_mpa": self.suture.mu,
                "thickness_mm": self.suture.thickness,
                "pressure_mmhg": self.suture.pressure / units::MMHG_IN_MPA,
                "k0_n_per_mm": self.suture.k0,
                "tolerance_sin_phi": self.suture.tolerance,
                "max_rounds": self.suture.max_rounds,
            },
        })
    }
}

/// Default fraction of the neo-Hookean energy a wrinkled or slack triangle
/// keeps (`wrinkled_stiffness`): enough to hold a gathered mesh together.
pub const WRINKLED_STIFFNESS: f64 = 0.02;

pub fn read(path: &Path) -> Result<CloseConfig> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::read(path, e))?;
    parse(&text).map_err(|e| Error::bad_input(path, e))
}

fn q(kind: Kind, v: &Option<String>, key: &str) -> std::result::Result<Option<f64>, String> {
    v.as_ref()
        .map(|s| units::parse(kind, s).map_err(|e| format!("{key}: {e}")))
        .transpose()
}

fn need(v: Option<f64>, key: &str, model: &str) -> std::result::Result<f64, String> {
    v.ok_or_else(|| format!("model \"{model}\" needs `{key}`"))
}

/// `v` when it is a positive finite number, else why not.
fn positive(v: f64, key: &str) -> std::result::Result<f64, String> {
    if v > 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{key} must be positive"))
    }
}

/// The material law `raw.model` names, with its parameters (`shear`: μ,
/// given or E/3; `young`: E), each checked.
fn model_of(
    raw: &Raw,
    shear: Option<f64>,
    young: Option<f64>,
) -> std::result::Result<Model, String> {
    let m = raw.model.as_str();
    Ok(match m {
        "neo-hookean" => Model::NeoHookean {
            mu: positive(need(shear, "mu", m)?, "mu")?,
        },
        "gent" => {
            let jm = raw.jm.unwrap_or(2.3);
            Model::Gent {
                mu: positive(need(shear, "mu", m)?, "mu")?,
                jm: positive(jm, "jm")?,
            }
        }
        "goh" => {
            let kappa = raw.kappa.unwrap_or(0.2);
            if !(0.0..=1.0 / 3.0 + 1e-12).contains(&kappa) {
                return Err(format!("kappa {kappa} must lie in [0, 1/3]"));
            }
            let k2 = raw.k2.unwrap_or(1000.0);
            if !(k2 >= 0.0) {
                return Err("k2 must be ≥ 0".into());
            }
            Model::Goh {
                mu: positive(need(shear, "mu", m)?, "mu")?,
                k1: positive(need(q(Kind::Pressure, &raw.k1, "k1")?, "k1", m)?, "k1")?,
                k2,
                kappa,
            }
        }
        "svk" => {
            let poisson = raw.poisson.unwrap_or(0.45);
            if !(-1.0 < poisson && poisson < 1.0) {
                return Err(format!("poisson {poisson} must lie in (−1, 1)"));
            }
            Model::Svk {
                young: positive(need(young, "young", m)?, "young")?,
                poisson,
            }
        }
        "msm" => Model::Msm(
            match raw.msm_law.as_deref().unwrap_or("seed000-isotropic") {
                "linear" => msm::Law::Linear {
                    young: positive(need(young, "young", m)?, "young")?,
                },
                "seed000-isotropic" => msm::seed000_isotropic(),
                "seed000-anisotropic" => msm::seed000_anisotropic(),
                other => {
                    return Err(format!(
                        "msm_law \"{other}\": expected linear, seed000-isotropic or seed000-anisotropic"
                    ));
                }
            },
        ),
        other => {
            return Err(format!(
                "model \"{other}\": expected msm, svk, neo-hookean, gent or goh"
            ));
        }
    })
}

pub fn parse(text: &str) -> std::result::Result<CloseConfig, String> {
    let raw: Raw = toml::from_str(text).map_err(|e| coapt_io::toml_error::describe(text, &e))?;
    let thickness = positive(
        units::parse(Kind::Length, &raw.thickness).map_err(|e| format!("thickness: {e}"))?,
        "thickness",
    )?;
    let pressure =
        units::parse(Kind::Pressure, &raw.pressure).map_err(|e| format!("pressure: {e}"))?;
    if !(pressure >= 0.0) {
        return Err("pressure must be ≥ 0".into());
    }
    let mu = q(Kind::Pressure, &raw.mu, "mu")?;
    let young = q(Kind::Pressure, &raw.young, "young")?;
    let shear = mu.or(young.map(|e| e / 3.0));
    let m = raw.model.as_str();
    let model = model_of(&raw, shear, young)?;
    let contact = match raw.contact.as_deref().unwrap_or("leaflets") {
        "leaflets" => ContactKind::Leaflets,
        "planes" => ContactKind::Planes,
        "none" => ContactKind::None,
        other => {
            return Err(format!(
                "contact \"{other}\": expected leaflets, planes or none"
            ));
        }
    };
    let solver = match raw.solver.as_deref().unwrap_or("newton") {
        "newton" => SolverKind::Newton,
        "relax" => SolverKind::Relax,
        "combined" => SolverKind::Combined,
        other => {
            return Err(format!(
                "solver \"{other}\": expected newton, relax or combined"
            ));
        }
    };
    // Seed 000 puts its springs on the advancing-front mesh of the flat
    // template, and Van Gelder's stiffness needs its non-obtuse triangles
    // (seed 004 §2.3.1): on the sutured mesh a third of the triangles are
    // obtuse and the MSM does not converge below h 2 mm (msm.rs). So the
    // MSM's springs rest at the cut pericardium's lengths unless asked.
    let default_reference = match model {
        Model::Msm(_) => "flat",
        _ => "sutured",
    };
    let reference = match raw.reference.as_deref().unwrap_or(default_reference) {
        "sutured" => Reference::Sutured,
        "placed" => Reference::Placed,
        "flat" => Reference::Flat,
        other => {
            return Err(format!(
                "reference \"{other}\": expected sutured, placed or flat"
            ));
        }
    };
    let suture = parse_suture(raw.suture)?;
    let wrinkling = match (raw.wrinkling.unwrap_or(false), raw.wrinkled_stiffness) {
        (true, c) => Some(match c.unwrap_or(WRINKLED_STIFFNESS) {
            c if (0.0..=1.0).contains(&c) => c,
            c => return Err(format!("wrinkled_stiffness {c} must lie in [0, 1]")),
        }),
        (false, Some(_)) => {
            return Err("wrinkled_stiffness needs wrinkling = true".into());
        }
        (false, None) => None,
    };
    if wrinkling.is_some() && !matches!(model, Model::NeoHookean { .. }) {
        return Err(format!(
            "wrinkling = true is built for model = \"neo-hookean\" only (the relaxed energy of {m} is not); set wrinkling = false or model = \"neo-hookean\""
        ));
    }
    let contact_margin =
        q(Kind::Length, &raw.contact_margin, "contact_margin")?.unwrap_or(0.5 * thickness);
    if raw.contact_alpha.is_some() {
        return Err("contact_alpha was the stiffness factor of the node-to-triangle penalty, which no closure uses since the leaflet barrier replaced it (its stiffness follows from the pressure): remove the key".into());
    }
    let cfg = CloseConfig {
        model,
        thickness,
        pressure,
        contact,
        contact_margin: positive(contact_margin, "contact_margin")?,
        plane_offset: match q(Kind::Length, &raw.plane_offset, "plane_offset")?.unwrap_or(0.0) {
            v if v >= 0.0 => v,
            _ => return Err("plane_offset must be ≥ 0".into()),
        },
        solver,
        tolerance: positive(
            q(Kind::Force, &raw.tolerance, "tolerance")?.unwrap_or(1e-7),
            "tolerance",
        )?,
        relative_tolerance: positive(raw.relative_tolerance.unwrap_or(1e-7), "relative_tolerance")?,
        step_tolerance: match q(Kind::Length, &raw.step_tolerance, "step_tolerance")?
            .unwrap_or(1e-4)
        {
            v if (0.0..=0.01).contains(&v) => v,
            v => {
                return Err(format!(
                    "step_tolerance {v} mm must lie in [0, 0.01] mm (0: only the residual decides)"
                ));
            }
        },
        max_iterations: raw.max_iterations.unwrap_or(MAX_ITERATIONS),
        time_limit: positive(
            q(Kind::Time, &raw.time_limit, "time_limit")?.unwrap_or(600.0),
            "time_limit",
        )?,
        reference,
        reference_steps: match raw.reference_steps.unwrap_or(1) {
            1 => 1,
            n if !(2..=100).contains(&n) => {
                return Err(format!("reference_steps {n} must lie in 1..=100"));
            }
            _ if reference == Reference::Sutured => {
                return Err("reference_steps blends the sutured state into the reference: it needs reference = \"flat\" or \"placed\"".into());
            }
            n => n,
        },
        bending: raw.bending.unwrap_or(false),
        wrinkling,
        wall_contact: raw.wall_contact.unwrap_or(false),
        material_source: raw
            .material_source
            .map(|s| s.trim().to_string())
            .filter(|s| !s.is_empty()),
        effective_height_pressure: match q(
            Kind::Pressure,
            &raw.effective_height_pressure,
            "effective_height_pressure",
        )? {
            Some(p) if p > 0.0 && p <= pressure => Some(p),
            Some(_) => {
                return Err(
                    "effective_height_pressure must be > 0 and at most the pressure".into(),
                );
            }
            None => None,
        },
        suture,
    };
    check_ranges(&cfg)?;
    Ok(cfg)
}

/// Ranges outside which a closure means nothing physically or costs without
/// bound: each value outside is refused with its range and why, before any
/// work (a 1e6 mm leaflet, 1e12 mmHg or a 1e12 s limit ran for as long as
/// anyone let them; a 1e300 N tolerance "converged" at the first iterate).
pub fn check_ranges(c: &CloseConfig) -> std::result::Result<(), String> {
    const MMHG: f64 = 133.322e-6;
    let check = |key: &str, v: f64, (lo, hi): (f64, f64), (scale, unit): (f64, &str), why: &str| {
        if v >= lo && v <= hi {
            Ok(())
        } else {
            let s = |x: f64| units::short(x / scale);
            let unit = if unit.is_empty() {
                String::new()
            } else {
                format!(" {unit}")
            };
            Err(format!(
                "{key} {}{unit} lies outside {}–{}{unit}: {why}",
                s(v),
                s(lo),
                s(hi)
            ))
        }
    };
    const MM: (f64, &str) = (1.0, "mm");
    const MPA: (f64, &str) = (1.0, "MPa");
    const HG: (f64, &str) = (MMHG, "mmHg");
    const ONE: (f64, &str) = (1.0, "");
    let tissue = "pericardium, native leaflets and polymers lie within 0.01–100 MPa";
    check(
        "thickness",
        c.thickness,
        (0.05, 3.0),
        MM,
        "leaflets are 0.1–1 mm thick",
    )?;
    check(
        "pressure",
        c.pressure,
        (0.0, 300.0 * MMHG),
        HG,
        "diastolic pressures lie within 40–120 mmHg",
    )?;
    let moduli: Vec<(&str, f64)> = match &c.model {
        Model::NeoHookean { mu } | Model::Gent { mu, .. } => vec![("mu", *mu)],
        Model::Goh { mu, k1, .. } => vec![("mu", *mu), ("k1", *k1)],
        Model::Svk { young, .. } => vec![("young", *young)],
        Model::Msm(msm::Law::Linear { young }) => vec![("young", *young)],
        Model::Msm(_) => vec![],
    };
    for (key, v) in moduli {
        check(key, v, (1e-3, 1e3), MPA, tissue)?;
    }
    if let Model::Goh { k2, .. } = c.model {
        check(
            "k2",
            k2,
            (0.0, 1e4),
            ONE,
            "fibre stiffening of tissues lies within 0–1000 (it enters as exp(k2 E²))",
        )?;
    }
    if let Model::Gent { jm, .. } = c.model {
        check(
            "jm",
            jm,
            (1e-3, 1e3),
            ONE,
            "Gent's locking invariant is of order 1",
        )?;
    }
    check(
        "contact_margin",
        c.contact_margin,
        (1e-3, 2.0),
        MM,
        "the contact reach is a fraction of the thickness",
    )?;
    check(
        "plane_offset",
        c.plane_offset,
        (0.0, 5.0),
        MM,
        "the planes move by about half a thickness",
    )?;
    check(
        "tolerance",
        c.tolerance,
        (0.0, 1.0),
        (1.0, "N"),
        "a closure's pressure load is of order 10 N; a tolerance near it accepts any state",
    )?;
    check(
        "relative_tolerance",
        c.relative_tolerance,
        (0.0, 0.1),
        ONE,
        "a fraction of the first residual",
    )?;
    check(
        "max_iterations",
        c.max_iterations as f64,
        (1.0, 1e5),
        ONE,
        "closures take tens to hundreds of iterations",
    )?;
    check(
        "time_limit",
        c.time_limit,
        (0.0, 86_400.0),
        (1.0, "s"),
        "one closure takes seconds to minutes; a day at most",
    )?;
    let s = &c.suture;
    check("suture.mu", s.mu, (1e-3, 1e3), MPA, tissue)?;
    check(
        "suture.thickness",
        s.thickness,
        (0.05, 3.0),
        MM,
        "leaflets are 0.1–1 mm thick",
    )?;
    check(
        "suture.pressure",
        s.pressure,
        (0.0, 300.0 * MMHG),
        HG,
        "the auxiliary problem's pressure is of the diastolic order",
    )?;
    check(
        "suture.k0",
        s.k0,
        (1e-9, 1e6),
        (1.0, "N/mm"),
        "the first suturing force parameter",
    )?;
    check(
        "suture.max_rounds",
        s.max_rounds as f64,
        (1.0, 1000.0),
        ONE,
        "the force parameter doubles each round",
    )?;
    Ok(())
}

fn parse_suture(raw: Option<RawSuture>) -> std::result::Result<suture::Settings, String> {
    let d = suture::Settings::default();
    let Some(r) = raw else { return Ok(d) };
    let pos = |v: Option<f64>, key: &str, default: f64| match v {
        None => Ok(default),
        Some(v) if v > 0.0 && v.is_finite() => Ok(v),
        Some(_) => Err(format!("suture.{key} must be positive")),
    };
    let tolerance = match r.tolerance {
        None => d.tolerance,
        Some(t) if t > 0.0 && t < 1.0 => t,
        Some(t) => return Err(format!("suture.tolerance {t} must lie in (0, 1) (a sine)")),
    };
    Ok(suture::Settings {
        mode: match r.mode.as_deref().unwrap_or("auto") {
            "auto" => suture::Mode::Auto,
            "on" => suture::Mode::On,
            "off" => suture::Mode::Off,
            other => {
                return Err(format!("suture.mode \"{other}\": expected auto, on or off"));
            }
        },
        mu: pos(q(Kind::Pressure, &r.mu, "suture.mu")?, "mu", d.mu)?,
        thickness: pos(
            q(Kind::Length, &r.thickness, "suture.thickness")?,
            "thickness",
            d.thickness,
        )?,
        pressure: pos(
            q(Kind::Pressure, &r.pressure, "suture.pressure")?,
            "pressure",
            d.pressure,
        )?,
        k0: pos(q(Kind::LineForce, &r.k0, "suture.k0")?, "k0", d.k0)?,
        tolerance,
        max_rounds: match r.max_rounds {
            None => d.max_rounds,
            Some(n) if n >= 1 => n,
            Some(_) => return Err("suture.max_rounds must be at least 1".into()),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values no closure can mean, or that cost without bound, are refused
    /// with the key, the value in its unit and the range; the bounds
    /// themselves are accepted.
    #[test]
    fn values_outside_physical_ranges_are_refused_with_their_range() {
        let base = "model = \"neo-hookean\"\nmu = \"900 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\n";
        let with = |line: &str| {
            let key = line.split(" =").next().unwrap();
            let kept: String = base
                .lines()
                .filter(|l| !l.starts_with(&format!("{key} =")))
                .map(|l| format!("{l}\n"))
                .collect();
            parse(&format!("{kept}{line}\n"))
        };
        for (line, words) in [
            (
                "thickness = \"1e6 mm\"",
                &["thickness 1000000 mm", "0.05–3 mm"][..],
            ),
            (
                "pressure = \"1e12 mmHg\"",
                &["pressure 1e12 mmHg", "0–300 mmHg"],
            ),
            ("mu = \"1e9 MPa\"", &["mu 1e9 MPa", "0.001–1000 MPa"]),
            ("tolerance = \"1e300 N\"", &["tolerance", "0–1 N"]),
            ("relative_tolerance = 0.5", &["relative_tolerance 0.5 lies"]),
            (
                "max_iterations = 1000000000000",
                &["max_iterations 1e12 lies", "1–100000"],
            ),
            (
                "time_limit = \"1e12 s\"",
                &["time_limit 1e12 s", "0–86400 s"],
            ),
            ("plane_offset = \"1e6 mm\"", &["plane_offset", "0–5 mm"]),
            (
                "contact_margin = \"1e6 mm\"",
                &["contact_margin", "0.001–2 mm"],
            ),
        ] {
            let e = with(line).expect_err(line);
            for w in words {
                assert!(e.contains(w), "{line}: no {w:?} in {e}");
            }
        }
        let e = parse(&format!("{base}[suture]\nmax_rounds = 1000000\n")).unwrap_err();
        assert!(
            e.contains("suture.max_rounds 1000000 lies outside 1–1000"),
            "{e}"
        );
        for line in [
            "thickness = \"3 mm\"",
            "pressure = \"300 mmHg\"",
            "pressure = \"0 mmHg\"",
            "max_iterations = 100000",
            "time_limit = \"86400 s\"",
            "tolerance = \"1e-18 N\"",
        ] {
            assert!(with(line).is_ok(), "{line}: {:?}", with(line).err());
        }
    }

    #[test]
    fn parses_units_and_refuses_bare_numbers_and_unknown_keys() {
        let c = parse("model = \"goh\"\nmu = \"900 kPa\"\nk1 = \"1100 kPa\"\nkappa = 0.29\nthickness = \"0.4 mm\"\npressure = \"90 mmHg\"\n").unwrap();
        assert_eq!(
            c.model,
            Model::Goh {
                mu: 0.9,
                k1: 1.1,
                k2: 1000.0,
                kappa: 0.29
            }
        );
        assert!((c.pressure - 90.0 * 133.322e-6).abs() < 1e-9);
        assert_eq!(c.contact, ContactKind::Leaflets);
        assert!((c.contact_margin - 0.2).abs() < 1e-12);
        let e = parse("model = \"neo-hookean\"\nmu = \"300\"\nthickness = \"0.4 mm\"\npressure = \"90 mmHg\"\n").unwrap_err();
        assert!(e.contains("mu") && e.contains("unit"), "{e}");
        let e = parse("model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.4 mm\"\npressure = \"90 mmHg\"\nfoo = 1\n").unwrap_err();
        assert!(e.contains("foo"), "{e}");
        // A key that once tuned the node-to-triangle penalty is refused
        // with why, not ignored.
        let e = parse("model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.4 mm\"\npressure = \"90 mmHg\"\ncontact_alpha = 25\n").unwrap_err();
        assert!(
            e.contains("contact_alpha") && e.contains("remove the key"),
            "{e}"
        );
        let e =
            parse("model = \"svk\"\nthickness = \"0.4 mm\"\npressure = \"90 mmHg\"\n").unwrap_err();
        assert!(e.contains("young"), "{e}");
        let c = parse("model = \"neo-hookean\"\nyoung = \"0.9 MPa\"\nthickness = \"0.4 mm\"\npressure = \"90 mmHg\"\ntolerance = \"0.1 mN\"\n").unwrap();
        assert_eq!(c.model, Model::NeoHookean { mu: 0.3 });
        assert!((c.tolerance - 1e-4).abs() < 1e-15);
        assert_eq!(c.plane_offset, 0.0);
        let c = parse("model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\neffective_height_pressure = \"3 mmHg\"\n").unwrap();
        assert!((c.effective_height_pressure.unwrap() - 3.0 * 133.322e-6).abs() < 1e-9);
        assert!(parse("model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\neffective_height_pressure = \"90 mmHg\"\n").is_err());
        let c = parse("model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\ncontact = \"planes\"\nplane_offset = \"0.25 mm\"\n").unwrap();
        assert_eq!(c.plane_offset, 0.25);
        assert!(!c.wall_contact);
        let c = parse("model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\nwall_contact = true\n").unwrap();
        assert!(c.wall_contact && c.to_json()["wall_contact"] == true);
        assert!(parse("model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\nwall_contact = \"yes\"\n").is_err());
        assert!(parse("model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\nplane_offset = \"-1 mm\"\n").is_err());
    }

    #[test]
    fn the_msm_rests_on_the_flat_template_unless_told_otherwise() {
        let base = "thickness = \"0.5 mm\"\npressure = \"80 mmHg\"\n";
        let msm = parse(&format!("model = \"msm\"\n{base}")).unwrap();
        assert_eq!(msm.reference, Reference::Flat);
        let msm = parse(&format!("model = \"msm\"\nreference = \"sutured\"\n{base}")).unwrap();
        assert_eq!(msm.reference, Reference::Sutured);
        let nh = parse(&format!(
            "model = \"neo-hookean\"\nmu = \"300 kPa\"\n{base}"
        ))
        .unwrap();
        assert_eq!(nh.reference, Reference::Sutured);
        assert_eq!(nh.to_json()["reference"], "sutured");
        assert_eq!(
            parse(&format!("model = \"msm\"\n{base}"))
                .unwrap()
                .to_json()["reference"],
            "flat"
        );
    }

    #[test]
    fn wrinkling_is_the_neo_hookean_relaxed_and_refused_elsewhere() {
        let base = "thickness = \"0.5 mm\"\npressure = \"80 mmHg\"\nmu = \"300 kPa\"\n";
        let nh = parse(&format!(
            "model = \"neo-hookean\"\nwrinkling = true\n{base}"
        ))
        .unwrap();
        assert!(nh.wrinkling == Some(WRINKLED_STIFFNESS) && nh.to_json()["wrinkling"] == true);
        assert_eq!(nh.model_name(), "neo-hookean, wrinkling");
        let plain = parse(&format!("model = \"neo-hookean\"\n{base}")).unwrap();
        assert!(plain.wrinkling.is_none());
        let c = parse(&format!(
            "model = \"neo-hookean\"\nwrinkling = true\nwrinkled_stiffness = 0\n{base}"
        ))
        .unwrap();
        assert_eq!(c.wrinkling, Some(0.0));
        for bad in [
            "wrinkling = true\nwrinkled_stiffness = 1.5",
            "wrinkled_stiffness = 0.1",
        ] {
            let e = parse(&format!("model = \"neo-hookean\"\n{bad}\n{base}")).unwrap_err();
            assert!(e.contains("wrinkled_stiffness"), "{e}");
        }
        assert_eq!(plain.model_name(), "neo-hookean");
        let e = parse(&format!(
            "model = \"goh\"\nk1 = \"1 MPa\"\nwrinkling = true\n{base}"
        ))
        .unwrap_err();
        assert!(e.contains("wrinkling") && e.contains("goh"), "{e}");
    }

    #[test]
    fn reference_steps_blend_towards_a_reference_other_than_the_sutured_one() {
        let base = "model = \"neo-hookean\"\nmu = \"300 kPa\"\nthickness = \"0.5 mm\"\npressure = \"80 mmHg\"\n";
        assert_eq!(parse(base).unwrap().reference_steps, 1);
        let c = parse(&format!(
            "{base}reference = \"flat\"\nreference_steps = 4\n"
        ))
        .unwrap();
        assert_eq!((c.reference, c.reference_steps), (Reference::Flat, 4));
        assert_eq!(c.to_json()["reference_steps"], 4);
        let e = parse(&format!("{base}reference_steps = 4\n")).unwrap_err();
        assert!(e.contains("reference_steps") && e.contains("flat"), "{e}");
        for n in [0, 101] {
            let e = parse(&format!(
                "{base}reference = \"flat\"\nreference_steps = {n}\n"
            ))
            .unwrap_err();
            assert!(e.contains("reference_steps"), "{e}");
        }
    }
}
