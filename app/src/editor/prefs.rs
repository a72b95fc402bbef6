//! User preferences kept between sessions: UI scale, theme, the method new documents start
//! with, the brush radius, and whether file dialogs are always the editor's own. Stored as
//! `prefs.json` in the editor's configuration folder ([`super::persist`]), read at start and
//! written atomically shortly after a preference changes (and at exit).
//!
//! A missing file means the defaults. A file that cannot be read or parsed gives the defaults,
//! and a value that cannot be read (a wrong type, a newer version's choice) or is out of range
//! gives the default for that value alone; either way a one-line message names the file, which
//! the editor shows; it never panics. A write changes only the values this editor changed
//! since it read or wrote them: what it could not read, a newer version's keys and another
//! editor window's changes to other values stay in the file (a file that is not a JSON object
//! is replaced whole).

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use solver::io::write_atomic;

/// File name of the preferences in the configuration folder.
pub const FILE_NAME: &str = "prefs.json";
/// The UI scales offered (egui zoom factor).
pub const UI_SCALES: [f32; 5] = [0.8, 1.0, 1.25, 1.5, 2.0];
/// Brush radius range, as a fraction of the bounding-box diagonal (the brush slider's).
pub const BRUSH_RADIUS_RANGE: (f32, f32) = (0.002, 0.5);

/// Dark or light egui visuals.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Theme {
    #[default]
    Dark,
    Light,
}

/// What persists. Missing fields in a file take their defaults; unknown fields are ignored
/// (and kept in the file).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Preferences {
    /// egui zoom factor, 0.5 to 3 (1 = 100 %).
    pub ui_scale: f32,
    pub theme: Theme,
    /// The method the main viewport runs in a new session.
    pub default_method: solver::Method,
    /// Handle brush radius, fraction of the bounding-box diagonal ([`BRUSH_RADIUS_RANGE`]).
    pub brush_radius: f32,
    /// Always use the editor's own file browser, never the system's file dialog (which needs
    /// a desktop portal or zenity on Linux).
    pub in_app_file_dialog: bool,
}

impl Default for Preferences {
    fn default() -> Self {
        Preferences {
            ui_scale: 1.0,
            theme: Theme::Dark,
            default_method: solver::Method::BsArapCoarse,
            brush_radius: 0.05,
            in_app_file_dialog: false,
        }
    }
}

impl Preferences {
    /// Replaces out-of-range values by their defaults; the message names each one.
    pub fn sanitized(mut self) -> (Preferences, Option<String>) {
        let d = Preferences::default();
        let mut bad = Vec::new();
        if !(0.5..=3.0).contains(&self.ui_scale) {
            bad.push(format!("ui_scale {} (0.5 to 3)", self.ui_scale));
            self.ui_scale = d.ui_scale;
        }
        let (lo, hi) = BRUSH_RADIUS_RANGE;
        if !(lo..=hi).contains(&self.brush_radius) {
            bad.push(format!("brush_radius {} ({lo} to {hi})", self.brush_radius));
            self.brush_radius = d.brush_radius;
        }
        let msg =
            (!bad.is_empty()).then(|| format!("out of range, default used: {}", bad.join(", ")));
        (self, msg)
    }

    /// Parses the JSON of [`Preferences::to_json`], value by value: one that cannot be read
    /// takes its default and is named in the message, as an out-of-range one is
    /// ([`Preferences::sanitized`]). An error when the text is not a JSON object.
    pub fn from_json(text: &str) -> Result<(Preferences, Option<String>), String> {
        let value: Value = serde_json::from_str(text).map_err(|e| e.to_string())?;
        let Value::Object(file) = value else {
            return Err("not a JSON object".into());
        };
        let mut p = Preferences::default();
        let mut bad = Vec::new();
        read_field(&file, "ui_scale", &mut p.ui_scale, &mut bad);
        read_field(&file, "theme", &mut p.theme, &mut bad);
        read_field(&file, "default_method", &mut p.default_method, &mut bad);
        read_field(&file, "brush_radius", &mut p.brush_radius, &mut bad);
        read_field(&file, "in_app_file_dialog", &mut p.in_app_file_dialog, &mut bad);
        let (p, range) = p.sanitized();
        let unread = (!bad.is_empty()).then(|| format!("default used: {}", bad.join(", ")));
        let msg = match (unread, range) {
            (Some(a), Some(b)) => Some(format!("{a}; {b}")),
            (a, b) => a.or(b),
        };
        Ok((p, msg))
    }

    pub fn to_json(&self) -> String {
        // Plain numbers, strings and enums: serializing cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// The preferences in `dir`, with a message for the user when the file was bad: the
    /// defaults then stand in (the file is left alone until a preference changes).
    pub fn load(dir: &Path) -> (Preferences, Option<String>) {
        let path = dir.join(FILE_NAME);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return (Preferences::default(), None);
            }
            Err(e) => {
                let why = format!("{e}; defaults used");
                return (Preferences::default(), Some(bad_file(&path, &why)));
            }
        };
        match Preferences::from_json(&text) {
            Ok((p, msg)) => (p, msg.map(|m| bad_file(&path, &m))),
            Err(e) => {
                (Preferences::default(), Some(bad_file(&path, &format!("{e}; defaults used"))))
            }
        }
    }

    /// Writes the values that differ from `since` (what this editor last read or wrote) into
    /// `prefs.json` in `dir` (created when missing), atomically, keeping the file's other keys;
    /// the whole preferences when the file is missing or not a JSON object.
    pub fn save_changes(&self, since: &Preferences, dir: &Path) -> Result<PathBuf, String> {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let path = dir.join(FILE_NAME);
        let (Value::Object(new), Value::Object(old)) = (to_value(self), to_value(since)) else {
            return Err("preferences are not a JSON object".into());
        };
        let on_disk =
            std::fs::read_to_string(&path).ok().and_then(|t| serde_json::from_str(&t).ok());
        let file = match on_disk {
            Some(Value::Object(mut file)) => {
                for (key, value) in new {
                    if old.get(&key) != Some(&value) {
                        file.insert(key, value);
                    }
                }
                file
            }
            _ => new,
        };
        let text = serde_json::to_string_pretty(&Value::Object(file)).unwrap_or_default();
        write_atomic(&path, text.as_bytes()).map_err(|e| e.to_string())?;
        Ok(path)
    }
}

/// Plain numbers, strings and enums: cannot fail.
fn to_value(p: &Preferences) -> Value {
    serde_json::to_value(p).unwrap_or(Value::Null)
}

/// Reads `file[name]` into `slot` when present; when it cannot be read, `slot` keeps its
/// default and `bad` names the key and why.
fn read_field<T: DeserializeOwned>(
    file: &Map<String, Value>,
    name: &str,
    slot: &mut T,
    bad: &mut Vec<String>,
) {
    if let Some(v) = file.get(name) {
        match T::deserialize(v) {
            Ok(x) => *slot = x,
            Err(e) => bad.push(format!("{name} ({e})")),
        }
    }
}

fn bad_file(path: &Path, why: &str) -> String {
    format!("preferences {}: {why}", path.display())
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;
    use solver::testing::ScratchDir;

    #[test]
    fn round_trip_through_the_folder() {
        let dir = ScratchDir::new("prefs-round-trip");
        assert_eq!(Preferences::load(&dir), (Preferences::default(), None));
        let p = Preferences {
            ui_scale: 1.5,
            theme: Theme::Light,
            default_method: solver::Method::Arap,
            brush_radius: 0.1,
            in_app_file_dialog: true,
        };
        p.save_changes(&Preferences::default(), &dir.join("sub")).unwrap();
        assert_eq!(Preferences::load(&dir.join("sub")), (p, None));
        assert!(p.to_json().contains("\"light\"") && p.to_json().contains("\"arap\""));
        assert!(p.to_json().contains("\"in_app_file_dialog\": true"));
    }

    #[test]
    fn bad_files_give_defaults_and_a_message() {
        let dir = ScratchDir::new("prefs-bad");
        std::fs::write(dir.join(FILE_NAME), "{ not json").unwrap();
        let (p, msg) = Preferences::load(&dir);
        assert_eq!(p, Preferences::default());
        let msg = msg.unwrap();
        assert!(msg.contains(FILE_NAME) && msg.contains("defaults used"), "{msg}");
        // A value of a wrong type, or a newer version's choice, takes its default alone and is
        // named; a partial file keeps what it has.
        let (p, msg) = Preferences::from_json(
            r#"{"theme": "system", "ui_scale": 1.5, "brush_radius": "big"}"#,
        )
        .unwrap();
        assert_eq!((p.theme, p.ui_scale, p.brush_radius), (Theme::Dark, 1.5, 0.05));
        let msg = msg.unwrap();
        assert!(
            msg.contains("theme (unknown variant `system`") && msg.contains("brush_radius"),
            "{msg}"
        );
        assert!(Preferences::from_json("[1]").is_err());
        let (p, msg) = Preferences::from_json(r#"{"theme": "light", "extra": 1}"#).unwrap();
        assert_eq!((p.theme, p.ui_scale, msg), (Theme::Light, 1.0, None));
        // Out of range: that value is replaced and named.
        let (p, msg) = Preferences::from_json(r#"{"ui_scale": 40, "brush_radius": 0.2}"#).unwrap();
        assert_eq!((p.ui_scale, p.brush_radius), (1.0, 0.2));
        assert!(msg.unwrap().contains("ui_scale 40"));
        // A folder where the file should be: unreadable, not a panic.
        let dir2 = ScratchDir::new("prefs-dir");
        std::fs::create_dir(dir2.join(FILE_NAME)).unwrap();
        let (p, msg) = Preferences::load(&dir2);
        assert_eq!(p, Preferences::default());
        assert!(msg.is_some());
    }

    /// A write changes only what this editor changed: a value it could not read, a newer
    /// version's key and another window's change to another value stay (the whole file was
    /// written, so one brush resize reset them all).
    #[test]
    fn a_write_keeps_what_this_editor_did_not_change() {
        let dir = ScratchDir::new("prefs-merge");
        let file = dir.join(FILE_NAME);
        std::fs::write(&file, r#"{"theme": "system", "grid_visible": false, "ui_scale": 1.5}"#)
            .unwrap();
        let (read, msg) = Preferences::load(&dir);
        assert!(msg.is_some());
        // another window sets the UI scale meanwhile
        let text = std::fs::read_to_string(&file).unwrap().replace("1.5", "2.0");
        std::fs::write(&file, text).unwrap();
        let mine = Preferences { brush_radius: 0.1, ..read };
        mine.save_changes(&read, &dir).unwrap();
        let back: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        assert_eq!(back["theme"], "system");
        assert_eq!(back["grid_visible"], false);
        assert_eq!(back["ui_scale"], 2.0);
        assert_eq!(back["brush_radius"].as_f64().unwrap() as f32, 0.1);
        // a file that is not an object is replaced by every value
        std::fs::write(&file, "{ not json").unwrap();
        mine.save_changes(&read, &dir).unwrap();
        assert_eq!(Preferences::load(&dir), (mine, None));
    }
}
