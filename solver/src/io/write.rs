//! Atomic file writing: Wavefront OBJ meshes and any byte buffer.
//!
//! Every writer goes through [`write_atomic`]: the bytes go to a temporary file in the same
//! folder (`NAME.EXT.tmpPID-N`), which is flushed to disk (`fsync`) and then renamed over the
//! target, so a reader never sees a half-written file and a crash leaves the old file intact.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use thiserror::Error;

/// Why a file could not be written. Display is one line naming the file.
#[derive(Debug, Error)]
pub enum SaveError {
    /// The operating system refused (folder missing, permission, disk full, ...).
    #[error("{file}: cannot write: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    /// A coordinate is NaN or infinite: such values are never written to a file.
    #[error("{file}: vertex {vertex} has a non-finite coordinate ({value}); nothing was written")]
    NonFinite { file: String, vertex: usize, value: f64 },
    /// A triangle refers to a vertex that does not exist.
    #[error(
        "{file}: triangle {face} refers to vertex {index}, but there are only {n_vertices} vertices; nothing was written"
    )]
    IndexOutOfRange { file: String, face: usize, index: u32, n_vertices: usize },
    /// The inputs do not fit together (a count, an attribute's or a material's index, the
    /// parts' ranges), so the file would be wrong.
    #[error("{file}: {what}; nothing was written")]
    Inconsistent { file: String, what: String },
}

/// Writes a triangle mesh as Wavefront OBJ, atomically.
///
/// Inputs: `positions` `#V×3 f64` (finite), `triangles` `#F×3 u32` (0-based indices into
/// `positions`). Output: `v x y z` lines with full `f64` precision (Rust's shortest
/// round-tripping `{}` formatting, so reading the file back gives bit-identical coordinates),
/// then `f i j k` lines with 1-based indices, no normals or texture coordinates.
///
/// Errors: [`SaveError::NonFinite`] or [`SaveError::IndexOutOfRange`] before anything touches the
/// disk; [`SaveError::Io`] when the folder is missing or not writable.
pub fn write_obj(
    path: &Path,
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> Result<(), SaveError> {
    check_mesh(path, positions, triangles)?;
    let mut text = String::with_capacity(40 * positions.len() + 24 * triangles.len());
    for p in positions {
        // Writing into a String cannot fail.
        let _ = writeln!(text, "v {} {} {}", p[0], p[1], p[2]);
    }
    for t in triangles {
        let _ = writeln!(text, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    write_atomic(path, text.as_bytes())
}

/// The checks every mesh writer makes before it touches the disk: finite coordinates
/// ([`SaveError::NonFinite`]) and triangle indices in range ([`SaveError::IndexOutOfRange`]).
pub(crate) fn check_mesh(
    path: &Path,
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> Result<(), SaveError> {
    let file = || path.display().to_string();
    for (vertex, p) in positions.iter().enumerate() {
        if let Some(&value) = p.iter().find(|c| !c.is_finite()) {
            return Err(SaveError::NonFinite { file: file(), vertex, value });
        }
    }
    let n_vertices = positions.len();
    for (face, t) in triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= n_vertices) {
            return Err(SaveError::IndexOutOfRange { file: file(), face, index, n_vertices });
        }
    }
    Ok(())
}

/// Writes `bytes` to `path` atomically: temporary file in the same folder, `fsync`, rename.
/// A symbolic link at `path` stays a link: the file it leads to is the one replaced (a loop of
/// links is an error). A file replaced keeps its mode bits (not its owner or group: the new
/// file is the writer's).
///
/// Known limitation: on failure after the rename started, the operating system decides; the
/// temporary file is removed on every error path this function sees.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), SaveError> {
    let file = path.display().to_string();
    let io_err = |source| SaveError::Io { file: file.clone(), source };
    let target = link_target(path).map_err(io_err)?;
    let path = target.as_path();
    let permissions = std::fs::metadata(path).ok().map(|m| m.permissions());
    let ext = path.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_default();
    // Unique per process and per call, so that two threads saving the same file never share
    // a temporary file.
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = path.with_extension(format!("{ext}.tmp{}-{n}", std::process::id()));
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        if let Some(p) = permissions {
            f.set_permissions(p)?;
        }
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)?;
        Ok(())
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(io_err(e));
    }
    // Make the rename itself durable; best effort (not every platform can open a folder).
    if let Some(dir) = path.parent() {
        let dir = if dir.as_os_str().is_empty() { Path::new(".") } else { dir };
        if let Ok(d) = std::fs::File::open(dir) {
            let _ = d.sync_all();
        }
    }
    Ok(())
}

/// Where the symbolic links at `path` lead (`path` itself when it is no link): the file a
/// write through `path` replaces. A link that cannot be read stops where it is; a chain longer
/// than the kernel follows (40 links: a loop) is an error, as opening it would be.
fn link_target(path: &Path) -> std::io::Result<std::path::PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..=40 {
        let is_link = std::fs::symlink_metadata(&p).is_ok_and(|m| m.file_type().is_symlink());
        let Some(next) = is_link.then(|| std::fs::read_link(&p).ok()).flatten() else {
            return Ok(p);
        };
        // a relative link is relative to the folder holding it
        p = p.parent().map_or(next.clone(), |dir| dir.join(&next));
    }
    Err(std::io::Error::other("too many levels of symbolic links"))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn temp_path(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("solver-write-{}-{name}", std::process::id()))
    }

    /// A write killed halfway (SIGKILL, no chance to clean up) leaves the previous file intact.
    ///
    /// The test re-runs its own binary as a child that writes 256 MB with [`write_atomic`];
    /// the parent waits until the child's temporary file is partly written, kills the child,
    /// and checks the target still holds its previous bytes.
    #[test]
    fn a_write_killed_halfway_keeps_the_previous_file() {
        const CHILD: &str = "SOLVER_WRITE_ATOMIC_CHILD";
        const SIZE: usize = 256 << 20;
        if let Some(target) = std::env::var_os(CHILD) {
            let bytes = vec![7u8; SIZE];
            write_atomic(Path::new(&target), &bytes).unwrap();
            return;
        }
        let dir = temp_path("killed");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("scene.json");
        let previous = b"{\"version\": 1, \"the\": \"previous contents\"}\n";
        std::fs::write(&target, previous).unwrap();

        let exe = std::env::current_exe().unwrap();
        let mut child = std::process::Command::new(exe)
            .args(["--exact", "io::write::tests::a_write_killed_halfway_keeps_the_previous_file"])
            .args(["--test-threads", "1"])
            .env(CHILD, &target)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let start = std::time::Instant::now();
        let partial = loop {
            let tmp = std::fs::read_dir(&dir)
                .unwrap()
                .flatten()
                .map(|e| e.path())
                .find(|p| p.to_string_lossy().contains(".tmp"));
            if let Some(tmp) = tmp
                && let Ok(m) = std::fs::metadata(&tmp)
                && m.len() > 0
                && (m.len() as usize) < SIZE
            {
                child.kill().unwrap();
                break tmp;
            }
            if let Ok(Some(status)) = child.try_wait() {
                panic!("the child finished ({status}) before it could be interrupted");
            }
            assert!(start.elapsed().as_secs() < 60, "the child never started writing");
            std::thread::sleep(std::time::Duration::from_micros(200));
        };
        child.wait().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), previous, "the previous file was damaged");
        let left = std::fs::metadata(&partial).map_or(0, |m| m.len()) as usize;
        assert!(left < SIZE, "the temporary file is complete: the kill came too late");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A save through a symbolic link replaces the file it leads to and keeps the link (it
    /// replaced the link with a file, and the linked file kept its old contents); the file
    /// keeps its permissions; a loop of links is an error.
    #[cfg(unix)]
    #[test]
    fn a_write_through_a_link_keeps_the_link_and_the_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let dir = temp_path("link");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("real")).unwrap();
        let real = dir.join("real/scene.json");
        std::fs::write(&real, b"old").unwrap();
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o640)).unwrap();
        let link = dir.join("scene.json");
        std::os::unix::fs::symlink("real/scene.json", &link).unwrap();
        let chained = dir.join("again.json");
        std::os::unix::fs::symlink(&link, &chained).unwrap();

        write_atomic(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        write_atomic(&chained, b"newer").unwrap();
        assert!(std::fs::symlink_metadata(&chained).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"newer");
        let mode = std::fs::metadata(&real).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640, "permissions {mode:o}");
        // A loop of links is refused, each link kept.
        let (a, b) = (dir.join("a.json"), dir.join("b.json"));
        std::os::unix::fs::symlink("b.json", &a).unwrap();
        std::os::unix::fs::symlink("a.json", &b).unwrap();
        let err = write_atomic(&a, b"x").unwrap_err().to_string();
        assert!(err.contains("symbolic links"), "{err}");
        for l in [&a, &b] {
            assert!(std::fs::symlink_metadata(l).unwrap().file_type().is_symlink());
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn obj_is_exact_and_one_based() {
        let p =
            vec![[0.1, -2.5e-300, 1.0 / 3.0], [1e300, 0.0, -0.0], [f64::MIN_POSITIVE, 7.0, 8.0]];
        let path = temp_path("exact.obj");
        write_obj(&path, &p, &[[0, 1, 2]]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let _ = std::fs::remove_file(&path);
        let mut read = Vec::new();
        for line in text.lines() {
            let mut it = line.split_whitespace();
            match it.next() {
                Some("v") => {
                    let v: Vec<f64> = it.map(|s| s.parse().unwrap()).collect();
                    read.push([v[0], v[1], v[2]]);
                }
                Some("f") => assert_eq!(line, "f 1 2 3"),
                _ => panic!("unexpected line {line}"),
            }
        }
        for (a, b) in read.iter().zip(&p) {
            for k in 0..3 {
                assert_eq!(a[k].to_bits(), b[k].to_bits());
            }
        }
    }

    #[test]
    fn refuses_bad_input_and_missing_folder() {
        let path = temp_path("bad.obj");
        let p = vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, f64::NAN, 0.0]];
        assert!(matches!(
            write_obj(&path, &p, &[[0, 1, 2]]),
            Err(SaveError::NonFinite { vertex: 2, .. })
        ));
        let p = vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!(matches!(
            write_obj(&path, &p, &[[0, 1, 3]]),
            Err(SaveError::IndexOutOfRange { face: 0, index: 3, .. })
        ));
        assert!(!path.exists());
        let missing = temp_path("no-such-dir").join("x.obj");
        let err = write_obj(&missing, &p, &[[0, 1, 2]]).unwrap_err();
        assert!(matches!(err, SaveError::Io { .. }));
        assert!(err.to_string().contains("x.obj"));
    }
}
