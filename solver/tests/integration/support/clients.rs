//! Shared by the tests with real clients (clients.rs, clients_asset.rs): finding and running
//! Blender's `bpy` (tools/blender) and the three.js checker (tools/threejs-check), and comparing
//! what they report with our frames. Skip rules: see clients.rs's doc.
#![allow(clippy::unwrap_used)]

use std::path::{Path as FsPath, PathBuf};
use std::process::Command;

use serde_json::Value;

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A tool that is installed but does not run: an error under CI (.ci/run installed it), a
/// skip note elsewhere. Returns `None` for the caller to return.
pub fn broken_tool<T>(what: &str) -> Option<T> {
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("{what} (installed by .ci/run, so this is an error under CI=true)");
    }
    println!("skipped: {what}");
    None
}

/// The Python of the venv that has `bpy` (tools/blender/.venv, or $BSARAP_BPY_PYTHON), checked
/// to import it; `None` with a printed note when it is missing or broken.
pub fn blender_python() -> Option<PathBuf> {
    let python = std::env::var_os("BSARAP_BPY_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("tools/blender/.venv/bin/python"));
    if !python.exists() {
        println!(
            "skipped: Blender's bpy not installed ({} missing; .ci/run installs it)",
            python.display()
        );
        return None;
    }
    match Command::new(&python).args(["-c", "import bpy"]).output() {
        Ok(o) if o.status.success() => Some(python),
        Ok(o) => broken_tool(&format!(
            "`import bpy` fails in {}: {}",
            python.display(),
            String::from_utf8_lossy(&o.stderr).trim()
        )),
        Err(e) => broken_tool(&format!("cannot run {}: {e}", python.display())),
    }
}

/// Runs a Blender script with arguments and returns the JSON object printed on its line that
/// starts with `prefix` (Blender prints its own log lines around it).
pub fn run_blender(python: &FsPath, script: &str, args: &[&FsPath], prefix: &str) -> Value {
    let out = Command::new(python)
        .arg(root().join("tools/blender").join(script))
        .args(args)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{script} failed ({}):\n{stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let line = stdout
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix(prefix))
        .unwrap_or_else(|| panic!("{script} printed no report line:\n{stdout}"));
    serde_json::from_str(line).unwrap()
}

/// Runs tools/threejs-check/check.mjs on `file` with `args`; `None` with a printed note when
/// the package, node or the browser is missing.
pub fn threejs_check(file: &FsPath, args: &[&str]) -> Option<Value> {
    let tool = root().join("tools/threejs-check");
    if !tool.join("node_modules/three").exists()
        || !tool.join("node_modules/puppeteer-core").exists()
    {
        println!(
            "skipped: three.js checker not installed (run \
             `PUPPETEER_SKIP_DOWNLOAD=1 npm ci --prefix tools/threejs-check`)"
        );
        return None;
    }
    let chromium = std::env::var_os("CHROMIUM")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/usr/bin/chromium"));
    if !chromium.exists() {
        println!("skipped: no browser at {} (Debian package chromium)", chromium.display());
        return None;
    }
    let out = match Command::new("node").arg(tool.join("check.mjs")).arg(file).args(args).output() {
        Ok(o) => o,
        Err(e) => return broken_tool(&format!("cannot run node: {e}")),
    };
    let stderr = String::from_utf8_lossy(&out.stderr);
    if out.status.code() == Some(2) && stderr.contains("cannot start the browser") {
        return broken_tool(&format!("three.js checker: {}", stderr.trim()));
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "three.js checker failed ({}):\n{stdout}\n{stderr}", out.status);
    Some(serde_json::from_str(stdout.trim()).unwrap())
}

pub fn vec3(v: &Value) -> [f64; 3] {
    let a = v.as_array().unwrap();
    assert_eq!(a.len(), 3, "{v}");
    [a[0].as_f64().unwrap(), a[1].as_f64().unwrap(), a[2].as_f64().unwrap()]
}

/// The largest coordinate difference between two bounding boxes.
pub fn bbox_change(a: &Value, b: &Value) -> f64 {
    let d = |k: &str| {
        let (p, q) = (vec3(&a[k]), vec3(&b[k]));
        (0..3).map(|i| (p[i] - q[i]).abs()).fold(0.0, f64::max)
    };
    d("min").max(d("max"))
}

/// The largest distance between a client's positions and our frame.
pub fn max_error(got: &Value, want: &[[f64; 3]]) -> f64 {
    let got = got.as_array().unwrap();
    assert_eq!(got.len(), want.len());
    got.iter()
        .zip(want)
        .map(|(g, w)| {
            let g = vec3(g);
            (0..3).map(|k| (g[k] - w[k]).abs()).fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

/// Materials a client reports: one that has a texture must have a decoded image of nonzero
/// size (checks the richer exporter's textures when it writes them; vacuous for plain output).
pub fn textures_have_pixels(materials: &Value, has: &str, size: &str) -> usize {
    let mut textured = 0;
    for m in materials.as_array().unwrap() {
        if m[has].as_bool().unwrap() {
            let s = m[size].as_array().unwrap();
            assert!(s.iter().all(|x| x.as_u64().unwrap() > 0), "empty texture image: {m}");
            textured += 1;
        }
    }
    textured
}
