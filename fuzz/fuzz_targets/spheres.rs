//! Fuzzes the sphere-selection reader against a fixed mesh (an icosphere of 42 vertices, plus
//! the same positions scaled by 1e300 to reach overflowing distances).
#![no_main]

use libfuzzer_sys::fuzz_target;
use solver::selection::parse_spheres;

fuzz_target!(|bytes: &[u8]| {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    let mesh = solver::shapes::icosphere(1);
    let mut positions = mesh.positions().to_vec();
    positions.extend(mesh.positions().iter().map(|p| p.map(|c| c * 1e300)));
    let _ = parse_spheres(text, &positions);
});
