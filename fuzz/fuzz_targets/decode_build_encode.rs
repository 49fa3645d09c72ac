//! Arbitrary bytes → decode → weld/validate → encode with seam-creating UVs: no panic anywhere,
//! and whatever decodes and builds must also encode and decode again.
#![no_main]
use libfuzzer_sys::fuzz_target;
use texatlas::gltf_io::{decode, encode, DecodeLimits, EncodeOptions, ErrorCode, Resources};
use texatlas::mesh::TriangleMesh;

fuzz_target!(|data: &[u8]| {
    let limits = DecodeLimits {
        max_triangles: Some(1 << 16),
        ..DecodeLimits::default()
    };
    let asset = match decode(data, &Resources::new(), &limits) {
        Ok(asset) => asset,
        Err(e) => {
            assert_ne!(e.code, ErrorCode::Internal, "{e}");
            return;
        }
    };
    let input = asset.mesh_input();
    if TriangleMesh::build(input).is_err() {
        return;
    }
    let uvs: Vec<[[f32; 2]; 3]> = (0..input.triangles.len())
        .map(|f| {
            let x = (f % 7) as f32 / 8.0;
            [[x, 0.0], [x + 0.1, 0.0], [x, 0.1]]
        })
        .collect();
    let out = encode(&asset, &uvs, &EncodeOptions::default()).expect("a decoded asset encodes");
    decode(&out.bytes, &Resources::new(), &limits).expect("encoded output decodes");
});
