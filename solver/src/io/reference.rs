//! References from a loaded file to other files (a glTF's buffer and image URIs, an OBJ's
//! `mtllib`, an MTL's `map_Kd`, a scene's mesh and handle files), and where they may lead.
//!
//! A downloaded asset is untrusted: a reference must not make us read a file the user did not
//! choose (an SSH key, a browser's cookie store) and carry its bytes into an export. Each
//! reference is resolved against the folder of the file that makes it, its *root*:
//!
//! - a URI scheme other than `data:` (`file:`, `http:`, ...) is refused, always;
//! - `\` is read as `/` (Windows exporters write `textures\a.png`, and `..\` must not slip
//!   past the check);
//! - the path is normalised lexically (`.` dropped, `..` cancels the name before it); it is
//!   *outside* when it is absolute (`/etc/passwd`, `C:/x`), when a `..` leaves the root, or
//!   when the file it names is a symbolic link (or lies under one) whose target is outside the
//!   root (compared after resolving links on both sides).
//!
//! What an outside reference does is the caller's rule, one per kind of reference (the module
//! docs of `gltf`, `mtl` and `crate::animation::scene` state theirs): a glTF buffer or image and
//! an OBJ's `mtllib` are refused unless [`ReferencePolicy::allow_outside`]; an MTL texture
//! and a scene's mesh or handle file are read (their bytes must decode as what they claim to
//! be) with a notice naming the file. glTF URIs are percent-decoded before they are resolved,
//! so `..%2F` is `../`.

use std::path::{Component, Path, PathBuf};

/// Where a loaded file's references may lead (see the module doc).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReferencePolicy {
    /// Read glTF buffers and images and OBJ material libraries outside the referring file's
    /// folder. Off by default: a downloaded asset cannot reach the user's other files.
    pub allow_outside: bool,
}

/// The folder a file's references are resolved against, and the policy for them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Folder<'a> {
    pub root: &'a Path,
    pub policy: ReferencePolicy,
}

/// A reference resolved to a file path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Resolved {
    /// The path to read (lexically normalised).
    pub path: PathBuf,
    /// Whether it leads outside the root (absolute, a `..` out of it, or a link out of it).
    pub outside: bool,
}

/// Resolves `reference`, written in a file in folder `from`, against `root` (`from` is `root`
/// or a folder below it, e.g. an MTL file's folder).
///
/// Errors (one line, naming the reference): an empty reference, a URI scheme (`file:`,
/// `http:`; `data:` URIs are the caller's to decode before).
pub(crate) fn resolve(root: &Path, from: &Path, reference: &str) -> Result<Resolved, String> {
    if reference.trim().is_empty() {
        return Err("an empty file reference".to_string());
    }
    if let Some(scheme) = scheme(reference) {
        return Err(format!("{reference}: a {scheme}: URI, which is never read"));
    }
    let text = reference.replace('\\', "/");
    let absolute = text.starts_with('/') || drive_letter(&text);
    let joined = if absolute { PathBuf::from(&text) } else { from.join(&text) };
    let path = normalize(&joined);
    let root = normalize(root);
    let outside = absolute || !path.starts_with(&root) || links_out(&root, &path);
    Ok(Resolved { path, outside })
}

/// Why the file a reference names at `path` is not read, when it exists and is neither a
/// regular file nor a folder: a named pipe blocks the open until a writer comes (forever), and
/// a device such as `/dev/zero` never ends (the read grows until memory runs out). A
/// downloaded archive can carry a pipe beside its mesh; a reference can name a device. Only
/// references are held to this: a file the user names is read as it is (a pipe there is the
/// user's own, such as a shell's `<(...)`; the editor's tests hold loads open with them).
pub fn not_regular(path: &Path) -> Option<&'static str> {
    let meta = std::fs::metadata(path).ok()?;
    (!meta.is_file() && !meta.is_dir())
        .then_some("not a regular file (a pipe, a socket or a device)")
}

/// The first `limit` bytes of the file a reference names at `path` (all of a shorter one),
/// refused when it is not a regular file ([`not_regular`]). The limit is the most the reader
/// can use (a buffer's declared length, what is left of the image budget): a reference to a
/// huge file, or a sparse one that reads as terabytes, costs no more than that.
pub(crate) fn read_file(path: &Path, limit: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    if let Some(why) = not_regular(path) {
        return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, why));
    }
    let mut out = Vec::new();
    std::fs::File::open(path)?.take(limit).read_to_end(&mut out)?;
    Ok(out)
}

/// The scheme of a URI (`file` of `file:///etc/passwd`): letters, digits, `+`, `-`, `.`
/// after a first letter, then `:`. One letter is a Windows drive (`C:`), not a scheme.
fn scheme(reference: &str) -> Option<&str> {
    let (head, _) = reference.split_once(':')?;
    let mut chars = head.chars();
    let first = chars.next()?;
    let ok = first.is_ascii_alphabetic()
        && head.len() > 1
        && chars.all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'));
    ok.then_some(head)
}

/// `C:/...` or `C:` alone.
fn drive_letter(text: &str) -> bool {
    let b = text.as_bytes();
    b.len() >= 2 && b[0].is_ascii_alphabetic() && b[1] == b':'
}

/// `path` made absolute (against the working directory) with `.` dropped and each `..`
/// cancelling the name before it; no file system access.
fn normalize(path: &Path) -> PathBuf {
    // The folder of a file named without one (`load_mesh("m.gltf")`) is the empty path.
    let path = if path.as_os_str().is_empty() { Path::new(".") } else { path };
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut out = PathBuf::new();
    for c in absolute.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

/// Whether `path` (under `root` lexically) lands outside `root` once symbolic links are
/// resolved on both sides. A path that does not exist (yet) is judged by its nearest existing
/// ancestor, so a link to a folder outside is caught even when the file is missing.
fn links_out(root: &Path, path: &Path) -> bool {
    let Ok(real_root) = root.canonicalize() else { return false };
    let mut probe = path;
    loop {
        if let Ok(real) = probe.canonicalize() {
            return !real.starts_with(&real_root);
        }
        match probe.parent() {
            Some(parent) if parent.starts_with(root) => probe = parent,
            _ => return false,
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::testing::ScratchDir;

    fn outside(root: &Path, reference: &str) -> bool {
        resolve(root, root, reference).unwrap().outside
    }

    #[test]
    fn inside_and_outside_lexically() {
        let root = Path::new("/data/assets/robot");
        assert!(!outside(root, "tex/a.png"));
        assert!(!outside(root, "./tex/../a.bin"));
        assert!(!outside(root, "tex\\a.png"));
        assert!(outside(root, "../../../../etc/passwd"));
        assert!(outside(root, "..\\..\\secret.bin"));
        assert!(outside(root, "tex/../../robot2/a.bin"), "a sibling folder is outside");
        assert!(outside(root, "/etc/passwd"));
        assert!(outside(root, "C:/Windows/win.ini"));
        assert!(outside(root, "c:\\x.png"));
        assert_eq!(
            resolve(root, root, "tex/./a.png").unwrap().path,
            Path::new("/data/assets/robot/tex/a.png")
        );
        // From a subfolder (an MTL file's): `..` back to the root is still inside.
        let sub = root.join("materials");
        assert!(!resolve(root, &sub, "../tex/a.png").unwrap().outside);
        assert!(resolve(root, &sub, "../../a.png").unwrap().outside);
    }

    /// At most the limit is read: a referenced file larger than the reader can use (a sparse
    /// one reads as terabytes) costs no more.
    #[test]
    fn a_file_is_read_up_to_the_limit() {
        let dir = crate::testing::ScratchDir::new("read-limit");
        let path = dir.join("big.bin");
        std::fs::write(&path, vec![7u8; 1000]).unwrap();
        assert_eq!(read_file(&path, 10).unwrap(), vec![7u8; 10]);
        assert_eq!(read_file(&path, 5000).unwrap().len(), 1000);
    }

    #[test]
    fn relative_roots_are_made_absolute() {
        assert!(!outside(Path::new(""), "a.bin"));
        assert!(outside(Path::new(""), "../a.bin"));
        assert!(outside(Path::new("assets"), "../Cargo.toml"));
    }

    #[test]
    fn schemes_and_empty_references_are_refused() {
        let root = Path::new("/a");
        for r in ["file:///etc/passwd", "http://example.com/x.png", "FILE:x", "smb+x://h/y"] {
            let e = resolve(root, root, r).unwrap_err();
            assert!(e.contains(r) && e.contains("URI"), "{e}");
        }
        assert!(resolve(root, root, " ").is_err());
        assert_eq!(scheme("C:/x"), None);
        assert_eq!(scheme("a b:c"), None);
        assert_eq!(scheme("x.png"), None);
    }

    #[cfg(unix)]
    #[test]
    fn symbolic_links_out_of_the_folder_are_outside() {
        let dir = ScratchDir::new("reference-links");
        let root = dir.join("asset");
        let elsewhere = dir.join("private");
        std::fs::create_dir_all(&root).unwrap();
        std::fs::create_dir_all(&elsewhere).unwrap();
        std::fs::write(elsewhere.join("key"), b"secret").unwrap();
        std::fs::write(root.join("ok.bin"), b"data").unwrap();
        std::os::unix::fs::symlink(elsewhere.join("key"), root.join("texture.png")).unwrap();
        std::os::unix::fs::symlink(&elsewhere, root.join("textures")).unwrap();
        std::os::unix::fs::symlink(root.join("ok.bin"), root.join("alias.bin")).unwrap();
        assert!(outside(&root, "texture.png"), "a link to a file outside");
        assert!(outside(&root, "textures/key"), "a file under a link to a folder outside");
        assert!(outside(&root, "textures/missing.png"), "even when the file is missing");
        assert!(!outside(&root, "alias.bin"), "a link that stays inside");
        assert!(!outside(&root, "missing.bin"));
    }
}
