//! The solver on the paper's meshes, one module a file, in one test binary (one link of the
//! solver instead of one a file).

mod dragon;
mod knight;
