#![no_main]
//! `cargo +nightly fuzz run config`: see mimnav_fuzz_bodies::config.
libfuzzer_sys::fuzz_target!(|data: &[u8]| mimnav_fuzz_bodies::config(data));
