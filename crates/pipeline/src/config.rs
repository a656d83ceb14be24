//! Run configs (TOML): where the run directory is, which external artifacts
//! feed the chain, and per-stage parameter sections named after the stages.
//!
//! ```toml
//! [run]
//! dir = "../runs/phantom"        # relative to this file; `--out` overrides
//! # series = "3"                 # the DICOM series, when the CT folder holds several
//!
//! [inputs]                       # external artifacts, by artifact name
//! ct = "../sample_data/ct.nii.gz"
//!
//! [phantom]                      # a stage section: its parameters
//! preset = "sample"
//! noise = "25 HU"                # quantities always carry a unit
//! ```

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use super::params::{self, Value};
use super::spec::StageSpec;
use coapt_base::{Error, Result};

#[derive(Debug, Clone)]
pub struct RunConfig {
    pub path: PathBuf,
    pub run_dir: Option<PathBuf>,
    /// `[run] series`: the DICOM series to read from a CT folder that holds
    /// several (UID or SeriesNumber), as `--series` on the command line.
    pub series: Option<String>,
    /// External artifacts by name, resolved against the config's directory.
    pub inputs: BTreeMap<String, PathBuf>,
    /// Parsed parameters of each stage section present.
    pub sections: BTreeMap<String, BTreeMap<String, Value>>,
    /// The `[design]` section as written: `coapt design` reads it (errors
    /// name this file and the key); `coapt run` ignores it.
    pub design: Option<toml::Table>,
    /// Inputs given in part, which the stage that makes them completes
    /// ([`RunConfig::complete_partial_inputs`]).
    pub completed: BTreeSet<String>,
}

impl RunConfig {
    pub fn has_section(&self, stage: &str) -> bool {
        self.sections.contains_key(stage)
    }

    pub fn load(path: &Path, registry: &[&'static StageSpec]) -> Result<RunConfig> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::read(path, e))?;
        Self::parse(path, &text, registry)
    }

    pub fn parse(path: &Path, text: &str, registry: &[&'static StageSpec]) -> Result<RunConfig> {
        let doc: toml::Table = text.parse().map_err(|e: toml::de::Error| {
            Error::bad_input(
                path,
                format!(
                    "not valid TOML: {}",
                    coapt_io::toml_error::describe(text, &e)
                ),
            )
        })?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let artifacts: BTreeSet<&str> = registry
            .iter()
            .flat_map(|s| s.inputs.iter().chain(s.outputs.iter()).map(|p| p.name))
            .collect();

        let mut cfg = RunConfig {
            path: path.to_path_buf(),
            run_dir: None,
            series: None,
            inputs: BTreeMap::new(),
            sections: BTreeMap::new(),
            design: None,
            completed: BTreeSet::new(),
        };
        for (key, value) in &doc {
            match key.as_str() {
                "run" => {
                    let t = table(path, key, value)?;
                    for (k, v) in t {
                        match (k.as_str(), v) {
                            ("dir", toml::Value::String(s)) => {
                                cfg.run_dir = Some(normalize(&base.join(s)))
                            }
                            ("dir", _) => {
                                return Err(Error::config(
                                    path,
                                    "run.dir",
                                    "must be a path string",
                                ));
                            }
                            ("series", toml::Value::String(s)) if !s.trim().is_empty() => {
                                cfg.series = Some(s.trim().to_string())
                            }
                            ("series", toml::Value::Integer(n)) => cfg.series = Some(n.to_string()),
                            ("series", _) => {
                                return Err(Error::config(
                                    path,
                                    "run.series",
                                    "must be a SeriesInstanceUID or a SeriesNumber (`coapt info \
                                     DIR` lists the folder's series)",
                                ));
                            }
                            _ => {
                                return Err(Error::config(
                                    path,
                                    format!("run.{k}"),
                                    "unknown key (the [run] section takes: dir, series)",
                                ));
                            }
                        }
                    }
                }
                "inputs" => {
                    for (k, v) in table(path, key, value)? {
                        if !artifacts.contains(k.as_str()) {
                            return Err(Error::config(
                                path,
                                format!("inputs.{k}"),
                                format!(
                                    "no stage uses an artifact called '{k}' (known: {})",
                                    artifacts.iter().copied().collect::<Vec<_>>().join(", ")
                                ),
                            ));
                        }
                        let toml::Value::String(s) = v else {
                            return Err(Error::config(
                                path,
                                format!("inputs.{k}"),
                                "must be a path string",
                            ));
                        };
                        cfg.inputs.insert(k.clone(), normalize(&base.join(s)));
                    }
                }
                "design" => {
                    cfg.design = Some(table(path, key, value)?.clone());
                }
                name => {
                    let Some(spec) = registry.iter().find(|s| s.name == name) else {
                        let known: Vec<&str> = registry.iter().map(|s| s.name).collect();
                        return Err(Error::config(
                            path,
                            format!("[{name}]"),
                            format!(
                                "unknown section: not a stage of this coapt (stages: {}; other sections: run, inputs, design)",
                                known.join(", ")
                            ),
                        ));
                    };
                    let mut values = BTreeMap::new();
                    for (k, v) in table(path, key, value)? {
                        let Some(p) = spec.param(k) else {
                            let names: Vec<&str> = spec.params.iter().map(|p| p.name).collect();
                            return Err(Error::config(
                                path,
                                format!("{name}.{k}"),
                                if names.is_empty() {
                                    format!(
                                        "unknown parameter: stage {name} takes none here{}",
                                        if spec.input("config").is_some() {
                                            " (its settings live in the file of `config =` under [inputs])"
                                        } else {
                                            ""
                                        }
                                    )
                                } else {
                                    format!(
                                        "unknown parameter (stage {name} takes: {})",
                                        names.join(", ")
                                    )
                                },
                            ));
                        };
                        let parsed = params::parse_toml(p, v).map_err(|e| {
                            Error::config(path, format!("{name}.{k}"), e.to_string())
                        })?;
                        values.insert(k.clone(), parsed);
                    }
                    cfg.sections.insert(name.to_string(), values);
                }
            }
        }
        cfg.complete_partial_inputs(registry)?;
        Ok(cfg)
    }

    /// An input `X` given in part (landmarks with some of the valve's six
    /// points: a user who placed the commissures, or only the nadirs) is
    /// completed by the stage that makes `X` from `given_X`: that stage
    /// runs with the file as `given_X` (its points override what the stage
    /// finds), the stages before it read the file as given (segment seeds
    /// from the commissures, cuts at the nadirs' plane), and those after it
    /// the completed artifact. Before, the landmarks stage was left out,
    /// and the valve laid its paths without nadirs, which the real CT's
    /// root does not take. An input that cannot be read is left for the
    /// run's validation to name; one given in part beside its own `given_X`
    /// is refused, since the stage takes one file of corrections.
    fn complete_partial_inputs(&mut self, registry: &[&'static StageSpec]) -> Result<()> {
        for spec in registry {
            for out in spec.outputs {
                let given = format!("given_{}", out.name);
                let Some(path) = self.inputs.get(out.name) else {
                    continue;
                };
                if spec.input(&given).is_none() || !super::validate::is_partial(out.kind, path) {
                    continue;
                }
                if let Some(other) = self.inputs.get(&given) {
                    return Err(Error::config(
                        &self.path,
                        format!("inputs.{}", out.name),
                        format!(
                            "{} holds only some of the points, which stage {} completes from a file of given points, but inputs.{given} ({}) is set too: put the points you placed into one file and give it as either",
                            path.display(),
                            spec.name,
                            other.display()
                        ),
                    ));
                }
                let path = path.clone();
                self.inputs.insert(given, path);
                self.completed.insert(out.name.to_string());
            }
        }
        Ok(())
    }
}

/// Remove `.` and `dir/..` lexically so paths in logs and manifests read
/// as written ("runs/x", not "pipelines/../runs/x"). Leading `..` stay.
fn normalize(p: &Path) -> PathBuf {
    use std::path::Component;
    let mut out: Vec<Component> = Vec::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir if matches!(out.last(), Some(Component::Normal(_))) => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    if out.is_empty() {
        PathBuf::from(".")
    } else {
        out.iter().collect()
    }
}

fn table<'a>(path: &Path, key: &str, v: &'a toml::Value) -> Result<&'a toml::Table> {
    v.as_table()
        .ok_or_else(|| Error::config(path, key, "must be a [section] table"))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::spec::{ArtifactKind, Param, ParamKind, Port};
    use coapt_base::units::Kind;

    fn noop(
        _: &super::super::StageIo,
        _: &super::super::Params,
        _: &super::super::Progress,
    ) -> Result<serde_json::Value> {
        Ok(serde_json::Value::Null)
    }

    pub static MAKE: StageSpec = StageSpec {
        name: "make",
        about: "",
        inputs: &[],
        outputs: &[Port {
            name: "a",
            flag: "out",
            file: "a.txt",
            kind: ArtifactKind::Json,
            required: true,
            help: "",
        }],
        out_dir: Some("out"),
        params: &[],
        check: |_| Ok(()),
        run: noop,
    };

    pub static CLOSE: StageSpec = StageSpec {
        name: "close",
        about: "",
        inputs: &[Port {
            name: "a",
            flag: "a",
            file: "a.txt",
            kind: ArtifactKind::Json,
            required: true,
            help: "",
        }],
        outputs: &[Port {
            name: "b",
            flag: "out",
            file: "b.txt",
            kind: ArtifactKind::Json,
            required: true,
            help: "",
        }],
        out_dir: None,
        params: &[Param {
            name: "pressure",
            kind: ParamKind::Quantity(Kind::Pressure),
            default: Some("80 mmHg"),
            help: "",
        }],
        check: |_| Ok(()),
        run: noop,
    };

    pub fn registry() -> Vec<&'static StageSpec> {
        vec![&MAKE, &CLOSE]
    }

    #[test]
    fn bare_pressure_names_file_key_and_unit() {
        let e = RunConfig::parse(
            Path::new("cfg/run.toml"),
            "[close]\npressure = 80\n",
            &registry(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("cfg/run.toml: close.pressure:"), "{e}");
        assert!(e.contains("bare number 80") && e.contains("mmHg"), "{e}");
        let cfg = RunConfig::parse(
            Path::new("cfg/run.toml"),
            "[close]\npressure = \"12 kPa\"\n[inputs]\na = \"x.txt\"\n",
            &registry(),
        )
        .unwrap();
        assert_eq!(
            cfg.sections["close"]["pressure"],
            Value::Quantity(0.012, Kind::Pressure)
        );
        assert_eq!(cfg.inputs["a"], Path::new("cfg/x.txt"));
        assert_eq!(
            normalize(Path::new("pipelines/../runs/./x")),
            Path::new("runs/x")
        );
        assert_eq!(normalize(Path::new("../a/../../b")), Path::new("../../b"));
        assert_eq!(normalize(Path::new("/a/../b")), Path::new("/b"));
    }

    #[test]
    fn unknown_names_are_refused_with_the_valid_ones() {
        let r = registry();
        let e = RunConfig::parse(Path::new("c.toml"), "[clsoe]\n", &r)
            .unwrap_err()
            .to_string();
        assert!(e.contains("[clsoe]") && e.contains("make, close"), "{e}");
        let e = RunConfig::parse(Path::new("c.toml"), "[close]\npresure = \"1 kPa\"\n", &r)
            .unwrap_err()
            .to_string();
        assert!(e.contains("close.presure") && e.contains("pressure"), "{e}");
        let e = RunConfig::parse(Path::new("c.toml"), "[inputs]\nzz = \"p\"\n", &r)
            .unwrap_err()
            .to_string();
        assert!(e.contains("inputs.zz") && e.contains("a, b"), "{e}");
        let e = RunConfig::parse(Path::new("c.toml"), "[run]\ndir = 3\n", &r)
            .unwrap_err()
            .to_string();
        assert!(e.contains("run.dir"), "{e}");
    }
}
