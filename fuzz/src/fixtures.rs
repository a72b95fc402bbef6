//! The files the folder targets (`gltf_folder`, `obj_folder`, `scene_folder`) load beside
//! their input and the files outside that no input may carry: all in this process's temporary
//! folder (`scratch`), made once.
//!
//! ```text
//! ROOT/private/   secret.png  (SECRET: not an image)    real.png  (a real 2×1 image)
//!                 tet.bin     (the tetrahedron ×1000)   far.off   (the tetrahedron ×1000)
//!                 far.dmat    (labels for it)           outside.mtl (material OUTSIDE_MATERIAL)
//! ROOT/asset/     gltf_folder's inputs, tet.bin, skin.png, link.png, outside/ (as below)
//! ROOT/KIND-N/    one per thread and folder target: the target's input files, and
//!                 skin.png (a real 1×1 image), skin.mtl (material `skin`, textured with it),
//!                 tet.off (the unit tetrahedron), link.png (a link to private/secret.png),
//!                 outside/ (a link to private/)
//! ```

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Bytes of the file outside the folder that no image may hold.
pub const SECRET: &[u8] = b"-----BEGIN OPENSSH PRIVATE KEY----- fuzz secret";

/// The buffer and mesh outside the folder hold the tetrahedron scaled by this.
pub const OUTSIDE_SCALE: f32 = 1000.0;

/// The material `private/outside.mtl` defines: no load may have it (an `mtllib` outside the
/// OBJ's folder is never read).
pub const OUTSIDE_MATERIAL: &str = "outside_library";

/// The fixture folders of this process (see the module doc).
pub struct ReferenceFolder {
    /// `ROOT/asset`: where `gltf_folder` writes its input.
    pub asset: PathBuf,
    /// `ROOT/private`: the files outside every input's folder.
    pub private: PathBuf,
    /// The bytes of `private/real.png`.
    pub outside_png: Vec<u8>,
}

impl ReferenceFolder {
    /// The folders, made on the first call. Panics when they cannot be made.
    pub fn get() -> &'static ReferenceFolder {
        static FOLDER: OnceLock<ReferenceFolder> = OnceLock::new();
        FOLDER.get_or_init(|| {
            let root = crate::scratch::root();
            let (asset, private) = (root.join("asset"), root.join("private"));
            let made = (|| -> std::io::Result<Vec<u8>> {
                std::fs::create_dir_all(&private)?;
                std::fs::write(private.join("tet.bin"), tet_bin(OUTSIDE_SCALE))?;
                std::fs::write(private.join("far.off"), tet_off(OUTSIDE_SCALE))?;
                std::fs::write(private.join("far.dmat"), "1 4\n0\n-1\n-1\n1\n")?;
                let mtl = format!("newmtl {OUTSIDE_MATERIAL}\nKd 0 1 0\nmap_Kd real.png\n");
                std::fs::write(private.join("outside.mtl"), mtl)?;
                let outside_png = png(2);
                std::fs::write(private.join("real.png"), &outside_png)?;
                std::fs::write(private.join("secret.png"), SECRET)?;
                beside(&asset, &private)?;
                std::fs::write(asset.join("tet.bin"), tet_bin(1.0))?;
                Ok(outside_png)
            })();
            let outside_png = made.unwrap_or_else(|e| panic!("{}: {e}", root.display()));
            ReferenceFolder { asset, private, outside_png }
        })
    }

    /// This thread's folder for target `kind` (`ROOT/KIND-N`, with the files the module doc
    /// lists), made on the thread's first call: the replay and libFuzzer may run bodies on
    /// several threads, and a target's input files have fixed names.
    pub fn thread_folder(&self, kind: &str) -> PathBuf {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        thread_local! {
            static FOLDERS: RefCell<HashMap<String, PathBuf>> = RefCell::new(HashMap::new());
        }
        FOLDERS.with_borrow_mut(|folders| {
            folders
                .entry(kind.to_string())
                .or_insert_with(|| {
                    let dir = crate::scratch::root()
                        .join(format!("{kind}-{}", NEXT.fetch_add(1, Ordering::Relaxed)));
                    let made = beside(&dir, &self.private).and_then(|()| {
                        std::fs::write(dir.join("tet.off"), tet_off(1.0))?;
                        std::fs::write(dir.join("skin.mtl"), "newmtl skin\nmap_Kd skin.png\n")
                    });
                    made.unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
                    dir
                })
                .clone()
        })
    }
}

/// Makes folder `dir` with `skin.png` (a real 1×1 image) and, on Unix, `link.png` (a link to
/// `private/secret.png`) and `outside/` (a link to `private/`).
fn beside(dir: &Path, private: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    std::fs::write(dir.join("skin.png"), png(1))?;
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(private.join("secret.png"), dir.join("link.png"))?;
        std::os::unix::fs::symlink(private, dir.join("outside"))?;
    }
    #[cfg(not(unix))]
    let _ = private;
    Ok(())
}

/// The unit tetrahedron's corners and its triangles (outward).
const TET: ([[f32; 3]; 4], [u32; 12]) = (
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    [0, 2, 1, 0, 1, 3, 1, 2, 3, 2, 0, 3],
);

/// A tetrahedron's buffer: 4 positions (f32, times `scale`) then 12 indices (u32).
pub fn tet_bin(scale: f32) -> Vec<u8> {
    let (p, t) = TET;
    let mut out: Vec<u8> = p.iter().flatten().flat_map(|c| (c * scale).to_le_bytes()).collect();
    out.extend(t.iter().flat_map(|i| i.to_le_bytes()));
    out
}

/// A tetrahedron as an OFF file, its positions times `scale`.
pub fn tet_off(scale: f32) -> String {
    let (p, t) = TET;
    let mut out = String::from("OFF\n4 4 0\n");
    for [x, y, z] in p {
        out += &format!("{} {} {}\n", x * scale, y * scale, z * scale);
    }
    for f in t.chunks(3) {
        out += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
    }
    out
}

/// A real `w`×1 PNG.
pub fn png(w: u32) -> Vec<u8> {
    let img = image::RgbImage::from_pixel(w, 1, image::Rgb([200, 30, 90]));
    let mut out = std::io::Cursor::new(Vec::new());
    // Encoding into memory cannot fail; an empty file would only make `skin.png` refused.
    let _ = img.write_to(&mut out, image::ImageFormat::Png);
    out.into_inner()
}
