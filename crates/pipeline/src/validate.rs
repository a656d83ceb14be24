//! Check external inputs before a run spends any time: each is read (for
//! volumes, only the header) and judged by the kind its stage declared.

use std::path::Path;

use super::spec::ArtifactKind;
use coapt_base::{Error, Result};
use coapt_io::{markups, nifti, volume_file, vtp};

/// Labels every landmarks input must hold.
pub const REQUIRED_LANDMARKS: [&str; 3] = ["C1", "C2", "C3"];

/// The points of the valve: commissures and nadirs.
pub const VALVE_LANDMARKS: [&str; 6] = ["C1", "C2", "C3", "N1", "N2", "N3"];

/// Whether an input of `kind` at `path` holds only part of what the stage
/// making that kind writes: landmarks with some of the valve's six points
/// but not all (a user who placed the commissures, or only the nadirs).
/// False when it cannot be read, or holds none of them (validation names
/// either).
pub fn is_partial(kind: ArtifactKind, path: &Path) -> bool {
    kind == ArtifactKind::Landmarks
        && markups::read(path).is_ok_and(|lm| {
            let held = VALVE_LANDMARKS
                .iter()
                .filter(|l| lm.get(l).is_some())
                .count();
            held > 0 && held < VALVE_LANDMARKS.len()
        })
}

pub fn input(kind: ArtifactKind, path: &Path) -> Result<()> {
    if !path.exists() {
        return Err(Error::bad_input(path, "not found"));
    }
    match kind {
        ArtifactKind::Volume => {
            volume_file::read_header(path, &nifti::ReadOptions::default())?;
        }
        ArtifactKind::Mask => {
            nifti::read_header(path)?;
        }
        ArtifactKind::Landmarks => {
            let lm = markups::read(path)?;
            lm.require(&REQUIRED_LANDMARKS)
                .map_err(|e| e.in_file(path))?;
        }
        ArtifactKind::SomeLandmarks => {
            let lm = markups::read(path)?;
            if !VALVE_LANDMARKS.iter().any(|l| lm.get(l).is_some()) {
                return Err(Error::bad_input(
                    path,
                    format!(
                        "holds none of {}: label the points you place C1–C3 (commissures) or N1–N3 (nadirs)",
                        VALVE_LANDMARKS.join(", ")
                    ),
                ));
            }
        }
        ArtifactKind::Mesh => {
            vtp::read_mesh(path)?;
        }
        ArtifactKind::Polylines => {
            vtp::read(path)?;
        }
        ArtifactKind::Json => {
            let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
            serde_json::from_slice::<serde_json::Value>(&bytes)
                .map_err(|e| Error::bad_input(path, format!("not valid JSON: {e}")))?;
        }
        ArtifactKind::Template => {
            coapt_template::check_templates(path)?;
        }
        ArtifactKind::MechConfig => {
            coapt_mech::config::read(path)?;
        }
        ArtifactKind::Html => {
            let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
            if !bytes.starts_with(b"<!DOCTYPE html") && !bytes.starts_with(b"<!doctype html") {
                return Err(Error::bad_input(
                    path,
                    "not an HTML page (no <!DOCTYPE html>)",
                ));
            }
        }
        ArtifactKind::Dir => {
            if !path.is_dir() {
                return Err(Error::bad_input(path, "expected a directory"));
            }
        }
    }
    Ok(())
}
