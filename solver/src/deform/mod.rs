//! Deformation: handle groups and the fixed/free partition they induce, the methods (ARAP,
//! the bi-harmonic base, BS-ARAP and its coarse variant) behind one [`deformer::Deformer`],
//! the loose parts (components without handles) that ride along, handle targets from group
//! transforms, and quality figures against a reference.

pub mod arap;
pub mod biharmonic;
pub mod bs_arap;
pub mod coarse;
pub mod config;
pub mod constraints;
pub mod deformer;
pub mod handles;
pub mod pose;
pub mod quality;
pub mod riders;
pub mod rig;
pub mod selection;
pub mod symmetry;
