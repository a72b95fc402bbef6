//! Test support shared by this crate's tests and benches and the app's tests: scratch
//! directories, seeded random values, the AVX2 test guard, the capped-sphere fixture.

pub mod gltf_decode;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A fresh, empty directory under the system's temporary directory, named after the tag, the
/// process and a counter (so parallel tests never share one), removed with its contents when
/// dropped (also when a test fails).
#[derive(Debug)]
pub struct ScratchDir(PathBuf);

impl ScratchDir {
    /// Creates `$TMP/bsarap-TAG-PID-N`, emptied first if a crashed run left it behind.
    pub fn new(tag: &str) -> ScratchDir {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("bsarap-{tag}-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        if let Err(e) = std::fs::create_dir_all(&dir) {
            panic!("cannot create the scratch directory {}: {e}", dir.display());
        }
        ScratchDir(dir)
    }
}

impl std::ops::Deref for ScratchDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for ScratchDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A seeded xorshift generator of uniform values in [−1, 1): the random cases of tests and
/// benches, the same sequence on every machine for a given nonzero `seed`.
pub fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// Whether this processor has AVX2, for the tests of the AVX2 builds against their portable
/// twins; where it has not, prints a line saying that the test `test` is SKIPPED, so that a run
/// on such a machine shows what it did not check (run with `--nocapture` to see it).
pub fn avx2_or_skip(test: &str) -> bool {
    avx2_token_or_skip(test).is_some()
}

/// [`avx2_or_skip`], returning the token that the AVX2 builds take.
pub(crate) fn avx2_token_or_skip(test: &str) -> Option<crate::linalg::lanes::Avx2> {
    let token = crate::linalg::lanes::Avx2::detect();
    if token.is_none() {
        eprintln!("SKIPPED {test}: this processor has no AVX2, the AVX2 build was not compared");
    }
    token
}

/// Handle labels of the capped-sphere fixture on an icosphere's `positions`: group 0 where
/// coordinate `axis` is above `cap`, group 1 where it is below `-cap`, and, with
/// `side: Some(s)`, group 2 where `x > s` among the rest; −1 (free) elsewhere.
pub fn cap_labels(positions: &[[f64; 3]], axis: usize, cap: f64, side: Option<f64>) -> Vec<i64> {
    positions
        .iter()
        .map(|p| {
            if p[axis] > cap {
                0
            } else if p[axis] < -cap {
                1
            } else if side.is_some_and(|s| p[0] > s) {
                2
            } else {
                -1
            }
        })
        .collect()
}

/// An icosphere of `level` with the handle caps of [`cap_labels`] (`axis`, `cap`, `side`).
pub fn capped_sphere(
    level: u32,
    axis: usize,
    cap: f64,
    side: Option<f64>,
) -> (crate::geometry::mesh::Mesh, crate::deform::handles::Handles) {
    let mesh = crate::geometry::shapes::icosphere(level);
    let labels = cap_labels(mesh.positions(), axis, cap, side);
    match crate::deform::handles::Handles::from_labels(&labels, mesh.n_vertices()) {
        Ok(handles) => (mesh, handles),
        Err(e) => panic!("capped-sphere fixture: {e}"),
    }
}

/// The common capped sphere: level 2 (162 vertices), group 0 at `x > 0.8`, group 1 at
/// `x < -0.8`.
pub fn sphere_with_caps() -> (crate::geometry::mesh::Mesh, crate::deform::handles::Handles) {
    capped_sphere(2, 0, 0.8, None)
}

/// A unit icosphere (level 1) with a small one (radius 0.2, level 0) resting on its top: a
/// loose part. Handle group 0 is the big sphere's bottom (`y < -0.5`), group 1 its top
/// (`y > 0.5`); the small sphere's vertices come after the big one's, from the returned index.
pub fn sphere_with_rider() -> (crate::geometry::mesh::Mesh, crate::deform::handles::Handles, usize)
{
    let big = crate::geometry::shapes::icosphere(1);
    let small = crate::geometry::shapes::icosphere(0);
    let mut p = big.positions().to_vec();
    let n = p.len();
    p.extend(small.positions().iter().map(|q| [0.2 * q[0], 1.2 + 0.2 * q[1], 0.2 * q[2]]));
    let mut t = big.triangles().to_vec();
    t.extend(small.triangles().iter().map(|f| f.map(|v| v + n as u32)));
    let labels = (0..p.len())
        .map(|v| match p[v][1] {
            _ if v >= n => None,
            y if y < -0.5 => Some(0),
            y if y > 0.5 => Some(1),
            _ => None,
        })
        .collect();
    let (Ok(mesh), Ok(handles)) = (
        crate::geometry::mesh::Mesh::new(p, t),
        crate::deform::handles::Handles::from_options(labels),
    ) else {
        panic!("sphere-with-rider fixture");
    };
    (mesh, handles, n)
}

/// A timeline of `n_frames` frames over one second in which group 0 circles about +z with
/// radius `radius`, turning with its path, and the other groups stay.
pub fn circling_timeline(radius: f64, n_frames: usize) -> crate::animation::timeline::Timeline {
    use crate::animation::timeline::{CircularPath, GroupPath, Path, Timeline};
    Timeline {
        duration: 1.0,
        fps: n_frames.saturating_sub(1).max(1) as f64,
        looping: false,
        paths: vec![GroupPath {
            group: 0,
            path: Path::Circular(CircularPath {
                turn_with_path: true,
                ..CircularPath::new([0.0, 0.0, 1.0], radius, 1.0)
            }),
        }],
    }
}

/// Runs the Khronos glTF validator (`node tools/gltf-validate/validate.mjs FILE`) and asserts
/// that it reports no error and no warning (its report is printed). Returns false, with a
/// printed "skipped: ...", when node or the npm package is missing, so that the caller can
/// return; panics on a finding or when the validator runs but produces no report (test code).
pub fn khronos_accepts(file: &Path) -> bool {
    khronos_accepts_with(file, &[])
}

/// [`khronos_accepts`], where the warnings whose code is in `allowed` are accepted too (each
/// caller says why).
#[allow(clippy::expect_used)]
pub fn khronos_accepts_with(file: &Path, allowed: &[&str]) -> bool {
    let tool = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tools/gltf-validate");
    if !tool.join("node_modules/gltf-validator").exists() {
        println!(
            "skipped: gltf-validator not installed (run `npm ci --prefix tools/gltf-validate`)"
        );
        return false;
    }
    let out = match std::process::Command::new("node")
        .arg(tool.join("validate.mjs"))
        .arg(file)
        .output()
    {
        Ok(o) => o,
        Err(e) => {
            println!("skipped: cannot run node: {e}");
            return false;
        }
    };
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() || !text.is_empty(),
        "validator failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_str(&text).expect("the validator prints one JSON report");
    let issues = &report["issues"];
    println!("{}: {issues}", file.display());
    assert_eq!(issues["numErrors"], 0, "{}: {report:#}", file.display());
    let messages = issues["messages"].as_array().map_or(&[][..], Vec::as_slice);
    let code = |m: &serde_json::Value| m["code"].as_str().unwrap_or_default().to_string();
    let accepted =
        messages.iter().filter(|m| m["severity"] == 1 && allowed.contains(&code(m).as_str()));
    let warnings = issues["numWarnings"].as_u64().expect("a warning count");
    assert_eq!(warnings, accepted.count() as u64, "{}: {report:#}", file.display());
    true
}
