//! The `landmarks` stage: commissures C1–C3 and nadirs N1–N3 found in the
//! segmented root, written as 3D Slicer markups (LPS) a user can open, move
//! and save, with their confidence and evidence in `landmarks.json`.

use serde_json::{Value as Json, json};

use super::annulus;
use super::detect::{self, Detection};
use super::numbering;
use super::ostia::{self, NamedBy};
use super::stage_params::LandmarksParams;
use coapt_base::{Error, Result};
use coapt_geom::bvh::Bvh;
use coapt_geom::closest_point::closest_point;
use coapt_geom::{Frame, Landmarks, Point3, TriMesh, Vector3};
use coapt_io::{Transaction, markups, nifti, volume_file, vtp};
use coapt_pipeline::{ArtifactKind, Param, ParamKind, Params, Port, Progress, StageIo, StageSpec};

pub static SPEC: StageSpec = StageSpec {
    name: "landmarks",
    about: "Find the commissures C1–C3 and nadirs N1–N3 in the segmented root (sinus lobes, STJ, annulus plane)",
    inputs: &[
        Port {
            name: "ct",
            flag: "ct",
            file: "ct.nii.gz",
            kind: ArtifactKind::Volume,
            required: false,
            help: "the CT the mask was segmented from: the coronary ostia it shows name the sinuses (without it, or without two ostia, the sinus facing anterior is the right-coronary one)",
        },
        Port {
            name: "mask",
            flag: "mask",
            file: "mask.nii.gz",
            kind: ArtifactKind::Mask,
            required: true,
            help: "aortic lumen from the VAJ up (as `segment` writes it)",
        },
        Port {
            name: "surface",
            flag: "surface",
            file: "aorta.vtp",
            kind: ArtifactKind::Mesh,
            required: true,
            help: "lumen wall: the points are put on it; its lowest cut cap is the annulus plane when no segment report is given",
        },
        Port {
            name: "segment_report",
            flag: "segment-report",
            file: "segment.json",
            kind: ArtifactKind::Json,
            required: false,
            help: "segment.json: its VAJ plane (vaj.plane) is the annulus plane",
        },
        Port {
            name: "given_landmarks",
            flag: "given",
            file: "given.mrk.json",
            kind: ArtifactKind::SomeLandmarks,
            required: false,
            help: "a user's points (any of C1–C3, N1–N3, e.g. corrected in 3D Slicer): each replaces the detected one; the rest are detected",
        },
    ],
    outputs: &[
        Port {
            name: "landmarks",
            flag: "out",
            file: "landmarks.mrk.json",
            kind: ArtifactKind::Landmarks,
            required: true,
            help: "C1–C3 and N1–N3, 3D Slicer markups in LPS",
        },
        Port {
            name: "landmarks_report",
            flag: "report",
            file: "landmarks.json",
            kind: ArtifactKind::Json,
            required: true,
            help: "per point: confidence and evidence; axis, sinus and STJ heights, radius against angle; findings",
        },
    ],
    out_dir: None,
    params: &[Param {
        name: "min_confidence",
        kind: ParamKind::Float { min: 0.0, max: 1.0 },
        default: Some("0.5"),
        help: "a point found with less confidence than this is listed as a finding (warning)",
    }],
    check: |p| LandmarksParams::try_from(p).map(|_| ()),
    run,
};

/// A detected point is put on the wall mesh; more than this from it means
/// the mask and the surface disagree (mm).
const MAX_SNAP_MM: f64 = 2.0;

/// Closest point of the wall (region 0 triangles) to `p`.
fn snap(mesh: &TriMesh, bvh: &Bvh, tris: &[[u32; 3]], p: &Point3) -> Option<Point3> {
    let x: Vector3 = p.coords;
    let mut best: Option<(f64, Vector3)> = None;
    bvh.query_sphere(&x, MAX_SNAP_MM, |t| {
        let [a, b, c] = tris[t as usize].map(|i| mesh.vertices[i as usize].coords);
        let q = closest_point(&x, &a, &b, &c).point;
        let d = (q - x).norm();
        if best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, q));
        }
    });
    best.map(|(_, q)| Point3::from(q))
}

/// Where a point of the written landmarks comes from.
#[derive(Debug, Clone, PartialEq)]
enum Source {
    Detected,
    /// The user's file; the detector had put the point at `detected`.
    Given {
        detected: Point3,
    },
}

impl Source {
    fn name(&self) -> &'static str {
        match self {
            Source::Detected => "detected",
            Source::Given { .. } => "given",
        }
    }
}

/// Every detected point that `given` holds is replaced by the user's; the
/// sources follow `det.points`.
fn merge_given(det: &mut Detection, given: Option<&Landmarks>) -> Vec<Source> {
    det.points
        .iter_mut()
        .map(|p| match given.and_then(|g| g.get(&p.label)) {
            Some(q) => {
                let detected = p.point_mm;
                p.point_mm = q;
                Source::Given { detected }
            }
            None => Source::Detected,
        })
        .collect()
}

/// Findings for detected points below `min_confidence` (a given point is
/// the user's), and for a STJ that is not a clear narrowing.
fn findings(det: &Detection, sources: &[Source], min_confidence: f64) -> Vec<String> {
    let mut out = Vec::new();
    if !det.stj_is_minimum {
        out.push(format!(
            "no clear STJ: the mean radius does not narrow to a minimum within 20 mm above mid-sinus (taken at {:.1} mm above the annulus); the commissure heights are uncertain",
            det.stj_height_mm
        ));
    }
    let naming = &det.sinus_naming;
    let seen = det.sinuses.iter().filter(|s| s.ostium.is_some()).count();
    if naming.ct_searched && seen != 2 {
        out.push(format!(
            "coronary ostia seen in {seen} sinuses, not two: the sinuses are named by position (the one facing anterior is the right-coronary sinus); check the names in the CT"
        ));
    }
    if !naming.agrees_with_position {
        out.push(
            "the coronary ostia name another sinus the right-coronary one than its position (the sinus facing anterior) does; the ostia were followed: check the names in the CT".into(),
        );
    }
    for (p, s) in det.points.iter().zip(sources) {
        if let (Some(h), Source::Detected) = (p.evidence["lifted_mm"].as_f64(), s) {
            out.push(format!(
                "{} lies {h:.1} mm above the annulus plane: the wall at its angle widens into the sinus only from there, so the annulus is tilted to that plane (segment's VAJ plane, or the mask's lowest cut); check N1–N3 in 3D Slicer",
                p.label
            ));
        }
        if p.confidence < min_confidence && *s == Source::Detected {
            out.push(format!(
                "{} detected with low confidence {:.2} (< {min_confidence}): check it in 3D Slicer ({})",
                p.label, p.confidence, p.evidence
            ));
        }
    }
    out
}

/// The detected commissures' angles about the detected axis, C1 to C3
/// (counter-clockwise, so they bound sectors 0, 1, 2).
fn commissure_angles(det: &Detection) -> Option<[f64; 3]> {
    let a: Vec<f64> = ["C1", "C2", "C3"]
        .iter()
        .filter_map(|c| {
            det.points
                .iter()
                .find(|p| p.label == *c)?
                .evidence
                .get("angle_deg")?
                .as_f64()
        })
        .collect();
    a.try_into().ok()
}

fn point_of<'a>(det: &'a Detection, label: &str) -> Option<&'a Point3> {
    det.points
        .iter()
        .find(|p| p.label == label)
        .map(|p| &p.point_mm)
}

/// Per leaflet k (sewn between the final C_k and C_k+1), the name of the
/// sinus it is sewn in: the detected sector holding the middle of the arc
/// between its commissures, whoever placed them.
fn leaflet_sinuses(det: &Detection) -> Option<Vec<&'static str>> {
    let sectors = commissure_angles(det)?;
    (0..3)
        .map(|k| {
            let a = det.angle_deg(point_of(det, &format!("C{}", k + 1))?);
            let b = det.angle_deg(point_of(det, &format!("C{}", (k + 1) % 3 + 1))?);
            let mid = a + 0.5 * (b - a).rem_euclid(360.0);
            Some(det.sinuses.get(ostia::sector_of(mid, &sectors))?.name)
        })
        .collect()
}

/// The words 3D Slicer shows beside a point: what it is, whose sinus, and
/// whether coapt found it or the user gave it. Sinus k lies between C_k and
/// C_k+1, so commissure C_k parts sinus k−1 from sinus k. A given point is
/// placed by where it lies (its angle about the detected axis among the
/// detected commissures), not by its label: a user's file may number the
/// sinuses otherwise.
fn describe(label: &str, det: &Detection, sources: &[Source]) -> String {
    let name = |k: usize| {
        det.sinuses
            .get(k)
            .map_or("?".to_string(), |s| s.name.replace('_', "-"))
    };
    let found = det
        .points
        .iter()
        .zip(sources)
        .find(|(p, _)| p.label == label);
    let source = found.map_or("detected", |(_, s)| s.name());
    let by_label = label[1..].parse::<usize>().unwrap_or(1).clamp(1, 3) - 1;
    let k = match (found, commissure_angles(det)) {
        (Some((p, Source::Given { .. })), Some(sectors)) => {
            let deg = det.angle_deg(&p.point_mm);
            if label.starts_with('C') {
                let off = |x: f64| super::angular::apart_deg(deg, x);
                (0..3)
                    .min_by(|&i, &j| off(sectors[i]).total_cmp(&off(sectors[j])))
                    .unwrap_or(by_label)
            } else {
                ostia::sector_of(deg, &sectors)
            }
        }
        _ => by_label,
    };
    let what = if label.starts_with('C') {
        format!(
            "commissure between the {} and {} sinuses",
            name((k + 2) % 3),
            name(k)
        )
    } else {
        format!("nadir of the {} sinus", name(k))
    };
    format!(
        "{what} ({source}; sinuses named by {})",
        match det.sinus_naming.by {
            NamedBy::CoronaryOstia => "the coronary ostia",
            NamedBy::Position => "position",
        }
    )
}

fn run(io: &StageIo, params: &Params, progress: &Progress) -> Result<Json> {
    let lp = LandmarksParams::try_from(params)?;
    let t0 = std::time::Instant::now();
    let mask_path = io.input("mask").expect("required input");
    let surf_path = io.input("surface").expect("required input");
    let mask = nifti::read_u8(mask_path)?;
    let mesh = vtp::read_mesh(surf_path)?;
    let (plane, plane_source) = match io.input("segment_report") {
        Some(p) => match annulus::from_segment_report(p)? {
            Some(pl) => (Some(pl), "segment.json vaj.plane"),
            None => (
                annulus::from_surface_caps(&mesh),
                "lowest cut cap of the surface",
            ),
        },
        None => (
            annulus::from_surface_caps(&mesh),
            "lowest cut cap of the surface",
        ),
    };
    let plane = plane.ok_or_else(|| {
        Error::bad_input(
            surf_path,
            "no annulus plane: the surface has no cut cap (cell data region 1) and no segment report with vaj.plane was given",
        )
    })?;
    let read_s = t0.elapsed().as_secs_f64();
    progress.set(0.2);
    let t1 = std::time::Instant::now();
    let ct = match io.input("ct") {
        Some(p) => Some(volume_file::read_ct(p)?),
        None => None,
    };
    let given = match io.input("given_landmarks") {
        Some(p) => Some(markups::read(p)?),
        None => None,
    };
    let mut det =
        detect::detect(&mask, &plane, ct.as_ref()).map_err(|e| Error::failed("landmarks", e))?;
    let numbering = given
        .as_ref()
        .map_or_else(Default::default, |g| numbering::user_numbering(&det, g));
    numbering::renumber(&mut det, numbering);
    let tris = mesh.wall_triangles();
    let x: Vec<Vector3> = mesh.vertices.iter().map(|p| p.coords).collect();
    let bvh = Bvh::build(&x, &tris);
    let mut moved = serde_json::Map::new();
    for p in &mut det.points {
        let q = snap(&mesh, &bvh, &tris, &p.point_mm).ok_or_else(|| {
            Error::failed(
                "landmarks",
                format!(
                    "{} found on the mask's wall lies more than {MAX_SNAP_MM} mm from the surface {}: were they made from the same mask?",
                    p.label,
                    surf_path.display()
                ),
            )
        })?;
        let d = (q - p.point_mm).norm();
        moved.insert(p.label.clone(), json!(d));
        p.evidence["wall_distance_mm"] = json!(d);
        // A commissure goes onto the wall mesh. A nadir stays in the
        // annulus plane: the wall nearest to it lies above the cap's rim,
        // and moving it there lifted the phantoms' nadirs by 0.6–0.9 mm
        // (`valve` snaps it again when it builds the frame).
        if p.label.starts_with('C') {
            p.point_mm = q;
        }
    }
    let detect_s = t1.elapsed().as_secs_f64();
    progress.set(0.9);
    let sources = merge_given(&mut det, given.as_ref());
    let found = findings(&det, &sources, lp.min_confidence);
    for f in &found {
        tracing::warn!(stage = "landmarks", event = "finding", "landmarks: {f}");
    }
    let mut lm = Landmarks::new(Frame::Lps);
    for p in &det.points {
        lm.push(p.label.clone(), p.point_mm);
    }
    lm.sanity_check()
        .map_err(|e| Error::failed("landmarks", e.to_string()))?;
    let mut report = serde_json::to_value(&det).expect("detection serialises");
    if let Json::Object(m) = &mut report {
        m.insert("frame".into(), json!(Frame::Lps.name()));
        m.insert("annulus_plane_source".into(), json!(plane_source));
        m.insert(
            "commissure_above_knee_mm".into(),
            json!(detect::COMMISSURE_ABOVE_KNEE_MM),
        );
        m.insert("min_confidence".into(), json!(lp.min_confidence));
        // How far the given file's numbering turns the detector's (which
        // starts at the right-coronary sinus): 1 means its C2, N2 are the
        // detector's C1, N1; mirrored, it runs the other way round (its
        // C_s−i and N_s−i−1 are the detector's C_i and N_i).
        m.insert("numbering_turn".into(), json!(numbering.turn));
        m.insert("numbering_mirrored".into(), json!(numbering.mirrored));
        if let Some(Json::Array(points)) = m.get_mut("points") {
            for ((p, s), found) in points.iter_mut().zip(&sources).zip(&det.points) {
                p["source"] = json!(s.name());
                if let Source::Given { detected } = s {
                    p["detected_mm"] = json!([detected.x, detected.y, detected.z]);
                    p["given_to_detected_mm"] = json!((found.point_mm - detected).norm());
                }
            }
        }
        m.insert("findings".into(), json!(found));
        m.insert("leaflet_sinuses".into(), json!(leaflet_sinuses(&det)));
        m.insert(
            "timings_s".into(),
            json!({"read": read_s, "detect": detect_s}),
        );
    }
    let text = serde_json::to_string_pretty(&report).expect("report serialises") + "\n";
    let mrk = markups::encode_mrk_json_described(&lm, Frame::Lps, |label| {
        describe(label, &det, &sources)
    });
    let mut tx = Transaction::new();
    tx.write_bytes(io.output("landmarks"), mrk.as_bytes())?;
    tx.write_bytes(io.output("landmarks_report"), text.as_bytes())?;
    tx.commit()?;
    progress.set(1.0);
    let conf: serde_json::Map<String, Json> = det
        .points
        .iter()
        .map(|p| (p.label.clone(), json!(p.confidence)))
        .collect();
    Ok(json!({
        "read_s": read_s,
        "detect_s": detect_s,
        "confidence": conf,
        "findings": found.len(),
        "annulus_plane_source": plane_source,
        "snapped_mm": moved,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::Found;

    fn detection(conf: [f64; 2], stj_is_minimum: bool) -> Detection {
        let found = |label: &str, confidence: f64| Found {
            label: label.into(),
            point_mm: Point3::origin(),
            confidence,
            evidence: json!({"pillar_depth_mm": 0.2}),
        };
        Detection::on_z_axis(
            vec![found("C1", conf[0]), found("N1", conf[1])],
            Vec::new(),
            stj_is_minimum,
        )
    }

    /// A point under the threshold, and an STJ that is no minimum, are
    /// findings naming what is uncertain; confident points are not.
    #[test]
    fn low_confidence_is_a_finding() {
        let d = vec![Source::Detected; 2];
        let f = findings(&detection([0.9, 0.3], true), &d, 0.5);
        assert_eq!(f.len(), 1, "{f:?}");
        assert!(f[0].contains("N1") && f[0].contains("0.30"), "{f:?}");
        let f = findings(&detection([0.9, 0.8], false), &d, 0.5);
        assert_eq!(f.len(), 1, "{f:?}");
        assert!(f[0].contains("no clear STJ"), "{f:?}");
        assert!(findings(&detection([0.9, 0.8], true), &d, 0.5).is_empty());
    }

    /// A user's point replaces the detected one of its label, whatever else
    /// the file holds; a low confidence of a replaced point is no finding.
    #[test]
    fn given_points_replace_detected_ones_by_label() {
        let mut det = detection([0.9, 0.3], true);
        let mut given = Landmarks::new(Frame::Lps);
        given.push("N1", Point3::new(1.0, 2.0, 3.0));
        given.push("STJ", Point3::new(9.0, 9.0, 9.0));
        let s = merge_given(&mut det, Some(&given));
        assert_eq!(
            s,
            vec![
                Source::Detected,
                Source::Given {
                    detected: Point3::origin()
                }
            ]
        );
        assert_eq!(det.points[1].point_mm, Point3::new(1.0, 2.0, 3.0));
        assert_eq!(det.points[0].point_mm, Point3::origin());
        assert!(findings(&det, &s, 0.5).is_empty());
        let mut det = detection([0.9, 0.3], true);
        assert_eq!(merge_given(&mut det, None), vec![Source::Detected; 2]);
    }
}
