//! User preferences kept between sessions: UI scale, theme, the method new documents start
//! with, the brush radius, and whether file dialogs are always the editor's own. Stored as
//! `prefs.json` in the editor's configuration folder ([`super::persist`]), written atomically
//! whenever a preference changes, read at start.
//!
//! A missing file means the defaults. A file that cannot be read or parsed, or that holds an
//! out-of-range value, also gives the defaults (for that value) and a one-line message that
//! names the file, which the editor shows; it never panics.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
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

/// What persists. Missing fields in a file take their defaults; unknown fields are ignored.
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

    /// Parses the JSON of [`Preferences::to_json`] (see [`Preferences::sanitized`]).
    pub fn from_json(text: &str) -> Result<(Preferences, Option<String>), String> {
        let p: Preferences = serde_json::from_str(text).map_err(|e| e.to_string())?;
        Ok(p.sanitized())
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
            Err(e) => return (Preferences::default(), Some(bad_file(&path, &e.to_string()))),
        };
        match Preferences::from_json(&text) {
            Ok((p, msg)) => (p, msg.map(|m| bad_file(&path, &m))),
            Err(e) => (Preferences::default(), Some(bad_file(&path, &e))),
        }
    }

    /// Writes `prefs.json` in `dir` (created when missing), atomically.
    pub fn save(&self, dir: &Path) -> Result<PathBuf, String> {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let path = dir.join(FILE_NAME);
        write_atomic(&path, self.to_json().as_bytes()).map_err(|e| e.to_string())?;
        Ok(path)
    }
}

fn bad_file(path: &Path, why: &str) -> String {
    format!("preferences {}: {why}; defaults used", path.display())
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
        p.save(&dir.join("sub")).unwrap();
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
        // A wrong type is an error too; a partial file keeps what it has.
        assert!(Preferences::from_json(r#"{"theme": 3}"#).is_err());
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
}
