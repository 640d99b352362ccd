#![no_main]
//! `cargo +nightly fuzz run velodyne_stream`: see mimnav_fuzz_bodies::velodyne_stream.
libfuzzer_sys::fuzz_target!(|data: &[u8]| mimnav_fuzz_bodies::velodyne_stream(data));
