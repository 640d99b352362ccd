#![no_main]
//! `cargo +nightly fuzz run world`: see mimnav_fuzz_bodies::world.
libfuzzer_sys::fuzz_target!(|data: &[u8]| mimnav_fuzz_bodies::world(data));
