//! Arbitrary bytes as an image file: decode with lfast's limits, then detect.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| lfast_fuzz::decode_detect(data));
