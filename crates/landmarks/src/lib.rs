//! The `landmarks` stage: the commissures C1–C3 and nadirs N1–N3 found in
//! the segmented root, so that a CT alone reaches a report. See
//! [`detect`] for the method, [`stage`] for the files.

pub mod angular;
pub mod annulus;
pub mod detect;
pub mod lumen_rays;
pub mod numbering;
pub mod ostia;
pub mod stage;
pub mod stage_params;

pub use detect::{AnnulusPlane, Detection, detect};
