//! `coapt bench stress-close`: the closure solver on hundreds of randomised,
//! deliberately hostile variants of the peer case (one Ozaki leaflet on the
//! cylindrical root, two contact planes): node positions jittered up to
//! 0.3 h, triangles squeezed toward degeneracy, pressure 5–200 mmHg,
//! stiffness 10 kPa–100 MPa, thickness 0.1–1 mm, mesh 0.25–3 mm, four
//! material models, with and without bending. Every case comes from
//! (seed, index) alone, so a run is reproducible and one case can be
//! replayed. Each ends in one of four ways: converged; failed with a
//! diagnosis (the solver's reason or the input error); non-finite numbers;
//! or a hang (still running well past its own time limit). The target is no
//! NaN, no hang, and a reason for every failure.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use rayon::prelude::*;

use super::close::{circumferential_fibres, ozaki_cylinder};
use coapt_base::rng::SplitMix64;
use coapt_base::{Error, Result};
use coapt_mech::closure;
use coapt_mech::config;
use coapt_mech::element::V3;
use coapt_mech::model;

/// The material laws drawn from.
pub const MODELS: [&str; 4] = ["neo-hookean", "svk", "goh", "msm"];

/// One randomised closure.
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    pub index: usize,
    pub h_mm: f64,
    pub model: &'static str,
    pub pressure_mmhg: f64,
    pub young_mpa: f64,
    pub thickness_mm: f64,
    pub bending: bool,
    /// Largest node displacement of the jitter, as a fraction of h.
    pub jitter: f64,
    /// Fraction of triangles squeezed, and how far (1: flat).
    pub squeezed: f64,
    pub squeeze: f64,
    /// Stream of the perturbations.
    pub stream: u64,
}

fn log_uniform(r: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    (r.range(lo.ln(), hi.ln())).exp()
}

/// Where the physical parameters of the cases are drawn from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ranges {
    pub pressure_mmhg: (f64, f64),
    /// Drawn log-uniformly.
    pub young_mpa: (f64, f64),
    pub thickness_mm: (f64, f64),
    /// Whether some triangles are squeezed toward degeneracy (height down
    /// to 0.1 % of their size); the jitter (≤ 0.3 h) is always applied.
    pub squeeze: bool,
}

/// The hostile ranges: far beyond any valve.
pub const HOSTILE: Ranges = Ranges {
    pressure_mmhg: (5.0, 200.0),
    young_mpa: (0.01, 100.0),
    thickness_mm: (0.1, 1.0),
    squeeze: true,
};

/// The plausible ranges (issue "closure trust"): pericardium, fixed or
/// fresh, 0.3–10 MPa; diastolic pressures 40–120 mmHg; 0.2–0.8 mm thick;
/// the meshes an advancing front makes, jittered but not squeezed flat.
/// With `--h-min 0.25 --h-max 2`.
pub const PLAUSIBLE: Ranges = Ranges {
    pressure_mmhg: (40.0, 120.0),
    young_mpa: (0.3, 10.0),
    thickness_mm: (0.2, 0.8),
    squeeze: false,
};

/// The case `index` of the run `seed`; `h_range` bounds the mesh (mm),
/// `ranges` the physics. The draws are the same in number and order for
/// any ranges, so a seed's hostile cases keep their identity.
pub fn case(seed: u64, index: usize, h_range: (f64, f64), ranges: &Ranges) -> Case {
    let mut r = SplitMix64::new(seed ^ (index as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    // Burn one so neighbouring indices do not start from related states.
    r.next_u64();
    let (p, e, t) = (ranges.pressure_mmhg, ranges.young_mpa, ranges.thickness_mm);
    Case {
        index,
        h_mm: log_uniform(&mut r, h_range.0, h_range.1),
        model: MODELS[(r.next_u64() % MODELS.len() as u64) as usize],
        pressure_mmhg: r.range(p.0, p.1),
        young_mpa: log_uniform(&mut r, e.0, e.1),
        thickness_mm: r.range(t.0, t.1),
        bending: r.uniform() < 0.5,
        jitter: r.range(0.0, 0.3),
        squeezed: r.range(0.0, 0.05) * if ranges.squeeze { 1.0 } else { 0.0 },
        squeeze: r.range(0.9, 0.999),
        stream: r.next_u64(),
    }
}

fn config_text(c: &Case, time_limit_s: f64) -> String {
    let e = c.young_mpa;
    let material = match c.model {
        "svk" => format!("model = \"svk\"\nyoung = \"{e} MPa\"\npoisson = 0\n"),
        "neo-hookean" => format!("model = \"neo-hookean\"\nyoung = \"{e} MPa\"\n"),
        "goh" => format!(
            "model = \"goh\"\nyoung = \"{e} MPa\"\nk1 = \"{} MPa\"\nk2 = 1000\nkappa = 0.2\n",
            1.1 * e / 2.7
        ),
        _ => format!("model = \"msm\"\nmsm_law = \"linear\"\nyoung = \"{e} MPa\"\n"),
    };
    format!(
        "{material}thickness = \"{} mm\"\npressure = \"{} mmHg\"\ncontact = \"planes\"\nsolver = \"newton\"\ntime_limit = \"{time_limit_s} s\"\nbending = {}\n",
        c.thickness_mm, c.pressure_mmhg, c.bending
    )
}

/// How a case ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    Converged,
    /// Stopped with a diagnosis (solver reason or refused input).
    Failed(String),
    /// A position or the residual is not finite: a bug.
    NonFinite(String),
    /// Still working long past its time limit: a bug.
    Hang,
}

impl Verdict {
    pub fn name(&self) -> &'static str {
        match self {
            Verdict::Converged => "converged",
            Verdict::Failed(_) => "failed",
            Verdict::NonFinite(_) => "non-finite",
            Verdict::Hang => "hang",
        }
    }
}

#[derive(Debug, Clone)]
pub struct Run {
    pub case: Case,
    pub nodes: usize,
    pub verdict: Verdict,
    pub iterations: usize,
    pub residual_n: f64,
    pub wall_s: f64,
}

/// Jitter the free nodes, then squeeze some triangles: move a free vertex
/// toward the opposite edge so its height shrinks to (1 − squeeze).
fn perturb(c: &Case, x: &mut [V3], tris: &[[u32; 3]], boundary: &[u8]) {
    let mut r = SplitMix64::new(c.stream);
    let free = |i: usize| boundary[i] != 1;
    for (i, p) in x.iter_mut().enumerate() {
        // Draw for every node so the stream does not depend on the labels.
        let v = V3::new(r.normal(), r.normal(), r.normal());
        let len = c.jitter * c.h_mm * r.uniform().cbrt();
        if free(i) && v.norm() > 0.0 {
            *p += v.normalize() * len;
        }
    }
    let n = (c.squeezed * tris.len() as f64).round() as usize;
    for _ in 0..n {
        let t = tris[(r.next_u64() % tris.len() as u64) as usize];
        let k = (r.next_u64() % 3) as usize;
        let (a, b, q) = (
            t[k] as usize,
            t[(k + 1) % 3] as usize,
            t[(k + 2) % 3] as usize,
        );
        if !free(a) {
            continue;
        }
        let foot = {
            let e = x[q] - x[b];
            let s = if e.norm_squared() > 0.0 {
                ((x[a] - x[b]).dot(&e) / e.norm_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            x[b] + e * s
        };
        x[a] += (foot - x[a]) * c.squeeze;
    }
}

/// The case's leaflet, perturbed, its axis and its settings: what
/// [`run_case`] closes, and what the pressure ladder
/// ([`super::limit_load`]) closes again at lower pressures.
pub(crate) fn prepare(
    c: &Case,
    time_limit_s: f64,
) -> std::result::Result<(model::Leaflets, model::Axis, config::CloseConfig), String> {
    let cfg = config::parse(&config_text(c, time_limit_s))
        .map_err(|e| format!("settings refused: {e}"))?;
    let (mut l, axis) = ozaki_cylinder(c.h_mm).map_err(|e| format!("mesh refused: {e}"))?;
    perturb(c, &mut l.x, &l.tris, &l.boundary);
    if c.model == "goh" {
        l.fibers = circumferential_fibres(&l);
    }
    Ok((l, axis, cfg))
}

/// Run one case; `time_limit_s` is the solver's own limit, and a case still
/// running at twice that plus 10 s counts as a hang.
pub fn run_case(c: &Case, time_limit_s: f64) -> Run {
    let t0 = Instant::now();
    let finish = |verdict, nodes, iterations, residual_n| Run {
        case: c.clone(),
        nodes,
        verdict,
        iterations,
        residual_n,
        wall_s: t0.elapsed().as_secs_f64(),
    };
    let (l, axis, cfg) = match prepare(c, time_limit_s) {
        Ok(v) => v,
        Err(e) => return finish(Verdict::Failed(e), 0, 0, f64::NAN),
    };
    let nodes = l.x.len();
    let res = closure::close(&l, &cfg, Some(axis));
    let mut r = match res {
        Ok(closed) => {
            let o = &closed.outcome;
            let bad = closed
                .x
                .iter()
                .position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()));
            let verdict = match bad {
                Some(i) => Verdict::NonFinite(format!("node {i} position")),
                None if o.converged && !o.residual_n.is_finite() => {
                    Verdict::NonFinite("residual".into())
                }
                None if o.converged => Verdict::Converged,
                // An empty reason stays empty: `unexplained` reports it.
                None => Verdict::Failed(o.reason.clone()),
            };
            finish(verdict, nodes, o.iterations, o.residual_n)
        }
        Err(e) => finish(Verdict::Failed(e), nodes, 0, f64::NAN),
    };
    if r.wall_s > 2.0 * time_limit_s + 10.0 {
        r.verdict = Verdict::Hang;
    }
    r
}

/// The first words of a diagnosis, so similar failures count together.
fn kind(reason: &str) -> String {
    let words: Vec<&str> = reason
        .split(|c: char| c.is_whitespace() || c == ':' || c == '(' || c == ',')
        .filter(|w| !w.is_empty() && !w.chars().any(|c| c.is_ascii_digit()))
        .take(6)
        .collect();
    if words.is_empty() {
        "(no diagnosis)".into()
    } else {
        words.join(" ")
    }
}

pub struct Summary {
    pub results: Vec<Run>,
}

impl Summary {
    pub fn count(&self, name: &str) -> usize {
        self.results
            .iter()
            .filter(|r| r.verdict.name() == name)
            .count()
    }

    /// Failures without a diagnosis, non-finite results and hangs: the
    /// things the target says must not happen.
    pub fn unexplained(&self) -> Vec<&Run> {
        self.results
            .iter()
            .filter(|r| match &r.verdict {
                Verdict::Converged => false,
                Verdict::Failed(why) => why.trim().is_empty(),
                _ => true,
            })
            .collect()
    }

    pub fn table(&self) -> String {
        let n = self.results.len();
        let mut t = format!(
            "{n} cases: {} converged, {} failed with a diagnosis, {} non-finite, {} hang\n",
            self.count("converged"),
            self.results
                .iter()
                .filter(|r| matches!(&r.verdict, Verdict::Failed(w) if !w.trim().is_empty()))
                .count(),
            self.count("non-finite"),
            self.count("hang"),
        );
        let mut kinds: BTreeMap<String, (usize, usize)> = BTreeMap::new();
        for r in &self.results {
            if let Verdict::Failed(why) = &r.verdict {
                let e = kinds.entry(kind(why)).or_insert((0, r.case.index));
                e.0 += 1;
            }
        }
        if !kinds.is_empty() {
            t.push_str("failures by diagnosis (count, first case):\n");
            for (k, (count, first)) in &kinds {
                t.push_str(&format!("  {count:>4}  {k}  (case {first})\n"));
            }
        }
        for r in self.unexplained() {
            t.push_str(&format!(
                "  UNEXPLAINED case {}: {:?}\n",
                r.case.index, r.verdict
            ));
        }
        t
    }

    pub fn csv(&self) -> String {
        let mut s = String::from(
            "index,h_mm,nodes,model,pressure_mmhg,young_mpa,thickness_mm,bending,jitter,squeezed,squeeze,verdict,iterations,residual_n,wall_s,reason\n",
        );
        for r in &self.results {
            let c = &r.case;
            let why = match &r.verdict {
                Verdict::Failed(w) | Verdict::NonFinite(w) => w.replace('"', "'"),
                _ => String::new(),
            };
            s.push_str(&format!(
                "{},{:.4},{},{},{:.2},{:.5},{:.3},{},{:.3},{:.4},{:.4},{},{},{:.3e},{:.3},\"{why}\"\n",
                c.index,
                c.h_mm,
                r.nodes,
                c.model,
                c.pressure_mmhg,
                c.young_mpa,
                c.thickness_mm,
                c.bending,
                c.jitter,
                c.squeezed,
                c.squeeze,
                r.verdict.name(),
                r.iterations,
                r.residual_n,
                r.wall_s
            ));
        }
        s
    }
}

/// Run the cases `indices` of `seed` (in parallel; each case is
/// independent, so one can be replayed alone). `on_done` sees each case as
/// it finishes (in finishing order), so a long run that is stopped part-way
/// has still told its count.
pub fn run(
    seed: u64,
    indices: &[usize],
    h_range: (f64, f64),
    ranges: &Ranges,
    time_limit_s: f64,
    on_done: &(dyn Fn(&Run) + Sync),
) -> Result<Summary> {
    if !(h_range.0 > 0.0 && h_range.0 <= h_range.1 && h_range.1.is_finite()) {
        return Err(Error::usage(format!(
            "mesh range {} – {} mm: must be positive and ordered",
            h_range.0, h_range.1
        )));
    }
    let results = indices
        .par_iter()
        .map(|&i| {
            let r = run_case(&case(seed, i, h_range, ranges), time_limit_s);
            on_done(&r);
            r
        })
        .collect();
    Ok(Summary { results })
}

/// `coapt bench stress-close`: the cases, a running tally on stderr (unless
/// `quiet`), the table on stdout; exit 1 when a case ends without a
/// diagnosis.
pub fn dispatch(b: &clap::ArgMatches, quiet: bool) -> Result<()> {
    let limit = *b.get_one::<f64>("time-limit").expect("has default");
    if !(limit > 0.0 && limit.is_finite()) {
        return Err(Error::usage(
            "--time-limit must be a positive number of seconds",
        ));
    }
    let indices: Vec<usize> = match b.get_many::<usize>("only") {
        Some(v) => v.copied().collect(),
        None => (0..*b.get_one::<usize>("cases").expect("has default")).collect(),
    };
    let cases = indices.len();
    // Running counts on stderr as cases finish: a run stopped
    // part-way (a cluster's wall limit) still reports its count.
    let tally = std::sync::Mutex::new([0usize; 4]);
    let progress = |r: &Run| {
        let mut t = tally.lock().unwrap_or_else(|p| p.into_inner());
        t[match r.verdict.name() {
            "converged" => 0,
            "failed" => 1,
            "non-finite" => 2,
            _ => 3,
        }] += 1;
        if quiet {
            return;
        }
        eprintln!(
            "case {:>4} {:<10} {:>4} its {:>8.2} s | {}/{cases} done: {} converged, {} failed, {} non-finite, {} hang",
            r.case.index,
            r.verdict.name(),
            r.iterations,
            r.wall_s,
            t.iter().sum::<usize>(),
            t[0],
            t[1],
            t[2],
            t[3],
        );
    };
    let s = run(
        *b.get_one::<u64>("seed").expect("has default"),
        &indices,
        (
            *b.get_one::<f64>("h-min").expect("has default"),
            *b.get_one::<f64>("h-max").expect("has default"),
        ),
        if b.get_flag("plausible") {
            &PLAUSIBLE
        } else {
            &HOSTILE
        },
        limit,
        &progress,
    )?;
    if let Some(path) = b.get_one::<PathBuf>("csv") {
        coapt_io::write_atomic(path, |w| std::io::Write::write_all(w, s.csv().as_bytes()))?;
    }
    print!("{}", s.table());
    if b.get_flag("explain") {
        let failed: Vec<Case> = s
            .results
            .iter()
            .filter(|r| matches!(r.verdict, Verdict::Failed(_)))
            .map(|r| r.case.clone())
            .collect();
        let ladders = super::limit_load::explain(&failed, limit);
        print!(
            "{}",
            super::limit_load::table(&ladders, s.count("converged"), s.results.len())
        );
    }
    if s.unexplained().is_empty() {
        Ok(())
    } else {
        Err(Error::failed(
            "bench stress-close",
            format!(
                "{} case(s) ended without a diagnosis, with non-finite numbers or past their time limit",
                s.unexplained().len()
            ),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cases_are_reproducible_and_span_the_ranges() {
        assert_eq!(
            case(7, 3, (0.25, 3.0), &HOSTILE),
            case(7, 3, (0.25, 3.0), &HOSTILE)
        );
        assert_ne!(
            case(7, 3, (0.25, 3.0), &HOSTILE),
            case(7, 4, (0.25, 3.0), &HOSTILE)
        );
        let cs: Vec<Case> = (0..500)
            .map(|i| case(1, i, (0.25, 3.0), &HOSTILE))
            .collect();
        let span = |f: fn(&Case) -> f64| {
            let v: Vec<f64> = cs.iter().map(f).collect();
            (
                v.iter().copied().fold(f64::INFINITY, f64::min),
                v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        };
        let (lo, hi) = span(|c| c.h_mm);
        assert!(lo >= 0.25 && lo < 0.3 && hi <= 3.0 && hi > 2.5, "{lo} {hi}");
        let (lo, hi) = span(|c| c.pressure_mmhg);
        assert!(lo >= 5.0 && lo < 10.0 && hi < 200.0 && hi > 190.0);
        let (lo, hi) = span(|c| c.young_mpa);
        assert!(lo >= 0.01 && lo < 0.02 && hi <= 100.0 && hi > 50.0);
        for m in MODELS {
            assert!(cs.iter().filter(|c| c.model == m).count() > 80, "{m}");
        }
    }

    /// The plausible cases are the hostile ones' draws mapped into the
    /// plausible ranges: same laws, meshes and bending per index, physics
    /// within range, nothing squeezed.
    #[test]
    fn plausible_cases_stay_in_range_and_keep_their_draws() {
        for i in 0..300 {
            let (h, p) = (
                case(1, i, (0.25, 2.0), &HOSTILE),
                case(1, i, (0.25, 2.0), &PLAUSIBLE),
            );
            assert_eq!(
                (h.h_mm, h.model, h.bending, h.jitter, h.stream),
                (p.h_mm, p.model, p.bending, p.jitter, p.stream)
            );
            assert!((40.0..=120.0).contains(&p.pressure_mmhg), "{p:?}");
            assert!((0.3..=10.0).contains(&p.young_mpa), "{p:?}");
            assert!((0.2..=0.8).contains(&p.thickness_mm), "{p:?}");
            assert_eq!(p.squeezed, 0.0);
        }
    }

    /// Plausible case 95 of seed 3 (GOH without bending, h 0.50 mm,
    /// 82.8 mmHg, 1.05 MPa, 0.40 mm) fails at its full load applied at once
    /// (1500 iterations): the load steps reach the equilibrium, and say so
    /// (1959 iterations in all). Which wandering membrane they rescue is
    /// chaotic: seed 1's case 42 was this test's case until the suturing
    /// rounds were loosened and moved its sutured state by about 1e-7 mm,
    /// then seed 2's case 81 until the contact patterns were kept across
    /// steps and ordered by node (which closes it at once); in 300
    /// plausible cases this is the one.
    #[test]
    fn a_closure_that_fails_at_once_converges_by_load_steps() {
        let r = run_case(&case(3, 95, (0.25, 2.0), &PLAUSIBLE), 600.0);
        match &r.verdict {
            Verdict::Converged => {}
            v => panic!("{v:?}"),
        }
        assert!(r.iterations > 1500, "{}", r.iterations);
        assert!(r.residual_n <= 1e-7, "{}", r.residual_n);
    }

    #[test]
    fn squeezing_makes_nearly_flat_triangles_and_keeps_sutures() {
        let mut c = case(3, 0, (1.0, 1.0), &HOSTILE);
        c.squeezed = 0.05;
        c.squeeze = 0.999;
        c.jitter = 0.3;
        let (l, _) = ozaki_cylinder(c.h_mm).unwrap();
        let mut x = l.x.clone();
        perturb(&c, &mut x, &l.tris, &l.boundary);
        for (i, (a, b)) in l.x.iter().zip(&x).enumerate() {
            if l.boundary[i] == 1 {
                assert_eq!(a, b, "sutured node {i} moved");
            }
        }
        let quality = |p: &[V3], t: &[u32; 3]| {
            let (a, b, c) = (p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
            let area2 = (b - a).cross(&(c - a)).norm();
            let l2 = (b - a)
                .norm_squared()
                .max((c - b).norm_squared())
                .max((a - c).norm_squared());
            area2 / l2
        };
        let worst = l
            .tris
            .iter()
            .map(|t| quality(&x, t))
            .fold(f64::INFINITY, f64::min);
        let before = l
            .tris
            .iter()
            .map(|t| quality(&l.x, t))
            .fold(f64::INFINITY, f64::min);
        assert!(worst < 0.01 * before, "worst {worst} vs {before}");
    }

    /// A handful of hostile cases on coarse meshes: each converges or says
    /// why not; none gives NaN or runs past its limit.
    #[test]
    fn hostile_cases_end_converged_or_explained() {
        let seen = std::sync::Mutex::new(Vec::new());
        let all: Vec<usize> = (0..8).collect();
        let s = run(11, &all, (1.0, 3.0), &HOSTILE, 20.0, &|r| {
            seen.lock().unwrap().push(r.case.index)
        })
        .unwrap();
        assert_eq!(s.results.len(), 8);
        // Every case was reported once as it finished.
        let mut seen = seen.into_inner().unwrap();
        seen.sort();
        assert_eq!(seen, all);
        // A case replayed alone ends as it did among the others.
        let again = run(11, &[5], (1.0, 3.0), &HOSTILE, 20.0, &|_| {}).unwrap();
        let (a, b) = (&again.results[0], &s.results[5]);
        assert_eq!(a.case, b.case);
        assert_eq!(a.verdict, b.verdict);
        assert_eq!(
            (a.iterations, a.residual_n.to_bits()),
            (b.iterations, b.residual_n.to_bits())
        );
        assert!(s.unexplained().is_empty(), "{}", s.table());
        assert!(s.count("converged") >= 1, "{}", s.table());
    }
}
