//! Fuzzes the scene reader (`Scene::from_json`: version check, fields, timeline, handles spec).
//! A scene it accepts must survive a round trip through the writer.
#![no_main]

use libfuzzer_sys::fuzz_target;
use solver::scene::Scene;

fuzz_target!(|bytes: &[u8]| {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    if let Ok(scene) = Scene::from_json(text, "fuzz") {
        let written = scene.to_json();
        if let Err(e) = Scene::from_json(&written, "fuzz-rewritten") {
            panic!("an accepted scene does not read back: {e}\n{written}");
        }
    }
});
