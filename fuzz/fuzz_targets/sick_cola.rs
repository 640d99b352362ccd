#![no_main]
//! `cargo +nightly fuzz run sick_cola`: see mimnav_fuzz_bodies::sick_cola.
libfuzzer_sys::fuzz_target!(|data: &[u8]| mimnav_fuzz_bodies::sick_cola(data));
