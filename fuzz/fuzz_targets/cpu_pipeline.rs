//! The CPU pipeline on arbitrary small images with arbitrary configs.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| lfast_fuzz::cpu_pipeline(data));
