//! File dialogs. The system's dialog (rfd: the desktop portal, else zenity) runs on a worker
//! thread; the editor's own browser (`egui_file`, drawn in the UI) stands in when the system's
//! cannot be shown, and always when the preference "always use the in-app file dialog" is on.
//!
//! rfd answers `None` both for a cancel and for a dialog that could not be shown, so a failure
//! is told apart two ways: before asking, a Linux session with neither a D-Bus session bus (for
//! the portal) nor `zenity` on the `PATH` cannot show one; after asking, a `None` sooner than
//! [`NATIVE_FAILED_WITHIN`] was not a person's cancel. Either way the status says so and the
//! in-app browser opens: a failed dialog is never taken as a cancel.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, TryRecvError};
use std::time::{Duration, Instant};

use eframe::egui;

use super::{DialogKind, EditorApp, file_name};
use crate::editor::loader;

/// A system dialog that answers nothing sooner than this after it was asked for did not show:
/// no one cancels a file dialog that fast.
const NATIVE_FAILED_WITHIN: Duration = Duration::from_millis(400);

/// The dialog in progress, if any.
#[derive(Default)]
pub(super) struct Dialogs {
    /// The system's dialog, on its thread, and when it was asked for.
    native: Option<(DialogKind, Receiver<Option<PathBuf>>, Instant)>,
    /// The in-app browser.
    in_app: Option<(DialogKind, egui_file::FileDialog)>,
    /// The open mesh's version (`Topology::version`) when the dialog was asked for: a file
    /// chosen for that mesh does nothing to another opened meanwhile.
    for_mesh: Option<u64>,
    /// A file the in-app browser chose to save over, asked about before it is written: the
    /// browser saves on Enter without asking (the system's dialogs ask themselves).
    replace: Option<(DialogKind, PathBuf)>,
}

impl DialogKind {
    /// Whether the file chosen acts on the open mesh or document (everything but an open).
    fn acts_on_open_mesh(self) -> bool {
        !matches!(self, DialogKind::OpenMesh | DialogKind::OpenScene)
    }

    fn saves(self) -> bool {
        matches!(self, DialogKind::SaveScene | DialogKind::ExportGltf | DialogKind::SaveSelection)
    }

    fn title(self) -> &'static str {
        match self {
            DialogKind::OpenMesh => "Open mesh or scene",
            DialogKind::OpenScene => "Open scene",
            DialogKind::SaveScene => "Save scene",
            DialogKind::ExportGltf => "Export glTF",
            DialogKind::LoadSelection => "Load selection",
            DialogKind::SaveSelection => "Save selection",
            DialogKind::LoadTexture => "Load texture",
        }
    }

    /// The file types offered, as (name, extensions).
    fn filters(self) -> &'static [(&'static str, &'static [&'static str])] {
        match self {
            DialogKind::OpenMesh => {
                &[("Meshes and scenes", &["obj", "off", "ply", "stl", "glb", "gltf", "json"])]
            }
            DialogKind::OpenScene | DialogKind::SaveScene => &[("Scene", &["json"])],
            DialogKind::ExportGltf => &[
                ("glTF binary", &["glb"]),
                ("glTF JSON", &["gltf"]),
                ("PC2 point cache (Blender Mesh Cache, 3ds Max)", &["pc2"]),
            ],
            DialogKind::LoadSelection => &[("Selections", &["dmat", "json"])],
            DialogKind::SaveSelection => &[("libigl dmat", &["dmat"])],
            DialogKind::LoadTexture => &[("PNG or JPEG image", &["png", "jpg", "jpeg"])],
        }
    }

    fn default_name(self) -> Option<&'static str> {
        match self {
            DialogKind::SaveScene => Some("scene.json"),
            DialogKind::ExportGltf => Some("animation.glb"),
            DialogKind::SaveSelection => Some("selection.dmat"),
            _ => None,
        }
    }

    /// Whether `path` has one of the offered extensions (the in-app browser's list filter).
    fn accepts(self, path: &Path) -> bool {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        ext.is_some_and(|e| self.filters().iter().any(|(_, exts)| exts.contains(&e.as_str())))
    }
}

/// Why the system's dialog cannot be shown here, found without asking it; `None` when it may.
fn native_unavailable() -> Option<&'static str> {
    if !cfg!(target_os = "linux") {
        return None;
    }
    let set = |k: &str| std::env::var_os(k).is_some_and(|v| !v.is_empty());
    let bus = set("DBUS_SESSION_BUS_ADDRESS")
        || std::env::var_os("XDG_RUNTIME_DIR").is_some_and(|d| Path::new(&d).join("bus").exists());
    let zenity = std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("zenity").is_file()));
    (!bus && !zenity).then_some("no D-Bus session for a desktop portal and no zenity")
}

/// A name beside the scene file `scene` for the restored work: `NAME-restored.json`, or
/// `NAME-restored-2.json`, ... when taken. Not the scene's own name: the in-app browser saves
/// on Enter without asking before writing over a file, and the scene is the newer work.
fn restored_name(scene: &Path) -> String {
    let stem = scene.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let name = |i: u32| match i {
        1 => format!("{stem}-restored.json"),
        i => format!("{stem}-restored-{i}.json"),
    };
    (1..1000).map(name).find(|n| !scene.with_file_name(n).exists()).unwrap_or_else(|| name(1))
}

impl EditorApp {
    /// Asks for a file for `kind`: the system's dialog, or the in-app browser (see the module
    /// doc). Returns whether it was shown: not while another is open (the user is told).
    pub(super) fn start_dialog(&mut self, ctx: &egui::Context, kind: DialogKind) -> bool {
        if self.file_dialog_open() {
            // info: an error stayed after the dialog had closed
            self.info = Some(format!("{}: a file dialog is open, finish it first", kind.title()));
            return false;
        }
        self.jobs.dialogs.for_mesh = self.session.scene.as_ref().map(|s| s.topology.version);
        if self.prefs.current.in_app_file_dialog {
            self.open_in_app_dialog(kind);
            return true;
        }
        if let Some(why) = native_unavailable() {
            self.native_dialog_failed(kind, why);
            return true;
        }
        let (tx, rx) = std::sync::mpsc::channel();
        let c = ctx.clone();
        let (start, name) = self.dialog_start(kind);
        let spawned = std::thread::Builder::new().name("file-dialog".into()).spawn(move || {
            let mut d = rfd::FileDialog::new().set_title(kind.title());
            if let Some(dir) = start {
                d = d.set_directory(dir);
            }
            for (name, exts) in kind.filters() {
                d = d.add_filter(*name, exts);
            }
            if let Some(n) = name {
                d = d.set_file_name(n);
            }
            let r = if kind.saves() { d.save_file() } else { d.pick_file() };
            let _ = tx.send(r);
            c.request_repaint();
        });
        match spawned {
            Ok(_) => self.jobs.dialogs.native = Some((kind, rx, Instant::now())),
            Err(e) => self.native_dialog_failed(kind, &format!("no thread for it: {e}")),
        }
        true
    }

    /// Says why the system's dialog did not show, and opens the in-app browser instead.
    fn native_dialog_failed(&mut self, kind: DialogKind, why: &str) {
        self.info = Some(format!(
            "The system file dialog could not be shown ({why}); using the in-app file browser. \
             Preferences → \"always use the in-app file dialog\" skips the system's."
        ));
        self.open_in_app_dialog(kind);
    }

    /// Where a dialog for `kind` starts, and the file name it proposes: the scene's folder,
    /// else the mesh's, else the working folder. A Save of restored work whose scene file
    /// changed on disk starts beside that file with a new name ([`restored_name`]).
    fn dialog_start(&self, kind: DialogKind) -> (Option<PathBuf>, Option<String>) {
        let doc = self.session.document_path.as_deref();
        let elsewhere = self.session.changed_on_disk.as_deref().filter(|_| doc.is_none());
        let elsewhere = elsewhere.filter(|_| kind == DialogKind::SaveScene);
        let mesh = self.session.scene.as_ref().map(|s| s.path.as_path());
        let folder = (elsewhere.or(doc).or(mesh))
            .and_then(Path::parent)
            .filter(|d| d.is_dir())
            .map(Path::to_path_buf)
            .or_else(|| std::env::current_dir().ok());
        let own = elsewhere.map(restored_name);
        (folder, own.or_else(|| kind.default_name().map(str::to_owned)))
    }

    fn open_in_app_dialog(&mut self, kind: DialogKind) {
        let mut d = if kind.saves() {
            egui_file::FileDialog::save_file()
        } else {
            egui_file::FileDialog::open_file()
        };
        d = d
            .title(kind.title())
            .default_size([560.0, 420.0])
            .anchor(egui::Align2::CENTER_CENTER, egui::Vec2::ZERO)
            .show_files_filter(Box::new(move |p: &Path| kind.accepts(p)));
        let (folder, name) = self.dialog_start(kind);
        if let Some(dir) = folder {
            d = d.initial_path(dir);
        }
        if let Some(n) = name {
            d = d.default_filename(n);
        }
        d.open();
        self.jobs.dialogs.in_app = Some((kind, d));
    }

    /// Whether a file dialog (either kind, or its question before replacing a file) is
    /// waiting for the user.
    pub fn file_dialog_open(&self) -> bool {
        let d = &self.jobs.dialogs;
        d.native.is_some() || d.in_app.is_some() || d.replace.is_some()
    }

    /// Asks whether to write over the file the in-app browser chose; goes on with the save,
    /// or cancels it.
    fn replace_question(&mut self, ctx: &egui::Context) {
        let Some((kind, path)) = self.jobs.dialogs.replace.clone() else { return };
        let folder = path.parent().map(|d| d.display().to_string()).unwrap_or_default();
        let mut answer = None;
        egui::Window::new("Replace the file?")
            .collapsible(false)
            .resizable(false)
            .anchor(egui::Align2::CENTER_CENTER, egui::Vec2::ZERO)
            .show(ctx, |ui| {
                ui.label(format!("{} already exists in {folder}. Replace it?", file_name(&path)));
                ui.horizontal(|ui| {
                    if ui.button("Replace").clicked() {
                        answer = Some(true);
                    }
                    if ui.button("Cancel").clicked() {
                        answer = Some(false);
                    }
                });
            });
        match answer {
            Some(true) => {
                self.jobs.dialogs.replace = None;
                self.dialog_chosen(ctx, kind, path, false);
            }
            Some(false) => {
                self.jobs.dialogs.replace = None;
                self.dialog_cancelled(kind);
            }
            None => {}
        }
    }

    /// Polls the system's dialog and draws the in-app one; acts on a chosen file.
    pub(super) fn poll_dialog(&mut self, ctx: &egui::Context) {
        if let Some((kind, rx, started)) = &self.jobs.dialogs.native {
            let (kind, started) = (*kind, *started);
            let answer = match rx.try_recv() {
                Err(TryRecvError::Empty) => None,
                Err(TryRecvError::Disconnected) => Some(Err("its thread stopped".to_string())),
                Ok(None) if started.elapsed() < NATIVE_FAILED_WITHIN => {
                    Some(Err("it closed at once; is a desktop portal or zenity installed?".into()))
                }
                Ok(r) => Some(Ok(r)),
            };
            match answer {
                None => {}
                Some(Err(why)) => {
                    self.jobs.dialogs.native = None;
                    self.native_dialog_failed(kind, &why);
                }
                Some(Ok(r)) => {
                    self.jobs.dialogs.native = None;
                    match r {
                        Some(path) => self.dialog_chosen(ctx, kind, path, false),
                        None => self.dialog_cancelled(kind),
                    }
                }
            }
        }
        self.replace_question(ctx);
        let Some((kind, d)) = &mut self.jobs.dialogs.in_app else { return };
        let kind = *kind;
        d.show(ctx);
        match d.state() {
            egui_file::State::Open => {}
            egui_file::State::Selected => {
                let path = d.path().map(Path::to_path_buf);
                self.jobs.dialogs.in_app = None;
                if let Some(path) = path {
                    self.dialog_chosen(ctx, kind, path, true);
                }
            }
            egui_file::State::Cancelled | egui_file::State::Closed => {
                self.jobs.dialogs.in_app = None;
                self.dialog_cancelled(kind);
            }
        }
    }

    /// Where a save chosen as `path` writes: with the extension `ext` added when it has none;
    /// refused when it has another (a scene typed as `creature.obj` wrote JSON over the mesh),
    /// or is a file the document was read from but its own scene (and a `.dmat` selection), a
    /// loaded texture or the autosave.
    fn save_path(&self, path: &Path, ext: &str) -> Result<PathBuf, String> {
        let path = if path.extension().is_none() { path.with_extension(ext) } else { path.into() };
        if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext)) {
            return Err(format!("{}: the name must end in .{ext}", path.display()));
        }
        let mut protected = self.read_files(false);
        // A selection is saved back over its own file; a scene only over itself, never over a
        // sphere list the mesh was opened with (the Save dialog lists `.json` files).
        let selection = self.session.scene.as_ref().and_then(|s| s.selection_path.as_ref());
        if let Some(p) = selection.filter(|&p| self.session.document_path.as_ref() != Some(p))
            && ext == "json"
        {
            protected.push(crate::outputs::Input::new("handle selection", p));
        }
        crate::outputs::check(std::slice::from_ref(&path), &protected)
            .map_err(|e| e.to_string())?;
        Ok(path)
    }

    /// Whether to ask before writing over `path` (a save's file, as it will be written; an
    /// error is said where the save is refused): when it exists, the question is set up. Not
    /// for the scene being edited: writing it is what Save does.
    fn ask_replace(&mut self, kind: DialogKind, path: &Result<PathBuf, String>) -> bool {
        let Ok(path) = path else { return false };
        let asks = path.is_file() && self.session.document_path.as_ref() != Some(path);
        if asks {
            self.jobs.dialogs.replace = Some((kind, path.clone()));
        }
        asks
    }

    /// A dialog closed with no file: an open or quit that waited for that Save as does not go
    /// on at a later save (one that waits for a save of this mesh being written stays).
    fn dialog_cancelled(&mut self, kind: DialogKind) {
        if kind == DialogKind::SaveScene {
            self.save_not_started();
        }
    }

    /// Acts on the file chosen in a dialog of `kind`; not, when it acts on the open mesh and
    /// another mesh was opened while the dialog was open (a load that was under way, a drop).
    /// With `ask_replace` (the in-app browser's choice), a save whose file exists asks first
    /// ([`Self::replace_question`]), once the name is known to be allowed.
    fn dialog_chosen(
        &mut self,
        ctx: &egui::Context,
        kind: DialogKind,
        path: PathBuf,
        ask_replace: bool,
    ) {
        let open = self.session.scene.as_ref().map(|s| s.topology.version);
        if kind.acts_on_open_mesh() && open != self.jobs.dialogs.for_mesh {
            self.session.after_save = None;
            let now = self.session.scene.as_ref().map(|s| file_name(&s.path));
            self.error = Some(format!(
                "{}: nothing done with {}: {} was opened while the dialog was open",
                kind.title(),
                file_name(&path),
                now.unwrap_or_else(|| "another mesh".into())
            ));
            return;
        }
        match kind {
            DialogKind::OpenMesh | DialogKind::OpenScene => self.request_open(ctx, path),
            DialogKind::LoadSelection => self.load_selection(ctx, &path),
            DialogKind::LoadTexture => self.load_texture(ctx, &path),
            DialogKind::SaveSelection => {
                let target = self.save_path(&path, "dmat");
                if ask_replace && self.ask_replace(kind, &target) {
                    return;
                }
                let written = target.and_then(|path| {
                    loader::write_dmat(&path, &self.session.edit.labels)
                        .map_err(|e| format!("{e:#}"))
                        .map(|()| path)
                });
                match written {
                    Ok(path) => self.info = Some(format!("saved {}", path.display())),
                    Err(e) => self.error = Some(format!("selection not saved: {e}")),
                }
            }
            DialogKind::SaveScene => {
                // the open or quit that waited for the save goes on once it is written
                let target = self.save_path(&path, "json");
                if ask_replace && self.ask_replace(kind, &target) {
                    return;
                }
                match target {
                    Ok(path) => self.start_save(ctx, &path),
                    Err(e) => {
                        self.save_not_started();
                        self.error = Some(format!("scene not saved: {e}"));
                    }
                }
            }
            DialogKind::ExportGltf => {
                let path =
                    if path.extension().is_none() { path.with_extension("glb") } else { path };
                // An OBJ sequence writes NAME_0001.obj, ..., not the file named.
                let sequence = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj"));
                if ask_replace && !sequence {
                    // Asked only of a file the export may write (not the open mesh, say).
                    let inputs = self.read_files(true);
                    let allowed = crate::outputs::check(std::slice::from_ref(&path), &inputs)
                        .map(|()| path.clone())
                        .map_err(|e| e.to_string());
                    if self.ask_replace(kind, &allowed) {
                        return;
                    }
                }
                self.export_gltf(ctx, path)
            }
        }
    }
}
