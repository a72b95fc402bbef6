//! Deformation: handle groups and the fixed/free partition they induce, the methods (ARAP,
//! the bi-harmonic base, BS-ARAP and its coarse variant) behind one [`deformer::Deformer`],
//! the loose parts (components without handles) that ride along, handle targets from group
//! transforms, and quality figures against a reference.

pub mod arap;
pub mod biharmonic;
pub mod bs_arap;
pub mod coarse;
pub mod coarse_base;
pub mod coarse_cache;
pub mod coarse_groups;
pub mod config;
pub mod constraints;
pub mod deformer;
pub mod embedding;
pub mod fine_level;
pub mod handles;
pub mod level_fairing;
pub mod middle_level;
pub mod pose;
pub mod prolong;
pub mod quality;
pub mod riders;
pub mod rig;
pub mod selection;
pub mod symmetry;
