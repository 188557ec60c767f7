//! Raw fuzzer bytes as a wavecache payload (after the checksum, so the structural validation is
//! what is fuzzed): parsing must refuse or accept without a panic, and an accepted cache must pass
//! its own validation again.
#![no_main]
use glimpse_wavecache::WaveCache;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let key = data.get(..8).map_or(0, |k| u64::from_le_bytes(k.try_into().unwrap()));
    if let Ok(c) = WaveCache::from_payload(data, key) {
        assert!(c.validate().is_ok());
    }
    let format = WaveCache::FORMAT;
    let _ = glimpse_core::cache_file::decode(format, std::path::Path::new("fuzz.bin"), data);
});
