//! Integration tests: every user-visible behaviour of the `coapt` binary.

mod bad_input;
mod bench_close_grid;
mod bench_pipeline;
mod bench_stress_close;
mod close;
mod common;
mod design;
mod dicom;
mod end_to_end;
mod formats;
mod hanging;
mod leaflets;
mod phantom;
mod real_ct;
mod real_ct_variants;
mod real_segment;
mod real_valve;
mod report;
mod report_html;
mod runner;
mod sample_data;
mod segment;
mod snakemake;
mod surface;
mod valve;
mod wall_contact;
