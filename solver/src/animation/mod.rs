//! Animation and export: timelines of handle paths, recordings of solved frames, scene files,
//! glTF export of a recording, and point caches (PC2, OBJ sequences) on the file's layout.

pub mod export;
pub mod pointcache;
pub mod recording;
pub mod scene;
pub mod timeline;
