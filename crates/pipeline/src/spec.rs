//! What a stage declares once: its input and output artifacts and its
//! parameters. The CLI subcommand, the run-config section and the provenance
//! record are all derived from this declaration.

use serde_json::Value as Json;

use super::params::Params;
use super::progress::Progress;
use coapt_base::Result;
use coapt_base::units;

/// The kind of file an artifact is; the runner validates external inputs by kind
/// before any stage starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArtifactKind {
    /// NIfTI image (CT).
    Volume,
    /// NIfTI uint8 mask.
    Mask,
    /// Markups / fcsv / plain JSON landmarks; C1–C3 required.
    Landmarks,
    /// Landmarks holding any of C1–C3 and N1–N3 (a user's corrections).
    SomeLandmarks,
    /// VTK XML PolyData triangle mesh.
    Mesh,
    /// VTK XML PolyData with polylines.
    Polylines,
    /// A JSON document.
    Json,
    /// A leaflet template file (TOML with explicit units).
    Template,
    /// A directory of files.
    Dir,
    /// Closure mechanics settings (`close.toml`, explicit units).
    MechConfig,
    /// A self-contained HTML page (the report).
    Html,
}

impl ArtifactKind {
    pub fn describe(self) -> &'static str {
        match self {
            ArtifactKind::Volume => {
                "CT volume (.nii/.nii.gz; as input also .nrrd/.nhdr, .mha/.mhd or a DICOM series folder)"
            }
            ArtifactKind::Mask => "NIfTI mask (.nii/.nii.gz)",
            ArtifactKind::Landmarks => "landmarks (.mrk.json/.fcsv/.json)",
            ArtifactKind::SomeLandmarks => {
                "landmarks (.mrk.json/.fcsv/.json) holding any of C1–C3, N1–N3"
            }
            ArtifactKind::Mesh => "triangle mesh (.vtp)",
            ArtifactKind::Polylines => "polylines (.vtp)",
            ArtifactKind::Json => "JSON",
            ArtifactKind::Template => "leaflet template (.toml)",
            ArtifactKind::Dir => "directory",
            ArtifactKind::MechConfig => "mechanics settings (.toml)",
            ArtifactKind::Html => "HTML page",
        }
    }
}

/// An input or output artifact of a stage.
#[derive(Debug, Clone, Copy)]
pub struct Port {
    /// Artifact name, shared along the chain ("ct", "mask", "landmarks", …).
    pub name: &'static str,
    /// Command-line flag without dashes ("ct", "out", "paths").
    pub flag: &'static str,
    /// File name inside a run directory ("ct.nii.gz").
    pub file: &'static str,
    pub kind: ArtifactKind,
    /// Inputs: must be given. Outputs: always written.
    pub required: bool,
    pub help: &'static str,
}

/// How a parameter's text is read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamKind {
    /// A physical quantity with a unit ("0.4 mm", "80 mmHg").
    Quantity(units::Kind),
    /// Three lengths ("0.44, 0.44, 0.6 mm").
    Lengths3,
    Int {
        min: i64,
        max: i64,
    },
    Float {
        min: f64,
        max: f64,
    },
    Bool,
    Choice(&'static [&'static str]),
    /// A file or directory path, taken as written (e.g. a debug directory).
    Path,
}

/// A stage parameter.
#[derive(Debug, Clone, Copy)]
pub struct Param {
    /// Name in configs (snake_case); the CLI flag is the same with dashes.
    pub name: &'static str,
    pub kind: ParamKind,
    /// Default, written as a user would ("25 HU"); `None`: unset unless given.
    pub default: Option<&'static str>,
    pub help: &'static str,
}

/// A stage: its declaration and the function that carries it out.
pub struct StageSpec {
    pub name: &'static str,
    pub about: &'static str,
    pub inputs: &'static [Port],
    pub outputs: &'static [Port],
    /// `Some(flag)`: the CLI takes `--flag DIR` and writes every output under
    /// its run-directory file name there (with a manifest). `None`: one flag per output.
    pub out_dir: Option<&'static str>,
    pub params: &'static [Param],
    /// Judge the resolved parameters together (ranges, combinations) before
    /// any stage of a run starts, so a bad value fails fast.
    pub check: fn(&Params) -> Result<()>,
    /// Carry the stage out; returns a summary recorded in the manifest.
    /// Must write its outputs atomically (all or nothing).
    pub run: fn(&StageIo, &Params, &Progress) -> Result<Json>,
}

impl std::fmt::Debug for StageSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StageSpec")
            .field("name", &self.name)
            .finish()
    }
}

impl StageSpec {
    pub fn param(&self, name: &str) -> Option<&Param> {
        self.params.iter().find(|p| p.name == name)
    }

    pub fn input(&self, name: &str) -> Option<&Port> {
        self.inputs.iter().find(|p| p.name == name)
    }

    pub fn output(&self, name: &str) -> Option<&Port> {
        self.outputs.iter().find(|p| p.name == name)
    }

    /// A stage with no inputs (it makes data, like the phantom).
    pub fn is_source(&self) -> bool {
        self.inputs.is_empty()
    }
}

/// Resolved file paths for one execution of a stage.
#[derive(Debug, Clone, Default)]
pub struct StageIo {
    pub inputs: Vec<(&'static str, std::path::PathBuf)>,
    pub outputs: Vec<(&'static str, std::path::PathBuf)>,
}

impl StageIo {
    pub fn input(&self, name: &str) -> Option<&std::path::Path> {
        self.inputs
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, p)| p.as_path())
    }

    pub fn output(&self, name: &str) -> &std::path::Path {
        self.outputs
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, p)| p.as_path())
            .unwrap_or_else(|| panic!("stage asked for undeclared output '{name}'"))
    }
}
