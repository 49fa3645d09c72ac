//! Arbitrary bytes → `gltf_io::decode` gives `Ok` or a typed error, never a panic.
//!
//! `decode` turns a panic inside the parser into `ErrorCode::Internal` (so a service worker
//! survives it); here that code is itself a finding, so the fuzzer stops on it.
#![no_main]
use libfuzzer_sys::fuzz_target;
use texatlas::gltf_io::{decode, DecodeLimits, ErrorCode, Resources};

fuzz_target!(|data: &[u8]| {
    if let Err(e) = decode(data, &Resources::new(), &DecodeLimits::default()) {
        assert_ne!(e.code, ErrorCode::Internal, "{e}");
    }
});
