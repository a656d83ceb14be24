//! The stages of this build of coapt, in chain order. The pipeline runs
//! whatever list it is given and knows no stage; this list is where the
//! binary, the design sweep and the benchmarks get theirs. Only stages that
//! really exist are registered.

use crate::pipeline::StageSpec;

pub fn registry() -> &'static [&'static StageSpec] {
    static STAGES: &[&StageSpec] = &[
        &crate::phantom::stage::SPEC,
        &crate::segment::stage::SPEC,
        &crate::surface::stage::SPEC,
        &crate::landmarks::stage::SPEC,
        &crate::valve::stage::SPEC,
        &crate::leaflet::stage::SPEC,
        &crate::close::SPEC,
        &crate::report::stage::SPEC,
    ];
    STAGES
}
