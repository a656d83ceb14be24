//! The TOML a user writes: close.toml, leaflet templates (with and without
//! the measured intercommissural distances) and run configs.
#![no_main]
use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = coapt::mech::config::parse(text);
    let _ = coapt::template::parse_templates(text, None);
    let _ = coapt::template::parse_templates(text, Some([22.4, 23.8, 23.1]));
    let _ = coapt::pipeline::config::RunConfig::parse(
        Path::new("/fuzz/pipelines/run.toml"),
        text,
        coapt::stages::registry(),
    );
});
