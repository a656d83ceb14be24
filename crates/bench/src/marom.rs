//! `coapt bench marom`: seed 000's closure benchmark (lines ~165–200 of
//! `000_*.txt`). The native-like valve of [`super::marom_geometry`]
//! (d_AA 24 mm) closed with true leaflet-to-leaflet contact under each of
//! the seed's membrane laws at its parameters — thickness 0.3 mm, E 1 MPa;
//! MSM linear springs of E 1 MPa; St.V-K ν 0.45; neo-Hookean μ = E/3; Gent
//! μ = E/3, J_m 2.3 — at 80 mmHg, then again at 3 mmHg for the effective
//! height, and measured by the seed's definitions with the report's code:
//!
//! - h_E: the height above the annulus (nadir) plane of the free-edge point
//!   nearest the axis, mean of the three leaflets, on the 3 mmHg closure
//!   (the seed reads h_E at 3 mmHg);
//! - h_C-C: the report's coaptation height read at 5 mm from the axis (the
//!   band of each pair's zone 4.75–5.25 mm off the axis), mean of the pairs;
//! - h_avr: coaptation area / free-edge length, summed over the leaflets;
//! - NCCA: coaptation area / closed cusp area, summed over the leaflets.
//!
//! The coaptation zone is the report's: the part of a leaflet within
//! 1.8 × thickness (0.54 mm) of another leaflet's mid-surface.

use std::time::Instant;

use clap::{Arg, ArgMatches, Command};

use super::marom_geometry as geo;
use coapt_base::{Error, Result};
use coapt_geom::Point3;
use coapt_mech::closure::{self, Closed};
use coapt_mech::config;
use coapt_mech::model::Leaflets;
use coapt_report::ClosedValve;
use coapt_report::coaptation::{self, Options as ZoneOptions};
use coapt_report::metrics::{self, Options as MetricOptions};

/// The seed's laws, in its table's order.
pub const LAWS: [&str; 4] = ["msm", "svk", "neo-hookean", "gent"];
/// Leaflet thickness (mm).
pub const THICKNESS: f64 = 0.3;
/// The report's contact margin per thickness.
pub const MARGIN_PER_THICKNESS: f64 = 1.8;

/// Seed 000's table: h_E, h_C-C, h_avr (mm), NCCA (%), CPU time (s).
pub fn seed_row(law: &str) -> [f64; 5] {
    match law {
        "msm" => [10.8, 3.8, 3.3, 25.0, 44.0],
        "svk" => [10.8, 3.1, 2.9, 24.0, 58.0],
        "neo-hookean" => [10.4, 3.0, 2.5, 21.0, 136.0],
        "gent" => [10.8, 3.4, 3.1, 24.0, 203.0],
        _ => [f64::NAN; 5],
    }
}

/// Marom et al.'s FSI (seed 000's first row): h_E, h_C-C, h_avr, NCCA %.
pub const FSI: [f64; 4] = [10.5, 1.5, 2.7, 21.0];

/// `close.toml` of one law at `pressure_mmhg`.
pub fn config_text(law: &str, pressure_mmhg: f64, bending: bool) -> String {
    let material = match law {
        "msm" => "model = \"msm\"\nmsm_law = \"linear\"\nyoung = \"1 MPa\"\n",
        "svk" => "model = \"svk\"\nyoung = \"1 MPa\"\npoisson = 0.45\n",
        "neo-hookean" => "model = \"neo-hookean\"\nyoung = \"1 MPa\"\n",
        "gent" => "model = \"gent\"\nyoung = \"1 MPa\"\njm = 2.3\n",
        other => panic!("unknown law {other}"),
    };
    format!(
        "{material}thickness = \"{THICKNESS} mm\"\npressure = \"{pressure_mmhg} mmHg\"\ncontact = \"leaflets\"\nsolver = \"newton\"\nbending = {bending}\nreference = \"placed\"\ntime_limit = \"600 s\"\n[suture]\nmode = \"off\"\n"
    )
}

/// One law's closures and numbers.
#[derive(Debug, Clone)]
pub struct Row {
    pub law: String,
    pub h: f64,
    pub nodes: usize,
    pub converged: bool,
    /// The solver's account when a closure did not converge.
    pub reason: String,
    pub iterations: [usize; 2],
    /// Wall seconds of the 80 mmHg and the 3 mmHg closure.
    pub seconds: [f64; 2],
    /// Crossing triangle pairs of different leaflets at 80 / 3 mmHg.
    pub crossings: [usize; 2],
    pub h_e_mm: Option<f64>,
    pub h_e_80_mm: Option<f64>,
    /// The same height on the placed (stress-free) leaflets.
    pub h_e_placed_mm: Option<f64>,
    pub h_cc_mm: Option<f64>,
    pub h_avr_mm: Option<f64>,
    pub ncca: Option<f64>,
    pub coaptation_height_mm: Option<f64>,
    pub central_coaptation_height_mm: Option<f64>,
    pub coaptation_area_mm2: f64,
    pub free_edge_mm: f64,
    pub cusp_area_mm2: f64,
}

fn valve_of(l: &Leaflets, c: &Closed) -> ClosedValve {
    let p = |v: &coapt_mech::element::V3| Point3::from(*v);
    ClosedValve {
        x: c.x.iter().map(p).collect(),
        x0: l.x.iter().map(p).collect(),
        tris: l.tris.clone(),
        tri_leaflet: l.leaflet.iter().map(|&k| k as u8).collect(),
        boundary: l.boundary.clone(),
        ref_uv: l.ref_uv.clone(),
        frame: geo::frame(),
        leaflets: 3,
    }
}

/// Close the valve at mesh size `h` under `law` and measure it.
pub fn run_one(h: f64, law: &str, bending: bool) -> Result<Row> {
    run_with(h, law, bending, geo::COMMISSURE_HEIGHT)
}

/// [`run_one`] on the cusp of [`geo::cusp_with`]`(lug_height)`.
pub fn run_with(h: f64, law: &str, bending: bool, lug_height: f64) -> Result<Row> {
    run_measured(
        h,
        law,
        bending,
        lug_height,
        MARGIN_PER_THICKNESS * THICKNESS,
    )
}

/// [`run_with`] with the coaptation zone cut at `margin_mm` from the other
/// leaflets (the report's default: 1.8 × thickness).
pub fn run_measured(
    h: f64,
    law: &str,
    bending: bool,
    lug_height: f64,
    margin_mm: f64,
) -> Result<Row> {
    let fail = |e: String| Error::failed("bench marom", e);
    let (l, axis) = geo::valve_with(h, lug_height).map_err(fail)?;
    let mut row = Row {
        law: law.to_string(),
        h,
        nodes: l.x.len(),
        converged: false,
        reason: String::new(),
        iterations: [0; 2],
        seconds: [0.0; 2],
        crossings: [0; 2],
        h_e_mm: None,
        h_e_80_mm: None,
        h_e_placed_mm: None,
        h_cc_mm: None,
        h_avr_mm: None,
        ncca: None,
        coaptation_height_mm: None,
        central_coaptation_height_mm: None,
        coaptation_area_mm2: 0.0,
        free_edge_mm: 0.0,
        cusp_area_mm2: 0.0,
    };
    let mut closed = Vec::new();
    for (k, p) in [80.0, 3.0].into_iter().enumerate() {
        let cfg = config::parse(&config_text(law, p, bending)).map_err(fail)?;
        let t0 = Instant::now();
        let c = closure::close(&l, &cfg, Some(axis)).map_err(fail)?;
        row.seconds[k] = t0.elapsed().as_secs_f64();
        row.iterations[k] = c.outcome.iterations;
        row.crossings[k] = c.crossings.len();
        if !c.outcome.converged {
            row.reason = format!("{p} mmHg: {}", c.outcome.reason);
            return Ok(row);
        }
        closed.push(c);
    }
    row.converged = true;
    let v = valve_of(&l, &closed[0]);
    let zone = coaptation::find(
        &v,
        &ZoneOptions {
            margin_mm,
            refine: 4,
        },
    );
    let m = metrics::measure(
        &v,
        &zone,
        &MetricOptions {
            half_thickness_mm: 0.5 * THICKNESS,
            ..MetricOptions::default()
        },
    );
    let low: Vec<Point3> = closed[1].x.iter().map(|q| Point3::from(*q)).collect();
    row.h_e_mm = metrics::effective_height_at(&v, &low, 3);
    row.h_e_80_mm = m.effective_height_mm;
    row.h_e_placed_mm = metrics::effective_height_at(&v, &v.x0, 3);
    row.h_cc_mm = m.h_cc_mm;
    row.h_avr_mm = m.h_avr_mm;
    row.ncca = m.ncca;
    row.coaptation_height_mm = m.coaptation_height_mm;
    row.central_coaptation_height_mm = m.central_coaptation_height_mm;
    row.coaptation_area_mm2 = m.leaflets.iter().map(|q| q.coaptation_area_mm2).sum();
    row.free_edge_mm = m.leaflets.iter().map(|q| q.free_edge_length_mm).sum();
    row.cusp_area_mm2 = m.leaflets.iter().map(|q| q.cusp_area_closed_mm2).sum();
    Ok(row)
}

const CSV_HEADER: &str = "law,h_mm,nodes,converged,iterations_80,iterations_3,wall_s_80,wall_s_3,crossings_80,crossings_3,h_e_3mmhg_mm,h_e_80mmhg_mm,h_e_placed_mm,h_cc_mm,h_avr_mm,ncca,coaptation_height_mm,central_coaptation_height_mm,coaptation_area_mm2,free_edge_mm,cusp_area_mm2,reason";

/// One CSV line; numbers in Rust's shortest round-trip form, so equal
/// lines mean bit-identical results.
fn csv_line(r: &Row) -> String {
    let o = |v: Option<f64>| v.map(|x| format!("{x:?}")).unwrap_or_default();
    format!(
        "{},{:?},{},{},{},{},{:.3},{:.3},{},{},{},{},{},{},{},{},{},{},{:?},{:?},{:?},\"{}\"",
        r.law,
        r.h,
        r.nodes,
        r.converged,
        r.iterations[0],
        r.iterations[1],
        r.seconds[0],
        r.seconds[1],
        r.crossings[0],
        r.crossings[1],
        o(r.h_e_mm),
        o(r.h_e_80_mm),
        o(r.h_e_placed_mm),
        o(r.h_cc_mm),
        o(r.h_avr_mm),
        o(r.ncca),
        o(r.coaptation_height_mm),
        o(r.central_coaptation_height_mm),
        r.coaptation_area_mm2,
        r.free_edge_mm,
        r.cusp_area_mm2,
        r.reason.replace('"', "'")
    )
}

pub fn command() -> Command {
    Command::new("marom")
        .about("Seed 000's closure benchmark: a native-like valve (d_AA 24 mm; Marom et al. 2013's template stand-in) closed with true contact under MSM, St.V-K, neo-Hookean and Gent, beside the seed's table")
        .arg(
            Arg::new("h")
                .long("h")
                .value_name("MM")
                .default_value("0.5")
                .value_parser(super::bounded::mesh_size())
                .help("mesh size (mm)"),
        )
        .arg(
            Arg::new("laws")
                .long("laws")
                .value_name("LIST")
                .default_value("msm,svk,neo-hookean,gent")
                .help("comma-separated laws: msm, svk, neo-hookean, gent"),
        )
        .arg(
            Arg::new("lug-height")
                .long("lug-height")
                .value_name("MM")
                .value_parser(super::bounded::number(5.0, 30.0, " mm"))
                .help("sensitivity only: the flat cusp's lug corners this far above its lowest point (default: the commissure height, 17.8 mm); a lower cusp hangs lower"),
        )
        .arg(
            Arg::new("margin")
                .long("margin")
                .value_name("MM")
                .value_parser(super::bounded::number(0.01, 5.0, " mm"))
                .help("coaptation margin: a point coapts within this distance of another leaflet (default 1.8 × thickness = 0.54 mm, the report's)"),
        )
        .arg(
            Arg::new("csv")
                .long("csv")
                .value_name("FILE")
                .value_parser(clap::value_parser!(std::path::PathBuf))
                .help("also write every number at full precision (one line per law)"),
        )
        .arg(
            Arg::new("bending")
                .long("bending")
                .action(clap::ArgAction::SetTrue)
                .help("add the hinge bending stiffness D = E t³/12 (the seed's laws are membranes: off by default)"),
        )
}

fn opt(v: Option<f64>, scale: f64, prec: usize) -> String {
    v.map(|x| format!("{:.*}", prec, x * scale))
        .unwrap_or_else(|| "–".into())
}

pub fn dispatch(m: &ArgMatches) -> Result<()> {
    let h = *m.get_one::<f64>("h").expect("default");
    if !(h > 0.0 && h.is_finite()) {
        return Err(Error::usage(format!("--h {h}: must be positive")));
    }
    let bending = m.get_flag("bending");
    let lug = m
        .get_one::<f64>("lug-height")
        .copied()
        .unwrap_or(geo::COMMISSURE_HEIGHT);
    let margin = m
        .get_one::<f64>("margin")
        .copied()
        .unwrap_or(MARGIN_PER_THICKNESS * THICKNESS);
    if !(margin > 0.0 && margin.is_finite()) {
        return Err(Error::usage(format!("--margin {margin}: must be positive")));
    }
    let laws: Vec<String> = m
        .get_one::<String>("laws")
        .expect("default")
        .split(',')
        .map(|s| s.trim().to_string())
        .collect();
    for l in &laws {
        if !LAWS.contains(&l.as_str()) {
            return Err(Error::usage(format!(
                "--laws: unknown law {l:?} (msm, svk, neo-hookean, gent)"
            )));
        }
    }
    let c = geo::cusp_with(lug).map_err(|e| Error::usage(format!("--lug-height {lug}: {e}")))?;
    let attach: f64 = geo::attachment(0)
        .windows(2)
        .map(|w| (w[1] - w[0]).norm())
        .sum();
    println!(
        "seed 000 closure benchmark (stand-in for Marom et al. 2013's template): d_AA {} mm, commissures {} mm above the annulus, cusp D {} H {:.2} H_f {} L_f {:.2} mm (free edge {:.1} mm, attached edge {:.1} mm on a {:.1} mm attachment line), t {THICKNESS} mm, E 1 MPa, true contact, {}, h {h} mm, coaptation margin {margin} mm",
        geo::D_AA,
        geo::COMMISSURE_HEIGHT,
        c.d,
        c.h,
        c.hf,
        c.lf,
        c.free_length(),
        c.sutured_length(),
        attach,
        if bending {
            "membrane + bending"
        } else {
            "membrane"
        }
    );
    println!(
        "h_E at 3 mmHg, the rest at 80 mmHg; each cell: ours (seed's); FSI (Marom): h_E {} h_C-C {} h_avr {} mm, NCCA {} %",
        FSI[0], FSI[1], FSI[2], FSI[3]
    );
    println!(
        "{:<12} {:>6} {:>13} {:>13} {:>13} {:>13} {:>7} {:>9} {:>9} {:>11} {:>7}",
        "law",
        "nodes",
        "h_E mm",
        "h_C-C mm",
        "h_avr mm",
        "NCCA %",
        "h_E80",
        "crossing",
        "its",
        "s (80+3)",
        "seed s"
    );
    let mut failed = 0;
    let mut csv = String::from(CSV_HEADER);
    csv.push('\n');
    for law in &laws {
        let r = run_measured(h, law, bending, lug, margin)?;
        csv += &csv_line(&r);
        csv.push('\n');
        let s = seed_row(law);
        let cell =
            |v: Option<f64>, scale: f64, seed: f64| format!("{} ({})", opt(v, scale, 2), seed);
        println!(
            "{:<12} {:>6} {:>13} {:>13} {:>13} {:>13} {:>7} {:>9} {:>9} {:>11} {:>7}",
            r.law,
            r.nodes,
            cell(r.h_e_mm, 1.0, s[0]),
            cell(r.h_cc_mm, 1.0, s[1]),
            cell(r.h_avr_mm, 1.0, s[2]),
            cell(r.ncca, 100.0, s[3]),
            opt(r.h_e_80_mm, 1.0, 2),
            format!("{}/{}", r.crossings[0], r.crossings[1]),
            format!("{}+{}", r.iterations[0], r.iterations[1]),
            format!("{:.2}+{:.2}", r.seconds[0], r.seconds[1]),
            s[4]
        );
        if r.converged {
            println!(
                "             coaptation area {:.1} mm², free edge {:.1} mm, cusp area {:.1} mm² (three leaflets); coaptation height {} mm, central {} mm; h_E placed (unloaded) {} mm",
                r.coaptation_area_mm2,
                r.free_edge_mm,
                r.cusp_area_mm2,
                opt(r.coaptation_height_mm, 1.0, 2),
                opt(r.central_coaptation_height_mm, 1.0, 2),
                opt(r.h_e_placed_mm, 1.0, 2)
            );
        } else {
            println!("             not converged: {}", r.reason);
            failed += 1;
        }
    }
    if let Some(path) = m.get_one::<std::path::PathBuf>("csv") {
        std::fs::write(path, csv).map_err(|e| Error::write(path, e))?;
    }
    if failed > 0 {
        return Err(Error::failed(
            "bench marom",
            format!("{failed} closure(s) did not converge"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seed 000's closure benchmark at a coarse mesh (h 1.5 mm, membrane as
    /// in the seed): every law closes with true contact and no crossing
    /// triangle pair at 80 and at 3 mmHg; the valve is closed (a triple
    /// zone); at 3 mmHg the free edge's centre stands higher than at
    /// 80 mmHg and below the commissures; the zone's share of the cusp is a
    /// fraction. h_E is *not* held to the seed's 10.4–10.8 mm: on this
    /// stand-in for Marom's template it is 15.4–15.5 mm (docs/verification.md,
    /// "Seed 000's closure benchmark": the cusp's geometric height decides
    /// it), so the band checked is that result's.
    #[test]
    fn marom_benchmark_closes_every_law_without_crossings() {
        for law in LAWS {
            let r = run_one(1.5, law, false).unwrap();
            assert!(r.converged, "{law}: {}", r.reason);
            assert_eq!(r.crossings, [0, 0], "{law}");
            let he = r.h_e_mm.unwrap();
            let he80 = r.h_e_80_mm.unwrap();
            assert!(
                he > he80 && he < geo::COMMISSURE_HEIGHT,
                "{law}: h_E {he} / {he80} mm"
            );
            assert!((14.5..16.5).contains(&he), "{law}: h_E {he} mm");
            assert!(
                r.central_coaptation_height_mm.unwrap() > 0.0,
                "{law}: not closed"
            );
            let ncca = r.ncca.unwrap();
            assert!(ncca > 0.1 && ncca < 0.6, "{law}: NCCA {ncca}");
            assert!(r.h_cc_mm.unwrap() > 0.0 && r.h_avr_mm.unwrap() > 0.0);
        }
    }
}
