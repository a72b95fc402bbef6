//! The deformers the solver threads run.
//!
//! TEMPORARY: `solver`'s ARAP and BS-ARAP are being written on `main`. Until they are merged,
//! [`factory`] returns a stand-in that interpolates handle displacements by inverse-distance
//! weights (Shepard), so the editor's threading, picking and drawing can be exercised. It runs
//! on the solver thread like the real methods will.

use std::sync::Arc;
use std::time::Instant;

use solver::{Handles, Mesh};

use super::solver_thread::{Deformer, DeformerFactory, FrameStats, Method, MethodSettings};

/// The factory used by the editor.
pub fn factory() -> DeformerFactory {
    Arc::new(|method: Method, mesh: &Mesh, handles: &Handles, settings: &MethodSettings| {
        Ok(Box::new(Shepard::new(method, mesh, handles, settings)) as Box<dyn Deformer>)
    })
}

/// Stand-in deformer: `x_v = p_v + Σ_h w_vh d_h / Σ_h w_vh`, `w_vh = |p_v − p_h|⁻²`, over at
/// most `MAX_SAMPLES` handle vertices.
struct Shepard {
    rest: Vec<[f64; 3]>,
    /// (index into the targets, rest position) of the sampled handle vertices.
    samples: Vec<(usize, [f64; 3])>,
    handle_vertices: Vec<u32>,
}

const MAX_SAMPLES: usize = 128;

impl Shepard {
    fn new(_method: Method, mesh: &Mesh, handles: &Handles, _settings: &MethodSettings) -> Self {
        let handle_vertices = handles.handle_vertices();
        let step = handle_vertices.len().div_ceil(MAX_SAMPLES).max(1);
        let samples = handle_vertices
            .iter()
            .enumerate()
            .step_by(step)
            .map(|(i, &v)| (i, mesh.positions()[v as usize]))
            .collect();
        Shepard { rest: mesh.positions().to_vec(), samples, handle_vertices }
    }
}

impl Deformer for Shepard {
    fn solve(&mut self, targets: &[[f64; 3]], x: &mut [[f64; 3]]) -> FrameStats {
        let start = Instant::now();
        for (xv, pv) in x.iter_mut().zip(&self.rest) {
            let mut acc = [0.0; 3];
            let mut wsum = 0.0;
            for &(i, ph) in &self.samples {
                let d2: f64 = (0..3).map(|k| (pv[k] - ph[k]).powi(2)).sum();
                let w = 1.0 / (d2 * d2 + 1e-12);
                for k in 0..3 {
                    acc[k] += w * (targets[i][k] - ph[k]);
                }
                wsum += w;
            }
            *xv = if wsum > 0.0 {
                [pv[0] + acc[0] / wsum, pv[1] + acc[1] / wsum, pv[2] + acc[2] / wsum]
            } else {
                *pv
            };
        }
        for (&v, t) in self.handle_vertices.iter().zip(targets) {
            x[v as usize] = *t;
        }
        FrameStats {
            iterations: 1,
            energy: 0.0,
            ms_per_iteration: start.elapsed().as_secs_f64() * 1e3,
            converged: true,
        }
    }
}
