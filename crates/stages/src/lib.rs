//! The stages of this build of coapt, in chain order. The pipeline runs
//! whatever list it is given and knows no stage; this list is where the
//! binary, the design sweep and the benchmarks get theirs. Only stages that
//! really exist are registered.

use coapt_pipeline::StageSpec;

pub fn registry() -> &'static [&'static StageSpec] {
    static STAGES: &[&StageSpec] = &[
        &coapt_phantom::stage::SPEC,
        &coapt_segment::stage::SPEC,
        &coapt_surface::stage::SPEC,
        &coapt_landmarks::stage::SPEC,
        &coapt_valve::stage::SPEC,
        &coapt_leaflet::stage::SPEC,
        &coapt_close::SPEC,
        &coapt_report::stage::SPEC,
    ];
    STAGES
}
