//! `coapt bench seed001`: seed 001 §3.1 reproduced. One leaflet of the
//! five-parameter template (R 15 mm, φ = 2π/3 − 0.4, H_c 1.5, H_b 15 mm,
//! ω = −2π/9) on its own ideal cylinder (eq. 2–3 exactly), sutured by
//! Algorithm 1 (the `[suture]` defaults are the seed's auxiliary problem),
//! then closed at 90 mmHg with 0.4 mm GOH pericardium (k₁ 1100 kPa,
//! k₂ 1000) between its two contact planes, over the seed's grid
//! μ ∈ {900, 3000} kPa × κ ∈ {0.2, 0.29, 1/3} × θ ∈ {0, π/4} (fibres
//! M = cos θ e_x ± sin θ e_y on the unfolded template). The seed reports a
//! smaller coaptation zone for the stiffer material.

use std::f64::consts::PI;
use std::time::Instant;

use clap::{Arg, ArgMatches, Command};

use super::close::{plane_distances, zones};
use coapt_base::{Error, Result};
use coapt_leaflet::{aft, place};
use coapt_mech::closure::{self};
use coapt_mech::config;
use coapt_mech::element::V3;
use coapt_mech::model::{Axis, Leaflets};
use coapt_template::seed001::Seed001;

pub const R: f64 = 15.0;
pub const MU_KPA: [f64; 2] = [900.0, 3000.0];
pub const KAPPA: [f64; 3] = [0.2, 0.29, 1.0 / 3.0];
pub const THETA: [f64; 2] = [0.0, PI / 4.0];

/// The §3.1 template.
pub fn template() -> Seed001 {
    Seed001::new(R, 2.0 * PI / 3.0 - 0.4, 1.5, 15.0, -2.0 * PI / 9.0).expect("the seed's template")
}

/// The placed §3.1 leaflet at mesh size `h` with fibres at angle `theta`
/// (axis +z through the origin).
pub fn leaflet(h: f64, theta: f64) -> std::result::Result<(Leaflets, Axis), String> {
    if !(h > 0.0 && h.is_finite()) {
        return Err(format!("mesh size h = {h} mm must be positive"));
    }
    let s = template();
    let m = aft::mesh(&s.outline(), h)?;
    let x = place::seed001_local(&s, &m);
    let (f1, f2) = place::fibres(&m, &x, theta);
    let v = |a: [f64; 3]| V3::new(a[0], a[1], a[2]);
    Ok((
        Leaflets {
            x: x.iter().map(|p| p.coords).collect(),
            tris: m.tris.clone(),
            boundary: m.boundary.clone(),
            leaflet: vec![0; m.tris.len()],
            ref_uv: Some(m.nodes.clone()),
            fibers: Some(f1.iter().zip(&f2).map(|(a, b)| [v(*a), v(*b)]).collect()),
            pressure_side: None,
        },
        Axis {
            origin: V3::zeros(),
            dir: V3::z(),
        },
    ))
}

/// One closure of the grid.
#[derive(Debug, Clone)]
pub struct Row {
    pub mu_kpa: f64,
    pub kappa: f64,
    pub theta: f64,
    pub bending: bool,
    pub nodes: usize,
    pub converged: bool,
    pub reason: String,
    pub suture_rounds: usize,
    pub iterations: usize,
    pub seconds: f64,
    /// Zone within 0.01 R of either plane (the seed's definition).
    pub coaptation_area_mm2: f64,
    pub coaptation_height_mm: f64,
}

/// The closure settings; `bending` false is the seed's membrane model,
/// true its shell (the bending stiffness D = E t³/12 on the membrane).
pub fn config_text(mu_kpa: f64, kappa: f64, bending: bool) -> String {
    format!(
        "model = \"goh\"\nmu = \"{mu_kpa} kPa\"\nk1 = \"1100 kPa\"\nk2 = 1000\nkappa = {kappa}\nthickness = \"0.4 mm\"\npressure = \"90 mmHg\"\ncontact = \"planes\"\nsolver = \"newton\"\nbending = {bending}\ntime_limit = \"300 s\"\n"
    )
}

pub fn run_one(h: f64, mu_kpa: f64, kappa: f64, theta: f64, bending: bool) -> Result<Row> {
    let (l, axis) = leaflet(h, theta).map_err(Error::usage)?;
    let cfg = config::parse(&config_text(mu_kpa, kappa, bending))
        .map_err(|e| Error::failed("bench seed001", e))?;
    let t0 = Instant::now();
    let c = closure::close(&l, &cfg, Some(axis)).map_err(|e| Error::failed("bench seed001", e))?;
    let seconds = t0.elapsed().as_secs_f64();
    // The seed's zone: signed distance to a contact plane ≤ 0.01 R, cut
    // inside triangles by the interpolated distance.
    let zone = zones(&c.x, &l.tris, &plane_distances(&l, &c.x), 0.01 * R);
    let extent = |(lo, hi, _): (f64, f64, f64)| if hi >= lo { hi - lo } else { 0.0 };
    Ok(Row {
        mu_kpa,
        kappa,
        theta,
        bending,
        nodes: l.x.len(),
        converged: c.outcome.converged,
        reason: c.outcome.reason.clone(),
        suture_rounds: c.suturing.as_ref().map_or(0, |s| s.rounds.len()),
        iterations: c.outcome.iterations,
        seconds,
        coaptation_area_mm2: zone[0].2 + zone[1].2,
        coaptation_height_mm: extent(zone[0]).max(extent(zone[1])),
    })
}

/// The whole grid at one mesh size, in a fixed order (θ, then κ, then μ).
pub fn run(h: f64, bending: bool) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
    for &theta in &THETA {
        for &kappa in &KAPPA {
            for &mu in &MU_KPA {
                rows.push(run_one(h, mu, kappa, theta, bending)?);
            }
        }
    }
    Ok(rows)
}

pub fn command() -> Command {
    Command::new("seed001")
        .about("Seed 001 §3.1 reproduced: one sutured leaflet closed between two planes over μ × κ × θ (GOH)")
        .arg(
            Arg::new("h")
                .long("h")
                .value_name("MM")
                .default_value("0.5")
                .value_parser(super::bounded::mesh_size())
                .help("mesh size (the seed's h₁ = 0.5 mm)"),
        )
        .arg(
            Arg::new("bending")
                .long("bending")
                .value_name("WHICH")
                .default_value("on")
                .value_parser(["on", "off", "both"])
                .help("shell (on: bending stiffness D = E t³/12), membrane (off), or both side by side with the area's change (seed 001 §3.3: the shell's zone is up to 8 % smaller at μ 900 kPa, 16 % at 3000 kPa)"),
        )
}

pub fn dispatch(m: &ArgMatches) -> Result<()> {
    let h = *m.get_one::<f64>("h").expect("default");
    if !(h > 0.0 && h.is_finite()) {
        return Err(Error::usage(format!("--h {h}: must be positive")));
    }
    let which: Vec<bool> = match m.get_one::<String>("bending").map(String::as_str) {
        Some("off") => vec![false],
        Some("both") => vec![true, false],
        _ => vec![true],
    };
    println!(
        "seed 001 §3.1: R {R} mm, φ 2π/3 − 0.4, Hc 1.5, Hb 15 mm, ω −2π/9; GOH k1 1100 kPa k2 1000, 0.4 mm, 90 mmHg, two planes, sutured (Algorithm 1), h {h} mm"
    );
    println!(
        "{:>7} {:>6} {:>6} {:>8} {:>6} {:>4} {:>6} {:>5} {:>7} {:>9} {:>8}",
        "mu_kPa",
        "kappa",
        "theta",
        "model",
        "nodes",
        "conv",
        "rounds",
        "iter",
        "s",
        "area_mm2",
        "height"
    );
    let mut failed = 0;
    for &theta in &THETA {
        for &kappa in &KAPPA {
            for &mu in &MU_KPA {
                let mut areas = Vec::new();
                for &bending in &which {
                    let r = run_one(h, mu, kappa, theta, bending)?;
                    println!(
                        "{:>7} {:>6.3} {:>6.3} {:>8} {:>6} {:>4} {:>6} {:>5} {:>7.2} {:>9.2} {:>8.2}",
                        r.mu_kpa,
                        r.kappa,
                        r.theta,
                        if bending { "shell" } else { "membrane" },
                        r.nodes,
                        if r.converged { "yes" } else { "no" },
                        r.suture_rounds,
                        r.iterations,
                        r.seconds,
                        r.coaptation_area_mm2,
                        r.coaptation_height_mm
                    );
                    if !r.converged {
                        println!("        not converged: {}", r.reason);
                        failed += 1;
                    }
                    areas.push(r.coaptation_area_mm2);
                }
                if let [shell, membrane] = areas[..] {
                    println!(
                        "        shell against membrane: area {:+.1} %",
                        100.0 * (shell - membrane) / membrane
                    );
                }
            }
        }
    }
    if failed > 0 {
        return Err(Error::failed(
            "bench seed001",
            format!("{failed} closure(s) did not converge"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seed 001 §3.2–3.3: on every (κ, θ) the stiffer pericardium
    /// (μ 3000 kPa) coapts over a smaller zone than μ 900 kPa, and the
    /// isotropic case does not see the fibre angle. Coarse mesh
    /// (h 1.5 mm) to keep the twelve sutured closures quick.
    #[test]
    fn stiffer_pericardium_coapts_less_over_the_seed_grid() {
        let rows = run(1.5, true).unwrap();
        assert_eq!(rows.len(), 12);
        for pair in rows.chunks(2) {
            let (soft, stiff) = (&pair[0], &pair[1]);
            assert!(soft.converged && stiff.converged, "{soft:?} {stiff:?}");
            assert!(soft.suture_rounds > 0, "not sutured");
            assert!(soft.coaptation_area_mm2 > 0.0, "{soft:?}");
            assert!(
                stiff.coaptation_area_mm2 < soft.coaptation_area_mm2,
                "κ {} θ {}: {} mm² at 3000 kPa vs {} mm² at 900 kPa",
                soft.kappa,
                soft.theta,
                stiff.coaptation_area_mm2,
                soft.coaptation_area_mm2
            );
        }
        // κ = 1/3 is the isotropic GOH (I₄* = I₁/3): the fibre angle must
        // not matter. Rows run θ, then κ, then μ.
        for m in 0..2 {
            let (a, b) = (&rows[4 + m], &rows[10 + m]);
            assert!(
                (a.coaptation_area_mm2 - b.coaptation_area_mm2).abs()
                    <= 1e-9 * a.coaptation_area_mm2,
                "{a:?} {b:?}"
            );
            assert!((a.coaptation_height_mm - b.coaptation_height_mm).abs() <= 1e-9);
        }
    }

    /// Seed 001 §3.3: the shell (membrane + bending) coapts over a smaller
    /// zone than the membrane, and more so for the stiffer pericardium
    /// (the seed: up to 8 % at μ 900 kPa, 16 % at 3000 kPa; here at h 1 mm
    /// 6.8–8.9 % and 21.5–22.6 %). At h 1.5 mm the soft cases scatter
    /// ±4 % around equal: the mesh is too coarse to see it.
    #[test]
    fn the_shell_coapts_less_than_the_membrane_and_more_so_when_stiffer() {
        let shell = run(1.0, true).unwrap();
        let membrane = run(1.0, false).unwrap();
        for pair in shell.chunks(2).zip(membrane.chunks(2)) {
            let ([s9, s3], [m9, m3]) = (pair.0, pair.1) else {
                unreachable!()
            };
            assert!(s9.converged && s3.converged && m9.converged && m3.converged);
            let drop = |s: &Row, m: &Row| 1.0 - s.coaptation_area_mm2 / m.coaptation_area_mm2;
            let (d9, d3) = (drop(s9, m9), drop(s3, m3));
            assert!(
                d9 > 0.0 && d3 > d9,
                "κ {} θ {}: shell smaller by {:.1} % at 900 kPa, {:.1} % at 3000 kPa",
                s9.kappa,
                s9.theta,
                100.0 * d9,
                100.0 * d3
            );
        }
    }
}
