#![no_main]
//! Fuzzes [`planemap_fuzz::readers::pmvs_camera`].
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = planemap_fuzz::readers::pmvs_camera(data);
});
