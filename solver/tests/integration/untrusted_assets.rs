//! Hostile assets: a downloaded glTF or OBJ must not read files outside its folder, and no
//! bytes reach the loaded asset (and so an export) unless they decoded as what they claim to
//! be. Each case is a one-tetrahedron file written here, beside a "secret" file outside its
//! folder that must never be read into the asset.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support::gltf_files;

use std::path::{Path, PathBuf};

use base64::Engine;
use gltf_files::{tet_bin, tet_doc, to_gltf};
use serde_json::{Value, json};
use solver::animation::scene::Scene;
use solver::io::{LoadError, LoadedMesh, ReferencePolicy, load_mesh, load_mesh_with};
use solver::testing::ScratchDir;

const SECRET: &[u8] = b"-----BEGIN OPENSSH PRIVATE KEY----- do not share\n";

/// A real 2×2 PNG.
fn png() -> Vec<u8> {
    let img = image::RgbImage::from_pixel(2, 2, image::Rgb([1, 2, 3]));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// `DIR/private/` with `key` (the secret), `key.bin` (a valid buffer: the tet's bytes
/// followed by the secret) and `photo.png` (a real image); `DIR/asset/` is the asset's folder.
struct Layout {
    _dir: ScratchDir,
    asset: PathBuf,
    private: PathBuf,
}

fn layout(tag: &str) -> Layout {
    let dir = ScratchDir::new(tag);
    let asset = dir.join("asset");
    let private = dir.join("private");
    std::fs::create_dir_all(&asset).unwrap();
    std::fs::create_dir_all(&private).unwrap();
    std::fs::write(private.join("key"), SECRET).unwrap();
    let mut bin = tet_bin();
    bin.extend_from_slice(SECRET);
    std::fs::write(private.join("key.bin"), bin).unwrap();
    std::fs::write(private.join("photo.png"), png()).unwrap();
    Layout { _dir: dir, asset, private }
}

/// The tetrahedron with its buffer embedded, one material textured with an image at `uri`.
fn textured(uri: &str) -> Value {
    let mut doc: Value =
        serde_json::from_slice(&to_gltf(tet_doc(&[[0.0; 3]]), &tet_bin())).unwrap();
    doc["images"] = json!([{"uri": uri}]);
    doc["textures"] = json!([{"source": 0}]);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc
}

/// The tetrahedron whose buffer is the file at `uri`.
fn external_buffer(uri: &str) -> Value {
    let mut doc = tet_doc(&[[0.0; 3]]);
    doc["buffers"][0]["uri"] = json!(uri);
    doc
}

fn load_doc(folder: &Path, doc: &Value, policy: ReferencePolicy) -> Result<LoadedMesh, LoadError> {
    let path = folder.join("hostile.gltf");
    std::fs::write(&path, serde_json::to_vec(doc).unwrap()).unwrap();
    load_mesh_with(&path, policy)
}

fn holds_secret(m: &LoadedMesh) -> bool {
    m.asset.images.iter().any(|i| i.bytes.windows(SECRET.len()).any(|w| w == SECRET))
}

/// Image references that leave the folder: the mesh loads without the texture, a notice
/// names the URI, and the material has no texture.
#[test]
fn images_outside_the_folder_are_not_read() {
    let l = layout("untrusted-images");
    #[cfg(unix)]
    std::os::unix::fs::symlink(l.private.join("key"), l.asset.join("linked.png")).unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(&l.private, l.asset.join("textures")).unwrap();
    let key = l.private.join("key");
    let mut uris = vec![
        "../private/key".to_string(),
        "../../../../../../../../etc/passwd".to_string(),
        "/etc/passwd".to_string(),
        key.display().to_string(),
        "..%2Fprivate%2Fkey".to_string(),
        "..\\private\\key".to_string(),
        "file:///etc/passwd".to_string(),
        format!("file://{}", key.display()),
        "http://example.com/x.png".to_string(),
        // A real image outside is refused too: the rule is where, not what.
        "../private/photo.png".to_string(),
    ];
    if cfg!(unix) {
        uris.extend(["linked.png".to_string(), "textures/photo.png".to_string()]);
    }
    for uri in &uris {
        let m = load_doc(&l.asset, &textured(uri), ReferencePolicy::default())
            .unwrap_or_else(|e| panic!("{uri}: {e}"));
        assert!(m.asset.images.is_empty(), "{uri} was read");
        assert_eq!(m.asset.materials[0].base_color_texture, None, "{uri}");
        let notes = m.notices().join("\n");
        assert!(notes.contains("image 0") && notes.contains("without this texture"), "{notes}");
        assert!(notes.contains(uri.as_str()), "the notice names the URI {uri}: {notes}");
        assert!(m.asset.check().is_ok());
    }
}

/// A buffer outside the folder fails the load, naming the URI; its bytes are never parsed.
#[test]
fn buffers_outside_the_folder_fail_the_load() {
    let l = layout("untrusted-buffers");
    #[cfg(unix)]
    std::os::unix::fs::symlink(l.private.join("key.bin"), l.asset.join("mesh.bin")).unwrap();
    let mut uris = vec![
        "../private/key.bin",
        "..%2Fprivate%2Fkey.bin",
        "..\\private\\key.bin",
        "../../../../../../../../etc/passwd",
        "/etc/passwd",
        "file:///etc/passwd",
    ];
    if cfg!(unix) {
        uris.push("mesh.bin");
    }
    for uri in uris {
        let e = load_doc(&l.asset, &external_buffer(uri), ReferencePolicy::default())
            .err()
            .unwrap_or_else(|| panic!("{uri} was read"));
        assert!(matches!(e, LoadError::Unsupported { .. }), "{uri}: {e:?}");
        let text = e.to_string();
        assert!(text.contains("buffer 0") && text.contains(uri), "{text}");
    }
    // The same buffer beside the file loads; and outside, when the policy allows it.
    std::fs::copy(l.private.join("key.bin"), l.asset.join("tet.bin")).unwrap();
    assert!(load_doc(&l.asset, &external_buffer("tet.bin"), ReferencePolicy::default()).is_ok());
    let allow = ReferencePolicy { allow_outside: true };
    let m = load_doc(&l.asset, &external_buffer("../private/key.bin"), allow).unwrap();
    assert_eq!(m.mesh.n_vertices(), 4);
}

/// With the policy allowing it, an image outside is read, but only if it decodes: the
/// secret never becomes a texture whatever the policy.
#[test]
fn allowed_outside_images_must_still_decode() {
    let l = layout("untrusted-allowed");
    let allow = ReferencePolicy { allow_outside: true };
    let m = load_doc(&l.asset, &textured("../private/photo.png"), allow).unwrap();
    assert_eq!(m.asset.images.len(), 1);
    assert_eq!(m.asset.images[0].mime_type, "image/png");
    assert_eq!(m.asset.materials[0].base_color_texture.map(|t| t.image), Some(0));
    for uri in ["../private/key", "/etc/passwd"] {
        let m = load_doc(&l.asset, &textured(uri), allow).unwrap();
        assert!(m.asset.images.is_empty() && !holds_secret(&m), "{uri}");
        assert!(m.notices().join("\n").contains("not a PNG or JPEG"), "{:?}", m.notices());
    }
}

/// Inside the folder, or embedded, only bytes that decode as the declared image type are kept.
#[test]
fn embedded_and_local_images_must_decode() {
    let l = layout("untrusted-decode");
    std::fs::write(l.asset.join("notes.png"), SECRET).unwrap();
    std::fs::write(l.asset.join("real.png"), png()).unwrap();
    let b64 = |b: &[u8]| base64::engine::general_purpose::STANDARD.encode(b);
    let cases = [
        ("notes.png".to_string(), false),
        ("real.png".to_string(), true),
        (format!("data:image/png;base64,{}", b64(SECRET)), false),
        (format!("data:image/jpeg;base64,{}", b64(&png())), false),
        (format!("data:image/png;base64,{}", b64(&png())), true),
    ];
    for (uri, kept) in &cases {
        let m = load_doc(&l.asset, &textured(uri), ReferencePolicy::default()).unwrap();
        assert_eq!(m.asset.images.len(), usize::from(*kept), "{uri}: {:?}", m.notices());
        assert!(!holds_secret(&m));
    }
    // A GLB's image in a buffer view is checked the same way.
    let mut doc = tet_doc(&[[0.0; 3]]);
    let mut bin = tet_bin();
    let offset = bin.len();
    bin.extend_from_slice(SECRET);
    doc["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": SECRET.len()}));
    doc["buffers"][0]["byteLength"] = json!(bin.len());
    doc["images"] = json!([{"bufferView": 2, "mimeType": "image/png"}]);
    doc["textures"] = json!([{"source": 0}]);
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    let path = l.asset.join("view.glb");
    std::fs::write(&path, gltf_files::to_glb(&doc, &bin)).unwrap();
    let m = load_mesh(&path).unwrap();
    assert!(m.asset.images.is_empty() && !holds_secret(&m));
    assert!(m.notices().join("\n").contains("image 0 (embedded)"), "{:?}", m.notices());
}

/// An OBJ's `mtllib` outside its folder is not read; a scene's mesh outside its folder is
/// read (it must parse as a mesh) with a notice; a URI in a scene is refused.
#[test]
fn obj_and_scene_references() {
    let l = layout("untrusted-obj");
    let obj = "mtllib ../private/m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";
    std::fs::write(l.private.join("m.mtl"), "newmtl leaked\nKd 1 0 0\n").unwrap();
    std::fs::write(l.asset.join("tet.obj"), obj).unwrap();
    let m = load_mesh(&l.asset.join("tet.obj")).unwrap();
    assert!(m.asset.materials.is_empty(), "{:?}", m.asset.materials);
    assert!(m.notices().join("\n").contains("../private/m.mtl is outside"), "{:?}", m.notices());

    std::fs::write(l.private.join("tet.obj"), obj.replace("mtllib ../private/m.mtl\n", ""))
        .unwrap();
    let scene = |mesh: &str| {
        json!({"version": 2, "mesh": mesh, "handles": {"labels": [0, -1, -1, 1]},
               "timeline": {"duration": 1.0, "fps": 24, "looping": false, "paths": []}})
    };
    let path = l.asset.join("s.json");
    std::fs::write(&path, scene("../private/tet.obj").to_string()).unwrap();
    let loaded = Scene::load(&path).unwrap();
    let notes = loaded.mesh.notices().join("\n");
    assert!(notes.contains("mesh") && notes.contains("outside the scene's folder"), "{notes}");
    std::fs::write(&path, scene("file:///etc/passwd").to_string()).unwrap();
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(e.contains("file:///etc/passwd") && e.contains("URI"), "{e}");
    // A secret named as the mesh does not parse as one.
    std::fs::copy(l.private.join("key"), l.private.join("key.obj")).unwrap();
    std::fs::write(&path, scene("../private/key.obj").to_string()).unwrap();
    assert!(Scene::load(&path).is_err());
}

/// A pipe or a device named by an asset is never opened: opening a pipe waits for a writer
/// (the load hung for good), and `/dev/zero` never ends (memory ran out). Each load runs on a
/// thread so that the old behaviour fails the test instead of hanging it. A scene naming a pipe
/// as its mesh is a clear error.
#[cfg(unix)]
#[test]
fn pipes_and_devices_are_not_read() {
    use std::sync::mpsc;
    use std::time::Duration;
    let l = layout("untrusted-pipes");
    let fifo = |name: &str| {
        let path = l.asset.join(name);
        let made = std::process::Command::new("mkfifo").arg(&path).status().unwrap();
        assert!(made.success(), "mkfifo {}", path.display());
    };
    for name in ["m.mtl", "t.png", "buffer.bin", "pipe.obj", "h.dmat"] {
        fifo(name);
    }
    let in_time = |what: &str, load: Box<dyn FnOnce() -> String + Send>| {
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || tx.send(load()).unwrap());
        rx.recv_timeout(Duration::from_secs(30)).unwrap_or_else(|_| panic!("{what} hung"))
    };
    let tet = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";
    // An OBJ whose material library is a pipe; an MTL whose textures are a pipe and a device.
    std::fs::write(l.asset.join("a.obj"), format!("mtllib m.mtl\n{tet}")).unwrap();
    std::fs::write(l.asset.join("b.obj"), format!("mtllib b.mtl\nusemtl x\n{tet}")).unwrap();
    std::fs::write(l.asset.join("b.mtl"), "newmtl x\nmap_Kd t.png\nnewmtl y\nmap_Kd /dev/zero\n")
        .unwrap();
    for obj in ["a.obj", "b.obj"] {
        let path = l.asset.join(obj);
        let notes = in_time(obj, Box::new(move || load_mesh(&path).unwrap().notices().join("\n")));
        assert!(notes.contains("not a regular file"), "{obj}: {notes}");
    }
    // A glTF whose buffer is a pipe.
    let doc = serde_json::to_vec(&external_buffer("buffer.bin")).unwrap();
    std::fs::write(l.asset.join("c.gltf"), doc).unwrap();
    let path = l.asset.join("c.gltf");
    let e = in_time("gltf", Box::new(move || load_mesh(&path).unwrap_err().to_string()));
    assert!(e.contains("buffer.bin") && e.contains("not a regular file"), "{e}");
    // A scene's mesh. (A pipe the user opens is the user's: read.)
    let scene = json!({"version": 2, "mesh": "pipe.obj", "handles": {"labels": [0, -1, -1, 1]},
                       "timeline": {"duration": 1.0, "fps": 24, "looping": false, "paths": []}});
    std::fs::write(l.asset.join("s.json"), scene.to_string()).unwrap();
    let path = l.asset.join("s.json");
    let e = in_time("scene", Box::new(move || Scene::load(&path).unwrap_err().to_string()));
    assert!(e.contains("not a regular file"), "{e}");
    // A scene's handle file (an error, as any unreadable one) and texture (a notice, as any
    // texture that cannot be used).
    std::fs::write(l.asset.join("tet.obj"), tet).unwrap();
    let mut scene = scene;
    scene["mesh"] = json!("tet.obj");
    scene["handles"] = json!({"file": "h.dmat"});
    std::fs::write(l.asset.join("s.json"), scene.to_string()).unwrap();
    let path = l.asset.join("s.json");
    let e = in_time("handles", Box::new(move || Scene::load(&path).unwrap_err().to_string()));
    assert!(e.contains("h.dmat") && e.contains("not a regular file"), "{e}");
    scene["handles"] = json!({"labels": [0, -1, -1, 1]});
    scene["texture"] = json!("t.png");
    std::fs::write(l.asset.join("s.json"), scene.to_string()).unwrap();
    let path = l.asset.join("s.json");
    let notes =
        in_time("texture", Box::new(move || Scene::load(&path).unwrap().mesh.notices().join("\n")));
    assert!(notes.contains("t.png not used: not a regular file"), "{notes}");
}
