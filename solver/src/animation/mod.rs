//! Animation and export: timelines of handle paths, recordings of solved frames, scene files,
//! glTF export of a recording (morph targets, or bones fitted by `skinning`), and point caches
//! (PC2, OBJ sequences) on the file's layout.

pub mod export;
pub mod pointcache;
pub mod recording;
pub mod scene;
pub mod skinning;
pub mod timeline;
