#![no_main]
//! Fuzzes [`planemap_fuzz::readers::colmap_text_points3d`].
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = planemap_fuzz::readers::colmap_text_points3d(data);
});
