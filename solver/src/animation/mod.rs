//! Animation and export: timelines of handle paths, recordings of solved frames, scene files,
//! and glTF export of a recording.

pub mod export;
pub mod recording;
pub mod scene;
pub mod timeline;
