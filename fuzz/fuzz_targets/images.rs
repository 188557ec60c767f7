//! Raw fuzzer bytes as an image file; the first byte picks HDR, EXR or PNG.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, body)) = data.split_first() else { return };
    let ext = ["hdr", "exr", "png"][pick as usize % 3];
    let path = std::env::temp_dir().join(format!("glimpse-cargo-fuzz-{}.{ext}", std::process::id()));
    if std::fs::write(&path, body).is_ok() {
        let _ = glimpse_core::Image::read(&path);
    }
});
