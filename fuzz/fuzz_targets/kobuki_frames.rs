#![no_main]
//! `cargo +nightly fuzz run kobuki_frames`: see mimnav_fuzz_bodies::kobuki_frames.
libfuzzer_sys::fuzz_target!(|data: &[u8]| mimnav_fuzz_bodies::kobuki_frames(data));
