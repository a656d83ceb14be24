//! Leaflet templates: the flat outlines cut from pericardium.
//!
//! * `four_parameter` — seed 000: arc B–C of radius r, extension segments of
//!   length a tangent to it, free segments of length b meeting at E. The arc
//!   is the part of the circle outside the angle BOC = α (so α = 160° gives
//!   a 200° arc whose tangents lean inwards by 10°); with this reading all
//!   four of seed 000's example templates are valid, whereas the minor-arc
//!   reading cannot close example (a) (r = a = b = 11 mm).
//! * `ozaki_size` — the Ozaki sizer table ([`OZAKI_SIZES`]): the same
//!   construction with a 170° arc (lean α = 5°), extension b, free segment a
//!   at angle β to the horizontal, r = (a cos β − b sin α)/cos α. `size =
//!   "measured"` is Ozaki's own rule: each leaflet is cut at the sizer size
//!   nearest the distance between its two commissures.
//! * `ozaki` — the group's later parametric template: belly circle of
//!   diameter D, lug corners at height H above its centre and L_f apart,
//!   apex H_f above the corners.
//! * `five_parameter` — seed 001 (R, φ, H_c, H_b, ω), eq. 1–3; its flat
//!   outline is the developed (unfolded) extruded surface, see [`Seed001`].

pub mod outline;
pub mod seed001;

use std::f64::consts::PI;

use serde::Deserialize;

use self::outline::{Edge, Outline, P2, Piece, Shape};
use self::seed001::Seed001;
use coapt_base::units::{Angle, Length};

/// One leaflet's template as written in TOML (units explicit).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TemplateSpec {
    FourParameter {
        r: Length,
        #[serde(default = "default_alpha")]
        alpha: Angle,
        a: Length,
        b: Length,
    },
    FiveParameter {
        radius: Length,
        phi: Angle,
        hc: Length,
        hb: Length,
        omega: Angle,
    },
    OzakiSize {
        size: SizerSize,
    },
    Ozaki {
        diameter: Length,
        lug_height: Length,
        apex_rise: Length,
        lug_chord: Length,
    },
}

/// An Ozaki sizer size: a number of the table, or `"measured"`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SizerSize {
    Size(u32),
    /// Ozaki's rule: the size nearest the leaflet's intercommissural
    /// distance (what the surgeon's sizer measures in the opened root).
    Measured,
}

impl<'de> Deserialize<'de> for SizerSize {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Size(u32),
            Word(String),
        }
        match Raw::deserialize(d)? {
            Raw::Size(n) => Ok(SizerSize::Size(n)),
            Raw::Word(w) if w == "measured" => Ok(SizerSize::Measured),
            Raw::Word(w) => Err(serde::de::Error::custom(format!(
                "size = {w:?}: give a sizer size (13, 15, …, 35) or \"measured\""
            ))),
        }
    }
}

/// Ozaki's rule: the sizer size nearest an intercommissural distance (the
/// smaller of two equally near, as seed 001 asks for leaflets as small as
/// suffices). A distance more than 1 mm beyond the table is refused.
pub fn sizer_size_for(distance_mm: f64) -> Result<u32, String> {
    let (lo, hi) = (
        OZAKI_SIZES[0].0 as f64,
        OZAKI_SIZES[OZAKI_SIZES.len() - 1].0 as f64,
    );
    if !(distance_mm >= lo - 1.0 && distance_mm <= hi + 1.0) {
        return Err(format!(
            "the intercommissural distance {distance_mm:.1} mm lies beyond the Ozaki sizer ({lo}–{hi} mm): give the size"
        ));
    }
    let mut best = OZAKI_SIZES[0].0;
    for &(size, ..) in &OZAKI_SIZES {
        if (size as f64 - distance_mm).abs() < (best as f64 - distance_mm).abs() {
            best = size;
        }
    }
    Ok(best)
}

fn default_alpha() -> Angle {
    Angle(160f64.to_radians())
}

/// The Ozaki sizer table: size, β (deg), a (free segment), b (extension), mm.
pub const OZAKI_SIZES: [(u32, f64, f64, f64); 12] = [
    (13, 11.4, 10.6, 11.0),
    (15, 10.9, 11.5, 11.2),
    (17, 9.0, 12.8, 13.3),
    (19, 8.8, 13.8, 13.1),
    (21, 7.8, 14.7, 13.6),
    (23, 7.7, 15.8, 13.5),
    (25, 10.0, 16.9, 13.5),
    (27, 10.0, 17.9, 13.6),
    (29, 9.3, 18.8, 13.7),
    (31, 8.3, 19.9, 14.0),
    (33, 8.2, 20.8, 14.1),
    (35, 8.0, 21.8, 14.1),
];

/// A validated template with its geometry.
#[derive(Debug, Clone, PartialEq)]
pub enum Template {
    /// Seed 000 and the Ozaki sizer presets.
    Arc(ArcTemplate),
    /// The later parametric Ozaki template.
    Ozaki(OzakiTemplate),
    /// Seed 001.
    Seed001(Seed001),
}

impl TemplateSpec {
    /// Validate and build; the error says which parameter is wrong and why.
    /// `gap_mm` is the distance between the leaflet's commissures, which
    /// `size = "measured"` needs.
    pub fn build(&self, gap_mm: Option<f64>) -> Result<Template, String> {
        match *self {
            TemplateSpec::FourParameter { r, alpha, a, b } => {
                let alpha = alpha.0;
                if !(alpha > 0.0 && alpha < PI) {
                    return Err(format!(
                        "alpha = {:.3} deg must lie in (0, 180) deg",
                        alpha.to_degrees()
                    ));
                }
                ArcTemplate::new(r.0, PI / 2.0 - alpha / 2.0, a.0, b.0).map(Template::Arc)
            }
            TemplateSpec::OzakiSize {
                size: SizerSize::Size(size),
            } => ArcTemplate::ozaki_size(size).map(Template::Arc),
            TemplateSpec::OzakiSize {
                size: SizerSize::Measured,
            } => {
                let gap = gap_mm.ok_or(
                    "size = \"measured\" needs the commissures: give this file to a stage that has valve.json or the suture paths",
                )?;
                let mut t = ArcTemplate::ozaki_size(sizer_size_for(gap)?)?;
                t.name = format!("{} (measured: intercommissural {gap:.1} mm)", t.name);
                Ok(Template::Arc(t))
            }
            TemplateSpec::Ozaki {
                diameter,
                lug_height,
                apex_rise,
                lug_chord,
            } => OzakiTemplate::new(diameter.0, lug_height.0, apex_rise.0, lug_chord.0)
                .map(Template::Ozaki),
            TemplateSpec::FiveParameter {
                radius,
                phi,
                hc,
                hb,
                omega,
            } => Seed001::new(radius.0, phi.0, hc.0, hb.0, omega.0).map(Template::Seed001),
        }
    }
}

impl Template {
    pub fn outline(&self) -> Outline {
        match self {
            Template::Arc(t) => t.outline(),
            Template::Ozaki(t) => t.outline(),
            Template::Seed001(t) => t.outline(),
        }
    }

    pub fn name(&self) -> String {
        match self {
            Template::Arc(t) => t.name.clone(),
            Template::Ozaki(t) => format!("ozaki D={} H={} Hf={} Lf={} mm", t.d, t.h, t.hf, t.lf),
            Template::Seed001(t) => format!(
                "seed001 R={} phi={:.4} rad Hc={} Hb={} omega={:.4} rad",
                t.r, t.phi, t.hc, t.hb, t.omega
            ),
        }
    }
}

/// Arc B–C of radius r about O = (0, 0) through the bottom (0, −r), tangent
/// extension segments C→D and B→A, free segments D→E→A with E on u = 0.
/// `theta_c` is the polar angle of C (positive: above O).
#[derive(Debug, Clone, PartialEq)]
pub struct ArcTemplate {
    pub name: String,
    pub r: f64,
    pub theta_c: f64,
    pub ext: f64,
    pub free: f64,
}

impl ArcTemplate {
    pub fn new(r: f64, theta_c: f64, ext: f64, free: f64) -> Result<Self, String> {
        let t = ArcTemplate {
            name: format!(
                "four_parameter r={r} alpha={:.3} deg a={ext} b={free} mm",
                180.0 - 2.0 * theta_c.to_degrees()
            ),
            r,
            theta_c,
            ext,
            free,
        };
        t.check()?;
        Ok(t)
    }

    pub fn ozaki_size(size: u32) -> Result<Self, String> {
        let &(_, beta, a, b) = OZAKI_SIZES.iter().find(|s| s.0 == size).ok_or_else(|| {
            format!("Ozaki size {size} is not in the sizer table (13, 15, …, 35)")
        })?;
        let (al, be) = (5f64.to_radians(), beta.to_radians());
        let r = (a * be.cos() - b * al.sin()) / al.cos();
        let mut t = ArcTemplate::new(r, -al, b, a)?;
        t.name = format!("ozaki_size {size}");
        Ok(t)
    }

    fn check(&self) -> Result<(), String> {
        if !(self.r > 0.0) {
            return Err(format!("arc radius r = {} mm must be positive", self.r));
        }
        if !(self.ext > 0.0) {
            return Err(format!(
                "extension segment length = {} mm must be positive",
                self.ext
            ));
        }
        if !(self.free > 0.0) {
            return Err(format!(
                "free segment length = {} mm must be positive",
                self.free
            ));
        }
        let d = self.d();
        if !(d[0] > 0.0) {
            return Err(format!(
                "extension segments a = {} mm cross the centre line (the outline must not self-intersect)",
                self.ext
            ));
        }
        // E must sit strictly above D: the free edge has to reach the centre
        // line with some rise, or the apex angle degenerates.
        if !(self.free > d[0] * (1.0 + 1e-6)) {
            return Err(format!(
                "free segment b = {} mm is too short to reach the centre line ({:.3} mm away)",
                self.free, d[0]
            ));
        }
        Ok(())
    }

    fn c(&self) -> P2 {
        [self.r * self.theta_c.cos(), self.r * self.theta_c.sin()]
    }

    fn d(&self) -> P2 {
        let c = self.c();
        let (s, co) = self.theta_c.sin_cos();
        [c[0] - self.ext * s, c[1] + self.ext * co]
    }

    pub fn apex(&self) -> P2 {
        let d = self.d();
        [0.0, d[1] + (self.free * self.free - d[0] * d[0]).sqrt()]
    }

    pub fn outline(&self) -> Outline {
        let c = self.c();
        let d = self.d();
        let b = [-c[0], c[1]];
        let a = [-d[0], d[1]];
        let e = self.apex();
        let pieces = vec![
            piece_arc(
                [0.0, 0.0],
                self.r,
                PI - self.theta_c,
                PI + 2.0 * self.theta_c,
            ),
            seg(c, d, Edge::Sutured),
            seg(d, e, Edge::Free),
            seg(e, a, Edge::Free),
            seg(a, b, Edge::Sutured),
        ];
        Outline::new(pieces).expect("validated arc template closes")
    }
}

/// Parametric Ozaki template of the seeds' group's later code (belly circle
/// of diameter D, lug corners H above its centre and L_f apart, apex H_f
/// above the corners), symmetric about u = 0, belly circle centred at the
/// origin.
#[derive(Debug, Clone, PartialEq)]
pub struct OzakiTemplate {
    pub d: f64,
    pub h: f64,
    pub hf: f64,
    pub lf: f64,
}

impl OzakiTemplate {
    pub fn new(d: f64, h: f64, hf: f64, lf: f64) -> Result<Self, String> {
        if !(d > 0.0) {
            return Err(format!("belly diameter D = {d} mm must be positive"));
        }
        if !(lf > 0.0) {
            return Err(format!("lug chord L_f = {lf} mm must be positive"));
        }
        if !(h >= 0.0) {
            return Err(format!("lug height H = {h} mm must not be negative"));
        }
        if !(hf > -h) {
            return Err(format!(
                "apex rise H_f = {hf} mm must exceed −H = {} mm (apex above the belly centre)",
                -h
            ));
        }
        if !(h * h + lf * lf / 4.0 > d * d / 4.0 * (1.0 + 1e-6)) {
            return Err(format!(
                "lug corners (H = {h}, L_f = {lf} mm) lie inside the belly circle (D = {d} mm)"
            ));
        }
        Ok(OzakiTemplate { d, h, hf, lf })
    }

    /// Half-angle of the belly arc: φ = π − atan(L_f/(2H)) − arccos(D/(2q)),
    /// q = √(H² + L_f²/4).
    pub fn phi(&self) -> f64 {
        let q = (self.h * self.h + self.lf * self.lf / 4.0).sqrt();
        PI - (self.lf / (2.0 * self.h)).atan() - (self.d / (2.0 * q)).acos()
    }

    /// Closed forms: free edge 2√(H_f² + L_f²/4); sutured edge
    /// D·φ + 2√(H² + L_f²/4 − D²/4).
    pub fn free_length(&self) -> f64 {
        2.0 * (self.hf * self.hf + self.lf * self.lf / 4.0).sqrt()
    }

    pub fn sutured_length(&self) -> f64 {
        self.d * self.phi()
            + 2.0 * (self.h * self.h + self.lf * self.lf / 4.0 - self.d * self.d / 4.0).sqrt()
    }

    pub fn outline(&self) -> Outline {
        let r = self.d / 2.0;
        let g = self.phi();
        let lug_r = [self.lf / 2.0, self.h];
        let lug_l = [-self.lf / 2.0, self.h];
        let apex = [0.0, self.h + self.hf];
        let tan_r = [r * g.sin(), -r * g.cos()];
        let tan_l = [-tan_r[0], tan_r[1]];
        let pieces = vec![
            piece_arc([0.0, 0.0], r, -PI / 2.0 - g, 2.0 * g),
            seg(tan_r, lug_r, Edge::Sutured),
            seg(lug_r, apex, Edge::Free),
            seg(apex, lug_l, Edge::Free),
            seg(lug_l, tan_l, Edge::Sutured),
        ];
        Outline::new(pieces).expect("validated Ozaki template closes")
    }
}

fn seg(a: P2, b: P2, edge: Edge) -> Piece {
    Piece {
        shape: Shape::Segment { a, b },
        edge,
    }
}

fn piece_arc(centre: P2, radius: f64, start: f64, sweep: f64) -> Piece {
    Piece {
        shape: Shape::Arc {
            centre,
            radius,
            start,
            sweep,
        },
        edge: Edge::Sutured,
    }
}

/// A template file: `[template]` for all three leaflets, or `[leaflet1]`,
/// `[leaflet2]`, `[leaflet3]` (each overriding `[template]`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct TemplateFile {
    template: Option<TemplateSpec>,
    leaflet1: Option<TemplateSpec>,
    leaflet2: Option<TemplateSpec>,
    leaflet3: Option<TemplateSpec>,
}

/// Read, parse and validate a template file (bad input names the file).
/// `gaps_mm[k]`: the distance between leaflet k's two commissures (the
/// ends of its suture path), for `size = "measured"`.
pub fn read_templates(
    path: &std::path::Path,
    gaps_mm: Option<[f64; 3]>,
) -> coapt_base::Result<[Template; 3]> {
    let text = std::fs::read_to_string(path).map_err(|e| coapt_base::Error::read(path, e))?;
    parse_templates(&text, gaps_mm).map_err(|e| coapt_base::Error::bad_input(path, e))
}

/// Check a template file before the commissures are known: every
/// template with its own numbers is built, `"measured"` sizes are left
/// for the stage that knows the commissures.
pub fn check_templates(path: &std::path::Path) -> coapt_base::Result<()> {
    let text = std::fs::read_to_string(path).map_err(|e| coapt_base::Error::read(path, e))?;
    let specs = parse_specs(&text).map_err(|e| coapt_base::Error::bad_input(path, e))?;
    for (k, spec) in specs.iter().enumerate() {
        if !matches!(
            spec,
            TemplateSpec::OzakiSize {
                size: SizerSize::Measured
            }
        ) {
            spec.build(None).map_err(|e| {
                coapt_base::Error::bad_input(path, format!("leaflet {}: {e}", k + 1))
            })?;
        }
    }
    Ok(())
}

fn parse_specs(text: &str) -> Result<[TemplateSpec; 3], String> {
    let f: TemplateFile =
        toml::from_str(text).map_err(|e| coapt_io::toml_error::describe(text, &e))?;
    let specs = [f.leaflet1, f.leaflet2, f.leaflet3];
    let mut out = Vec::with_capacity(3);
    for (i, s) in specs.into_iter().enumerate() {
        out.push(s.or_else(|| f.template.clone()).ok_or_else(|| {
            format!(
                "no template for leaflet {}: give [template] or [leaflet{}]",
                i + 1,
                i + 1
            )
        })?);
    }
    Ok(out.try_into().expect("three templates"))
}

/// Parse and validate a template file's text: one template per leaflet.
pub fn parse_templates(text: &str, gaps_mm: Option<[f64; 3]>) -> Result<[Template; 3], String> {
    let specs = parse_specs(text)?;
    let mut out = Vec::with_capacity(3);
    for (i, spec) in specs.iter().enumerate() {
        out.push(
            spec.build(gaps_mm.map(|g| g[i]))
                .map_err(|e| format!("leaflet {}: {e}", i + 1))?,
        );
    }
    Ok(out.try_into().expect("three templates"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parametric_ozaki_default_lengths() {
        // The seeds' group's default template (D 19, H 11, H_f 2, L_f 24 mm):
        // free edge 24.33 mm, sutured edge 52.4 mm.
        let t = OzakiTemplate::new(19.0, 11.0, 2.0, 24.0).unwrap();
        assert!((t.free_length() - 24.33).abs() < 0.005);
        assert!((t.sutured_length() - 52.4).abs() < 0.05);
        let o = t.outline();
        assert!((o.length(Edge::Free) - t.free_length()).abs() < 1e-12);
        assert!((o.length(Edge::Sutured) - t.sutured_length()).abs() < 1e-12);
    }

    #[test]
    fn ozaki_sizes_match_the_table_construction() {
        for &(size, beta, a, _b) in &OZAKI_SIZES {
            let t = ArcTemplate::ozaki_size(size).unwrap();
            // Apex at height a·sin β above the lug corners, lug at u = a·cos β.
            let d = t.d();
            let e = t.apex();
            let be = beta.to_radians();
            assert!((d[0] - a * be.cos()).abs() < 1e-12, "size {size}");
            assert!((e[1] - d[1] - a * be.sin()).abs() < 1e-9, "size {size}");
            assert!((t.outline().length(Edge::Free) - 2.0 * a).abs() < 1e-12);
        }
    }

    #[test]
    fn seed000_examples_are_valid_and_bad_ones_refused() {
        for (r, a, b) in [
            (11.0, 11.0, 11.0),
            (12.0, 13.0, 13.0),
            (13.0, 13.0, 14.0),
            (14.5, 15.8, 13.5),
        ] {
            let spec = TemplateSpec::FourParameter {
                r: Length(r),
                alpha: default_alpha(),
                a: Length(a),
                b: Length(b),
            };
            let t = spec.build(None).unwrap();
            let o = t.outline();
            // Arc 200° + two extensions.
            let expect = r * 200f64.to_radians() + 2.0 * a;
            assert!((o.length(Edge::Sutured) - expect).abs() < 1e-12);
            assert!((o.length(Edge::Free) - 2.0 * b).abs() < 1e-12);
        }
        let bad = |r, al: f64, a, b| {
            TemplateSpec::FourParameter {
                r: Length(r),
                alpha: Angle(al.to_radians()),
                a: Length(a),
                b: Length(b),
            }
            .build(None)
            .unwrap_err()
        };
        assert!(bad(-1.0, 160.0, 11.0, 11.0).contains("positive"));
        assert!(bad(11.0, 160.0, -2.0, 11.0).contains("positive"));
        assert!(bad(11.0, 160.0, 11.0, 5.0).contains("too short"));
        assert!(bad(11.0, 180.0, 11.0, 11.0).contains("(0, 180)"));
        assert!(bad(11.0, 0.0, 11.0, 11.0).contains("(0, 180)"));
    }

    #[test]
    fn the_measured_size_is_the_sizer_size_nearest_each_leaflets_commissures() {
        assert_eq!(sizer_size_for(21.1), Ok(21));
        assert_eq!(sizer_size_for(25.6), Ok(25));
        assert_eq!(sizer_size_for(24.0), Ok(23), "a tie goes to the smaller");
        assert_eq!(sizer_size_for(24.01), Ok(25));
        assert_eq!(sizer_size_for(12.0), Ok(13));
        assert_eq!(sizer_size_for(36.0), Ok(35));
        for bad in [11.9, 36.1, f64::NAN] {
            assert!(
                sizer_size_for(bad)
                    .unwrap_err()
                    .contains("beyond the Ozaki sizer")
            );
        }
        let text = "[template]\nkind = \"ozaki_size\"\nsize = \"measured\"\n[leaflet3]\nkind = \"ozaki_size\"\nsize = 19\n";
        let t = parse_templates(text, Some([22.4, 25.6, 30.0])).unwrap();
        let names: Vec<String> = t.iter().map(Template::name).collect();
        assert_eq!(
            names,
            [
                "ozaki_size 23 (measured: intercommissural 22.4 mm)",
                "ozaki_size 25 (measured: intercommissural 25.6 mm)",
                "ozaki_size 19",
            ]
        );
        // The outline is the table's: the same as the size given by number.
        let by_number = ArcTemplate::ozaki_size(25).unwrap().outline();
        assert_eq!(
            t[1].outline().length(Edge::Free),
            by_number.length(Edge::Free)
        );
        let e = parse_templates(text, None).unwrap_err();
        assert!(
            e.contains("leaflet 1") && e.contains("needs the commissures"),
            "{e}"
        );
        let e = parse_templates(text, Some([40.0, 25.0, 25.0])).unwrap_err();
        assert!(e.contains("40.0 mm lies beyond"), "{e}");
        let e = parse_templates("[template]\nkind = \"ozaki_size\"\nsize = \"big\"\n", None)
            .unwrap_err();
        assert!(e.contains("\"measured\""), "{e}");
    }

    #[test]
    fn toml_files_parse_with_units_and_refuse_bare_numbers() {
        let t = parse_templates(
            "[template]\nkind = \"ozaki\"\ndiameter = \"19 mm\"\nlug_height = \"11 mm\"\n\
             apex_rise = \"2 mm\"\nlug_chord = \"24 mm\"\n[leaflet2]\nkind = \"ozaki_size\"\nsize = 21\n",
            None,
        )
        .unwrap();
        assert!(matches!(t[0], Template::Ozaki(_)));
        assert!(matches!(t[1], Template::Arc(_)));
        let e = parse_templates(
            "[template]\nkind = \"four_parameter\"\nr = 11\na = \"11 mm\"\nb = \"11 mm\"\n",
            None,
        )
        .unwrap_err();
        assert!(e.contains("unit"), "{e}");
        let e =
            parse_templates("[template]\nkind = \"ozaki_size\"\nsize = 14\n", None).unwrap_err();
        assert!(e.contains("sizer table"), "{e}");
        let e =
            parse_templates("[leaflet1]\nkind = \"ozaki_size\"\nsize = 19\n", None).unwrap_err();
        assert!(e.contains("leaflet 2"), "{e}");
        let e = parse_templates(
            "[template]\nkind = \"ozaki_size\"\nsize = 19\nextra = 1\n",
            None,
        )
        .unwrap_err();
        assert!(e.contains("extra"), "{e}");
    }
}

/// The 18 templates the mesher is held to (quality test and `cargo bench
/// --bench mesher`): four seed 000 templates, the twelve Ozaki sizer
/// presets, the parametric Ozaki template and the seed 001 §3.1 case.
pub fn reference_templates() -> Vec<Template> {
    let mut v = Vec::new();
    for (r, a, b) in [
        (11.0, 11.0, 11.0),
        (12.0, 13.0, 13.0),
        (13.0, 13.0, 14.0),
        (14.5, 15.8, 13.5),
    ] {
        v.push(
            TemplateSpec::FourParameter {
                r: Length(r),
                alpha: Angle(160f64.to_radians()),
                a: Length(a),
                b: Length(b),
            }
            .build(None)
            .expect("a valid four-parameter template"),
        );
    }
    for &(size, ..) in &OZAKI_SIZES {
        v.push(Template::Arc(
            ArcTemplate::ozaki_size(size).expect("a sizer preset"),
        ));
    }
    v.push(Template::Ozaki(
        OzakiTemplate::new(19.0, 11.0, 2.0, 24.0).expect("the peer template"),
    ));
    v.push(Template::Seed001(
        Seed001::new(15.0, 2.0 * PI / 3.0 - 0.4, 1.5, 15.0, -2.0 * PI / 9.0)
            .expect("the seed 001 §3.1 case"),
    ));
    v
}
