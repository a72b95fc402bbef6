//! Fuzzes the `.dmat` selection reader. The first two bytes give the mesh's vertex count
//! (0..=65535); the rest is the file's text.
#![no_main]

use libfuzzer_sys::fuzz_target;
use solver::selection::parse_dmat;

fuzz_target!(|bytes: &[u8]| {
    if bytes.len() < 2 {
        return;
    }
    let n_vertices = usize::from(u16::from_le_bytes([bytes[0], bytes[1]]));
    if let Ok(text) = std::str::from_utf8(&bytes[2..]) {
        let _ = parse_dmat(text, n_vertices);
    }
});
