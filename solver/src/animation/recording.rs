//! Recording: solve every frame of a [`Timeline`] to the tolerance, warm-started from the previous
//! frame, and keep the positions.
//!
//! Frame $i$ at time $t_i$ ([`Timeline::frame_times`]) hands the group motions of
//! [`Timeline::transforms_at`]$(t_i)$ as they are to one [`Deformer::solve_groups`] (which
//! derives the handle targets where its method needs them), whose starting guess is frame
//! $i-1$'s result (frame 0 starts from rest: the deformer is reset first). The result depends
//! only on the inputs, not on wall-clock time or on what the deformer solved before, so the
//! editor's recording and `bsarap export` agree.

use std::ops::ControlFlow;

use thiserror::Error;

use crate::animation::timeline::{AnimationError, Timeline};
use crate::deform::arap::{ArapConfig, FrameStats};
use crate::deform::deformer::Deformer;
use crate::deform::handles::{Handles, HandlesError};
use crate::deform::pose::handle_targets;
use crate::error::SolveError;
use crate::geometry::mesh::Mesh;

/// The most frames one recording may have: the editor's, and the command line's and the Python
/// package's frame counts (export, render, bench, timelines).
pub const MAX_FRAMES: usize = 100_000;

/// Why a recording stopped.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RecordError {
    #[error("{0}")]
    Timeline(#[from] AnimationError),
    /// A path for a group the selection lacks, or a move beyond the coordinate limit.
    #[error("the timeline: {0}")]
    Handles(#[from] HandlesError),
    #[error("frame {frame} (t = {time} s): {source}")]
    Solve {
        frame: usize,
        time: f64,
        #[source]
        source: SolveError,
    },
    #[error("recording cancelled after {done} of {total} frames")]
    Cancelled { done: usize, total: usize },
}

/// Recorded frames: `frames[i]` (`#V×3`) is the pose at `times[i]` seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// Strictly increasing seconds, `#frames`.
    pub times: Vec<f64>,
    /// `#frames × #V × 3`.
    pub frames: Vec<Vec<[f64; 3]>>,
    /// `#frames`.
    pub stats: Vec<FrameStats>,
}

impl Recording {
    /// Total iterations over all frames.
    pub fn total_iterations(&self) -> usize {
        self.stats.iter().map(|s| s.iterations).sum()
    }
}

/// Solves `n_frames` frames of `timeline` ([`Timeline::frame_times`]) with `deformer`, built for
/// `mesh` and `handles`.
///
/// Inputs: the deformer (it is reset, and its stopping rule set from `config.tolerance` and
/// `config.max_iterations`); `mesh` (rest positions `#V×3`); `handles`; the timeline (validated
/// here); `n_frames ≥ 1`; `progress(done, total)`, called after each frame (and once with
/// `done = 0` before the first), returning [`ControlFlow::Break`] to cancel: an editor's cancel
/// button, or an `AtomicBool` read in the closure.
///
/// Output: the [`Recording`]; the deformer is left at the last frame. Errors: invalid timeline,
/// a path for a group the selection lacks, a failed solve (non-finite result included; nothing
/// non-finite is ever returned), or [`RecordError::Cancelled`].
pub fn record(
    deformer: &mut Deformer,
    mesh: &Mesh,
    handles: &Handles,
    timeline: &Timeline,
    n_frames: usize,
    config: &ArapConfig,
    progress: &mut dyn FnMut(usize, usize) -> ControlFlow<()>,
) -> Result<Recording, RecordError> {
    timeline.validate()?;
    if n_frames == 0 {
        return Err(AnimationError::NoFrames(0).into());
    }
    let times = timeline.frame_times(n_frames);
    // Check every group before solving anything ([`handle_targets`] of the selection).
    handle_targets(mesh.positions(), handles, &timeline.transforms_at(0.0))?;
    deformer.reset();
    deformer.set_stopping(config.tolerance, config.max_iterations);
    let mut frames = Vec::with_capacity(n_frames);
    let mut stats = Vec::with_capacity(n_frames);
    if progress(0, n_frames).is_break() {
        return Err(RecordError::Cancelled { done: 0, total: n_frames });
    }
    for (frame, &time) in times.iter().enumerate() {
        let s = deformer
            .solve_groups(&timeline.transforms_at(time))
            .map_err(|source| RecordError::Solve { frame, time, source })?;
        let positions = deformer.positions();
        if let Some(vertex) = positions.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
            return Err(RecordError::Solve {
                frame,
                time,
                source: SolveError::NonFiniteResult { vertex },
            });
        }
        frames.push(positions.to_vec());
        stats.push(s.frame_stats());
        if progress(frame + 1, n_frames).is_break() && frame + 1 < n_frames {
            return Err(RecordError::Cancelled { done: frame + 1, total: n_frames });
        }
    }
    Ok(Recording { times, frames, stats })
}
