//! `coapt run`: carry out the chain a run config describes, in a run
//! directory, skipping every stage whose record still holds.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::config::RunConfig;
use super::execute::{self, Invocation};
use super::manifest::{FileRecord, Manifest, Status};
use super::params::Params;
use super::spec::{StageIo, StageSpec};
use super::validate;
use coapt_base::{Error, Result};

#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    pub config: PathBuf,
    /// Run directory; overrides the config's `[run] dir`.
    pub out: Option<PathBuf>,
    pub from: Option<String>,
    pub until: Option<String>,
    pub force: bool,
}

/// What happened to each stage of the chain.
#[derive(Debug, Clone)]
pub struct RunReport {
    pub run_dir: PathBuf,
    pub stages: Vec<(String, Status, String)>,
    /// Stages the config could not reach, with the inputs no stage makes
    /// that it would need (a config without landmarks stops after the
    /// surface; this says why).
    pub left_out: Vec<(String, Vec<String>)>,
}

/// The stages the planned chain leaves out for want of an input that only
/// the config can give (not made by any stage that runs on its inputs, a
/// source such as `phantom` runs only when configured), with those inputs.
fn left_out(
    cfg: &RunConfig,
    registry: &[&'static StageSpec],
    chain: &[&'static StageSpec],
) -> Vec<(String, Vec<String>)> {
    let available = |name: &str| {
        cfg.inputs.contains_key(name) || chain.iter().any(|s| s.output(name).is_some())
    };
    let made_downstream = |name: &str| {
        registry
            .iter()
            .any(|s| !s.is_source() && s.output(name).is_some())
    };
    registry
        .iter()
        .filter(|s| !s.is_source() && !chain.iter().any(|c| c.name == s.name))
        // A stage whose output the config gives is replaced, not missing.
        .filter(|s| !s.outputs.iter().any(|o| cfg.inputs.contains_key(o.name)))
        .filter_map(|s| {
            let missing: Vec<String> = s
                .inputs
                .iter()
                .filter(|p| p.required && !available(p.name) && !made_downstream(p.name))
                .map(|p| p.name.to_string())
                .collect();
            (!missing.is_empty()).then(|| (s.name.to_string(), missing))
        })
        .collect()
}

/// The stages a config asks for, in chain order: a source stage (no inputs)
/// runs when its section is present; any other stage runs when all its
/// required inputs are available from `[inputs]` or an earlier stage.
pub fn plan(cfg: &RunConfig, registry: &[&'static StageSpec]) -> Result<Vec<&'static StageSpec>> {
    let mut available: Vec<&str> = cfg.inputs.keys().map(String::as_str).collect();
    let mut chain = Vec::new();
    for &spec in registry {
        let configured = cfg.has_section(spec.name);
        if spec.is_source() && !configured {
            continue;
        }
        let missing: Vec<&str> = spec
            .inputs
            .iter()
            .filter(|p| p.required && !available.contains(&p.name))
            .map(|p| p.name)
            .collect();
        if !missing.is_empty() {
            if configured {
                return Err(Error::config(
                    &cfg.path,
                    format!("[{}]", spec.name),
                    format!(
                        "stage {} needs {} — give it under [inputs] or configure a stage that makes it",
                        spec.name,
                        missing.join(", ")
                    ),
                ));
            }
            continue;
        }
        // A stage the config does not name is left out when the config
        // already gives what it would make (e.g. a mask segmented elsewhere),
        // or an earlier stage makes it (the phantom's true landmarks are not
        // detected again).
        let completes = spec.outputs.iter().any(|o| cfg.completed.contains(o.name));
        if !configured
            && !completes
            && spec
                .outputs
                .iter()
                .any(|o| cfg.inputs.contains_key(o.name) || available.contains(&o.name))
        {
            continue;
        }
        for out in spec.outputs {
            if cfg.inputs.contains_key(out.name) && !cfg.completed.contains(out.name) {
                return Err(Error::config(
                    &cfg.path,
                    format!("inputs.{}", out.name),
                    format!(
                        "{} is made by stage {}; remove it from [inputs] or remove [{}]",
                        out.name, spec.name, spec.name
                    ),
                ));
            }
            available.push(out.name);
        }
        chain.push(spec);
    }
    if chain.is_empty() && cfg.inputs.is_empty() {
        let names: Vec<&str> = registry.iter().map(|s| s.name).collect();
        return Err(Error::config(
            &cfg.path,
            "stages",
            format!(
                "nothing to run: no stage of this coapt ({}) has its inputs or a section in this config",
                names.join(", ")
            ),
        ));
    }
    Ok(chain)
}

/// The kind an external input is judged as: the artifact's own (the kind
/// of the stage output of that name, when one makes it), or, for an input
/// given in part, what the completing stage's `given_X` takes.
fn input_kind(
    registry: &[&'static StageSpec],
    cfg: &RunConfig,
    name: &str,
) -> Option<super::spec::ArtifactKind> {
    let port = |name: &str, ports: fn(&StageSpec) -> &[super::spec::Port]| {
        registry
            .iter()
            .flat_map(|s| ports(s).iter())
            .find(|p| p.name == name)
            .map(|p| p.kind)
    };
    if cfg.completed.contains(name) {
        return port(&format!("given_{name}"), |s| s.inputs);
    }
    port(name, |s| s.outputs).or_else(|| port(name, |s| s.inputs))
}

fn position(chain: &[&StageSpec], name: &str, flag: &str) -> Result<usize> {
    chain.iter().position(|s| s.name == name).ok_or_else(|| {
        let names: Vec<&str> = chain.iter().map(|s| s.name).collect();
        Error::usage(format!(
            "{flag} {name}: not a stage of this run (the chain is: {})",
            names.join(" → ")
        ))
    })
}

/// Run the chain.
pub fn run(
    opts: &RunOptions,
    registry: &[&'static StageSpec],
    inv: &Invocation,
) -> Result<RunReport> {
    let cfg = RunConfig::load(&opts.config, registry)?;
    if let Some(pick) = &cfg.series {
        coapt_io::volume_file::set_series(pick).map_err(|first| {
            Error::config(
                &cfg.path,
                "run.series",
                format!("is {pick}, but --series chose {first}; give one of them"),
            )
        })?;
    }
    let run_dir = match (&opts.out, &cfg.run_dir) {
        (Some(d), _) => d.clone(),
        (None, Some(d)) => d.clone(),
        (None, None) => {
            return Err(Error::usage(format!(
                "{}: no run directory: set [run] dir in the config or pass --out DIR",
                opts.config.display()
            )));
        }
    };
    let chain = plan(&cfg, registry)?;
    if chain.is_empty() {
        // Inputs only: check them, which is all this build can do with them.
        for (name, path) in &cfg.inputs {
            if let Some(kind) = input_kind(registry, &cfg, name) {
                validate::input(kind, path)?;
            }
        }
        let names: Vec<&str> = registry.iter().map(|s| s.name).collect();
        tracing::warn!(
            event = "nothing_to_run",
            "{}: inputs are valid, but no stage of this coapt ({}) consumes them",
            opts.config.display(),
            names.join(", ")
        );
        return Ok(RunReport {
            run_dir,
            stages: Vec::new(),
            left_out: left_out(&cfg, registry, &chain),
        });
    }
    let first = match &opts.from {
        Some(s) => position(&chain, s, "--from")?,
        None => 0,
    };
    let last = match &opts.until {
        Some(s) => position(&chain, s, "--until")?,
        None => chain.len() - 1,
    };
    if first > last {
        return Err(Error::usage(format!(
            "--from {} comes after --until {}",
            chain[first].name, chain[last].name
        )));
    }

    // Where every artifact lives: external inputs where the config says,
    // everything a stage makes under its run-directory name.
    let mut artifact: BTreeMap<&str, PathBuf> = cfg
        .inputs
        .iter()
        .map(|(k, v)| (k.as_str(), v.clone()))
        .collect();
    for spec in &chain {
        for out in spec.outputs {
            artifact.insert(out.name, run_dir.join(out.file));
        }
    }

    // Fail fast on bad external inputs and on missing upstream artifacts,
    // before any stage spends time.
    for (name, path) in &cfg.inputs {
        if let Some(kind) = input_kind(registry, &cfg, name) {
            validate::input(kind, path)?;
        }
    }
    for (at, spec) in chain.iter().enumerate().take(last + 1).skip(first) {
        for port in spec.inputs {
            let Some(path) = wired(&artifact, &cfg, &chain, at, port.name) else {
                continue;
            };
            let made_upstream = chain[..first].iter().any(|s| s.output(port.name).is_some());
            if made_upstream && !path.exists() {
                return Err(Error::usage(format!(
                    "--from {}: {} should have been made by an earlier run in {}, but {} does not exist; run without --from first",
                    chain[first].name,
                    port.name,
                    run_dir.display(),
                    path.display()
                )));
            }
        }
    }

    // Every stage's parameters, judged before anything runs.
    let mut resolved = Vec::with_capacity(chain.len());
    for spec in &chain[first..=last] {
        let given = cfg.sections.get(spec.name).cloned().unwrap_or_default();
        let params = Params::resolve(spec, given)
            .and_then(|p| (spec.check)(&p).map(|_| p))
            .map_err(|e| Error::config(&cfg.path, spec.name, e.to_string()))?;
        resolved.push(params);
    }

    std::fs::create_dir_all(&run_dir).map_err(|e| Error::write(&run_dir, e))?;
    let mut manifest = Manifest::load(&run_dir)?;
    manifest.config = Some(FileRecord::of(&opts.config, &run_dir)?);
    let order: Vec<&str> = chain.iter().map(|s| s.name).collect();
    let mut report = RunReport {
        run_dir: run_dir.clone(),
        stages: Vec::new(),
        left_out: left_out(&cfg, registry, &chain),
    };

    for ((at, spec), params) in chain
        .iter()
        .enumerate()
        .take(last + 1)
        .skip(first)
        .zip(resolved)
    {
        let io = StageIo {
            inputs: spec
                .inputs
                .iter()
                .filter_map(|p| {
                    wired(&artifact, &cfg, &chain, at, p.name).map(|path| (p.name, path))
                })
                .collect(),
            outputs: spec
                .outputs
                .iter()
                .map(|p| (p.name, run_dir.join(p.file)))
                .collect(),
        };
        let inputs = execute::hash_inputs(&io, &run_dir)?;
        let previous = manifest.stage(spec.name).cloned();
        let reason = if opts.force {
            Some("--force".to_string())
        } else {
            execute::reason_to_run(previous.as_ref(), &inputs, &params, &io)
        };
        match reason {
            None => {
                let mut rec = previous.expect("a skip needs an earlier record");
                rec.status = Status::Skipped;
                rec.reason =
                    "inputs, parameters and coapt version unchanged; outputs intact".into();
                rec.checked = Some(super::provenance::now_utc());
                tracing::info!(stage = spec.name, event = "skipped", reason = %rec.reason, "{}: skipped ({})", spec.name, rec.reason);
                report
                    .stages
                    .push((spec.name.to_string(), Status::Skipped, rec.reason.clone()));
                manifest.put(rec, &order);
            }
            Some(reason) => {
                let rec =
                    execute::execute(spec, &io, &params, inputs, &run_dir, reason.clone(), inv)?;
                report
                    .stages
                    .push((spec.name.to_string(), Status::Ran, reason));
                manifest.put(rec, &order);
            }
        }
        manifest.save(&run_dir)?;
    }
    Ok(report)
}

/// Where the stage at `at` in `chain` reads its input `name`: a file the
/// config gives, or one an earlier stage writes. An artifact only a later
/// stage makes is not an input (segment's optional landmarks are not the
/// ones the landmarks stage detects from segment's own mask).
fn wired(
    artifact: &BTreeMap<&str, PathBuf>,
    cfg: &RunConfig,
    chain: &[&'static StageSpec],
    at: usize,
    name: &str,
) -> Option<PathBuf> {
    let made_later = chain[at..].iter().any(|s| s.output(name).is_some());
    let made_earlier = chain[..at].iter().any(|s| s.output(name).is_some());
    if made_later && !made_earlier {
        // An input given in part reaches the stages before the one that
        // completes it as given.
        return cfg
            .completed
            .contains(name)
            .then(|| cfg.inputs.get(name).cloned())
            .flatten();
    }
    artifact.get(name).cloned()
}

/// Run a single stage by hand (`coapt <stage> …`): always runs. When the
/// stage writes into a directory, its record goes to that directory's manifest.
pub fn run_single(
    spec: &'static StageSpec,
    io: &StageIo,
    params: &Params,
    out_dir: Option<&Path>,
    inv: &Invocation,
) -> Result<()> {
    (spec.check)(params)?;
    for (name, path) in &io.inputs {
        if let Some(port) = spec.input(name) {
            validate::input(port.kind, path)?;
        }
    }
    let record_dir = out_dir
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    // Read an existing manifest first: an unreadable one stops us before any work.
    let mut manifest = match out_dir {
        Some(dir) => Some(Manifest::load(dir)?),
        None => None,
    };
    let inputs = execute::hash_inputs(io, &record_dir)?;
    let rec = execute::execute(
        spec,
        io,
        params,
        inputs,
        &record_dir,
        "run by hand".into(),
        inv,
    )?;
    if let (Some(dir), Some(manifest)) = (out_dir, manifest.as_mut()) {
        // Keep the order the directory already has; a new stage goes last.
        let mut order: Vec<String> = manifest.stages.iter().map(|s| s.stage.clone()).collect();
        order.push(spec.name.to_string());
        let order: Vec<&str> = order.iter().map(String::as_str).collect();
        manifest.put(rec, &order);
        manifest.save(dir)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::tests::registry;

    fn cfg(text: &str) -> RunConfig {
        RunConfig::parse(Path::new("c.toml"), text, &registry()).unwrap()
    }

    #[test]
    fn plan_follows_available_inputs() {
        let r = registry();
        // A source stage runs only when configured; its outputs feed the next.
        let chain = plan(&cfg("[make]\n"), &r).unwrap();
        assert_eq!(
            chain.iter().map(|s| s.name).collect::<Vec<_>>(),
            ["make", "close"]
        );
        // Given the artifact as an input, only the consumer runs.
        let chain = plan(&cfg("[inputs]\na = \"a.txt\"\n"), &r).unwrap();
        assert_eq!(chain.iter().map(|s| s.name).collect::<Vec<_>>(), ["close"]);
        // Configured but starved: an error naming what is missing.
        let e = plan(&cfg("[close]\n"), &r).unwrap_err().to_string();
        assert!(e.contains("needs a"), "{e}");
        // Not named, and its output is given: the stage is left out.
        let chain = plan(&cfg("[inputs]\na = \"a.txt\"\nb = \"b.txt\"\n"), &r).unwrap();
        assert!(chain.is_empty());
        // Named, and its output is given as well: ambiguous.
        let e = plan(&cfg("[make]\n[inputs]\na = \"a.txt\"\n"), &r)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("inputs.a") && e.contains("made by stage make"),
            "{e}"
        );
        // Nothing at all.
        assert!(plan(&cfg(""), &r).is_err());
    }
}
