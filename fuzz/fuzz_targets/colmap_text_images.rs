#![no_main]
//! Fuzzes [`planemap_fuzz::readers::colmap_text_images`].
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = planemap_fuzz::readers::colmap_text_images(data);
});
