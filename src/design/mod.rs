//! `coapt design CONFIG`: leaflet sizing for one patient.
//!
//! The patient's chain runs once up to the suture paths (segmentation,
//! surface, valve frame and paths are shared by every size, as the issue and
//! the operation demand: the surgeon sizes leaflets for one root). Then
//! every Ozaki sizer size of the sweep closes in its own run directory
//! (`RUN/design/size-NN/`, leaflets → close → report), in parallel, and the
//! smallest size that meets every criterion is recommended ([`recommend`]).
//! The design report (`RUN/design/report.html`) is the report of the
//! recommended size's valve with the sweep's table and charts.
//!
//! Sizes are independent runs, so the answer does not depend on the thread
//! count, and a second `coapt design` skips every size whose inputs hold.

pub mod document;
pub mod ozaki_rule;
pub mod recommend;
pub mod settings;
pub mod sweep;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;

pub use recommend::{Outcome, Recommendation};
pub use settings::Settings;

use crate::io::write_atomic;
use crate::pipeline::config::RunConfig;
use crate::pipeline::execute::Invocation;
use crate::pipeline::progress::Progress;
use crate::pipeline::runner::{self, RunOptions};
use crate::pipeline::{Params, StageIo, StageSpec};
use crate::{Error, Result};

#[derive(Debug, Clone, Default)]
pub struct Options {
    pub config: PathBuf,
    /// Run directory; overrides the config's `[run] dir`.
    pub out: Option<PathBuf>,
    /// Overrides the config's `[design] sizes`.
    pub sizes: Option<Vec<u32>>,
    pub force: bool,
}

/// What a sweep found.
#[derive(Debug, Clone)]
pub struct Summary {
    pub design_dir: PathBuf,
    pub outcomes: Vec<Outcome>,
    pub recommendation: Recommendation,
    /// Ozaki's rule for the root, when its valve frame could be read.
    pub ozaki_rule: Option<ozaki_rule::OzakiRule>,
    /// The valve closed as Ozaki's rule cuts it, when it could be cut.
    pub rule_outcome: Option<RuleOutcome>,
}

/// The closure of Ozaki's rule: its run directory (its own, or the sweep's
/// size when the rule cuts that size for all three) and what it gave.
#[derive(Debug, Clone)]
pub struct RuleOutcome {
    pub run: String,
    pub result: std::result::Result<recommend::Measured, String>,
}

/// Inputs the sizes take from the patient's run but do not need: the CT
/// and mask only feed the CT figure, drawn once on the design report.
const FIGURE_ONLY: [&str; 2] = ["ct", "mask"];

pub fn run(opts: &Options, registry: &[&'static StageSpec], inv: &Invocation) -> Result<Summary> {
    let cfg = RunConfig::load(&opts.config, registry)?;
    let run_dir = match (&opts.out, &cfg.run_dir) {
        (Some(d), _) | (None, Some(d)) => d.clone(),
        (None, None) => {
            return Err(Error::usage(format!(
                "{}: no run directory: set [run] dir in the config or pass --out DIR",
                opts.config.display()
            )));
        }
    };
    let sizes = match (&opts.sizes, &cfg.design) {
        (Some(s), _) => s.clone(),
        (None, Some(d)) => Settings::from_toml(&cfg.path, d)?.sizes,
        (None, None) => Settings::default().sizes,
    };
    let chain = runner::plan(&cfg, registry)?;
    let names: Vec<&str> = chain.iter().map(|s| s.name).collect();
    let Some(first) = names.iter().position(|n| *n == sweep::STAGES[0]) else {
        return Err(Error::config(
            &cfg.path,
            "inputs",
            format!(
                "coapt design sizes the leaflets, so the chain must reach leaflets, close and report (give template and config under [inputs]); this config's chain is: {}",
                names.join(" → ")
            ),
        ));
    };
    if let Some(missing) = sweep::STAGES.iter().find(|s| !names.contains(s)) {
        return Err(Error::config(
            &cfg.path,
            "inputs",
            format!(
                "coapt design needs the {missing} stage in the chain (its inputs are missing); the chain is: {}",
                names.join(" → ")
            ),
        ));
    }
    if first > 0 {
        runner::run(
            &RunOptions {
                config: opts.config.clone(),
                out: Some(run_dir.clone()),
                from: None,
                until: Some(chain[first - 1].name.to_string()),
                force: opts.force,
            },
            registry,
            inv,
        )?;
    }

    // Everything the sizes' stages take and do not make themselves.
    let made_by_sizes: Vec<&str> = chain[first..]
        .iter()
        .flat_map(|s| s.outputs.iter().map(|p| p.name))
        .collect();
    let mut upstream: BTreeMap<String, PathBuf> = BTreeMap::new();
    for port in chain[first..].iter().flat_map(|s| s.inputs.iter()) {
        if port.name == "template" || made_by_sizes.contains(&port.name) {
            continue;
        }
        // An input given in part was completed upstream: the sizes read
        // the completed artifact.
        let given = cfg
            .inputs
            .get(port.name)
            .filter(|_| !cfg.completed.contains(port.name));
        let path = match given {
            Some(p) => p.clone(),
            None => match chain[..first].iter().find_map(|s| s.output(port.name)) {
                Some(out) => run_dir.join(out.file),
                None => continue,
            },
        };
        let abs = std::fs::canonicalize(&path).map_err(|e| Error::read(&path, e))?;
        upstream.insert(port.name.to_string(), abs);
    }
    let for_sizes: BTreeMap<String, PathBuf> = upstream
        .iter()
        .filter(|(k, _)| !FIGURE_ONLY.contains(&k.as_str()))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();

    let design_dir = run_dir.join("design");
    std::fs::create_dir_all(&design_dir).map_err(|e| Error::write(&design_dir, e))?;
    let frame = upstream
        .get("valve")
        .and_then(|p| crate::io::valve_json::read_frame(p).ok());
    let rule = frame
        .as_ref()
        .map(|f| ozaki_rule::OzakiRule::of(f.intercommissural_mm()));
    // Ozaki's rule is closed too, unless it is a size of the sweep already
    // (one size for all three) or a distance lies beyond the sizer.
    let rule_sizes: Option<Vec<u32>> = rule
        .as_ref()
        .and_then(|r| r.sizes.iter().copied().collect());
    let rule_in_sweep = rule_sizes
        .as_ref()
        .filter(|s| s.iter().all(|&x| x == s[0]) && sizes.contains(&s[0]))
        .map(|s| s[0]);
    let mut cuts: Vec<sweep::Cut> = sizes.iter().map(|&s| sweep::Cut::Size(s)).collect();
    if rule_sizes.is_some() && rule_in_sweep.is_none() {
        cuts.push(sweep::Cut::Rule);
    }

    let mut sub = inv.clone();
    sub.log.quiet = true; // no progress bars racing each other
    tracing::info!(event = "design", sizes = ?sizes, "design: closing {} sizes ({}){}", sizes.len(), sizes.iter().map(u32::to_string).collect::<Vec<_>>().join(", "), if cuts.len() > sizes.len() { " and Ozaki's rule" } else { "" });
    // One bar for the sweep (the sizes' own are silenced), with the time
    // left estimated from the closures done, and a line as each ends.
    let bar = Progress::new("design", inv.log);
    let done = AtomicUsize::new(0);
    let results = cuts
        .par_iter()
        .map(|&cut| {
            let _span = tracing::info_span!("size", message = %cut.name()).entered();
            let t0 = Instant::now();
            let text = sweep::config(cut, &for_sizes, &cfg.sections);
            let result = sweep::run_cut(cut, &design_dir, &text, registry, &sub, opts.force)?;
            let k = done.fetch_add(1, Ordering::Relaxed) + 1;
            bar.suspend(|| {
                tracing::info!(
                    event = "size_done",
                    run = %cut.dir(),
                    done = k,
                    of = cuts.len(),
                    "{} ({:.1} s; {k} of {} closures done)",
                    recommend::fails(&result),
                    t0.elapsed().as_secs_f64(),
                    cuts.len()
                )
            });
            bar.set(k as f64 / cuts.len() as f64);
            Ok((cut, result))
        })
        .collect::<Result<Vec<_>>>()?;
    bar.finish();
    let mut outcomes = Vec::new();
    let mut rule_outcome = None;
    for (cut, result) in results {
        match cut {
            sweep::Cut::Size(size) => outcomes.push(Outcome { size, result }),
            sweep::Cut::Rule => {
                rule_outcome = Some(RuleOutcome {
                    run: sweep::RULE_DIR.to_string(),
                    result,
                })
            }
        }
    }
    if let Some(size) = rule_in_sweep {
        rule_outcome = outcomes
            .iter()
            .find(|o| o.size == size)
            .map(|o| RuleOutcome {
                run: sweep::size_dir(size),
                result: o.result.clone(),
            });
    }
    let rec = recommend::recommend(&outcomes);

    let doc = document::build(
        &outcomes,
        &rec,
        rule.as_ref(),
        rule_outcome.as_ref(),
        &cfg.sections,
    );
    let design_json = design_dir.join("design.json");
    let text = doc.to_text();
    write_atomic(&design_json, |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })?;

    let Some(shown) = rec.shown else {
        return Err(Error::failed("design", rec.reason.clone()));
    };
    report(
        registry,
        &cfg,
        &design_dir,
        shown,
        &upstream,
        &design_json,
        inv,
    )?;
    Ok(Summary {
        design_dir,
        outcomes,
        recommendation: rec,
        ozaki_rule: rule,
        rule_outcome,
    })
}

/// The design report: the report stage on the shown size's valve, with the
/// sweep (`design.json`) as an extra input, written into the design directory.
fn report(
    registry: &[&'static StageSpec],
    cfg: &RunConfig,
    design_dir: &Path,
    size: u32,
    upstream: &BTreeMap<String, PathBuf>,
    design_json: &Path,
    inv: &Invocation,
) -> Result<()> {
    let spec = registry
        .iter()
        .copied()
        .find(|s| s.name == "report")
        .expect("the report stage is registered");
    let size_dir = design_dir.join(sweep::size_dir(size));
    let mut io = StageIo::default();
    for port in spec.inputs {
        let path = if port.name == "design" {
            Some(design_json.to_path_buf())
        } else if let Some(p) = upstream.get(port.name) {
            Some(p.clone())
        } else {
            Some(size_dir.join(port.file)).filter(|p| p.is_file())
        };
        if let Some(p) = path {
            io.inputs.push((port.name, p));
        }
    }
    for port in spec.outputs {
        io.outputs.push((port.name, design_dir.join(port.file)));
    }
    let mut given = cfg.sections.get("report").cloned().unwrap_or_default();
    given.insert(
        "run_dir".into(),
        crate::pipeline::Value::Path(size_dir.to_string_lossy().into_owned()),
    );
    let params = Params::resolve(spec, given)?;
    runner::run_single(spec, &io, &params, Some(design_dir), inv)
}

/// The sweep as a text table for the terminal.
pub fn table(s: &Summary) -> String {
    let f = |x: Option<f64>, d: usize| x.map_or("—".to_string(), |v| format!("{v:.d$}"));
    let mut t = String::from(
        "size  leaflet area  coaptation  central  effective  criteria\n\
         \x20       (mm²)      height (mm)  (mm)    height (mm)\n",
    );
    for o in &s.outcomes {
        match &o.result {
            Ok(m) => t.push_str(&format!(
                "{:>4}  {:>12}  {:>10}  {:>7}  {:>10}  {}/{}{}{}\n",
                o.size,
                f(m.leaflet_area_mm2, 0),
                f(m.coaptation_height_mm, 2),
                f(m.central_coaptation_height_mm, 2),
                f(m.effective_height_mm, 2),
                m.passed,
                m.judged,
                if m.assessable { "" } else { ", not assessable" },
                if s.recommendation.size == Some(o.size) {
                    "  ← recommended"
                } else {
                    ""
                }
            )),
            Err(e) => t.push_str(&format!("{:>4}  not computed: {e}\n", o.size)),
        }
    }
    t.push_str(&s.recommendation.reason);
    t.push('\n');
    if let Some(rule) = &s.ozaki_rule {
        t.push_str(&rule.sentence(s.recommendation.size));
        t.push('\n');
    }
    if let Some(r) = &s.rule_outcome {
        let numbers = match &r.result {
            Ok(m) => {
                let mm = |x: Option<f64>| x.map_or("none".to_string(), |v| format!("{v:.2} mm"));
                format!(
                    ": central coaptation {}, effective height {}, {}/{} criteria",
                    mm(m.central_coaptation_height_mm),
                    mm(m.effective_height_mm),
                    m.passed,
                    m.judged
                )
            }
            Err(_) => String::new(),
        };
        t.push_str(&format!(
            "Closed as Ozaki's rule cuts it ({}/){numbers}; {}.\n",
            r.run,
            recommend::fails(&r.result)
        ));
    }
    t
}
