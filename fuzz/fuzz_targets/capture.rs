#![no_main]
//! `cargo +nightly fuzz run capture`: see mimnav_fuzz_bodies::capture.
libfuzzer_sys::fuzz_target!(|data: &[u8]| mimnav_fuzz_bodies::capture(data));
