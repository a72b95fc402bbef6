//! When settling stops ([`crate::deform::coarse::CoarseBsArap::settle`], step 6): the distance
//! still to go to the converged pose, estimated from the lengths of the settle steps.
//!
//! Local–global iterations converge linearly near a minimum, slowest along the soft modes that
//! cost the energy least (a limb turning a little about its joint). A rule on the energy's
//! decrease per iteration stops on those modes while the pose still has tenths of a percent of
//! the diagonal to go (raw `bench/results/settle/settle_rule.txt`: 0.47 % on average on
//! armadillo-c at 692k vertices, which converged ARAP reached from there).
//! This rule measures the pose instead. With $d_k$ the mean distance the $k$-th step of a
//! phase (the coarse level's, measured at its vertices, the level's or the full mesh's) moved the
//! vertices, over the bounding-box diagonal,
//! the last [`WINDOWS`] windows of [`WINDOW`] steps each, their lengths summed newest first
//! $S_0, S_1, \dots$, and the slowest contraction among them, $\rho = \max_j S_j / S_{j+1}$, a
//! contraction that holds leaves at most
//! $$r_k = S_0 \sum_{m \ge 1} \rho^m = S_0\,\frac{\rho}{1 - \rho}$$
//! for the steps still to come (a geometric series; by the triangle inequality per vertex it
//! bounds the mean distance to the limit). Windows, not single steps: the steps come in bursts
//! (the rotations catching up; one step's length varies tenfold from the next, with or
//! without Anderson acceleration). The slowest of several ratios, not the last: a phase
//! starts with fast modes that die within a few steps, and a ratio across them promises a
//! contraction the slow modes do not keep (at 692k, armadillo-d, one ratio of two windows
//! stopped settling 0.108 % of the diagonal short). On a test's bar of 10k vertices, a ratio of
//! single steps stopped 2.7e-3 of the diagonal short of where the steps led, one ratio of
//! windows of 3 steps 1.1e-3, of 5 steps 6e-5, the slowest of three such ratios 7e-7
//! (`coarse::tests`, "a failed level"). A phase has settled when $r_k <$ [`SETTLED`], or at
//! once when a step moves less than [`STILL`] (nothing left to measure) or ran no iteration;
//! windows that do not shrink ($\rho \ge 1$) never end it, nor does a phase shorter than
//! [`WINDOWS`] windows.

/// The distance still to go, over the diagonal, at which a phase has settled: a hundredth of a
/// percent, a twentieth of issue 51's 0.2 % settling target.
pub const SETTLED: f64 = 1e-4;

/// A step that moves the vertices less than this on average (over the diagonal) has settled
/// whatever the ratio: the iterations have stopped moving the pose.
pub const STILL: f64 = 1e-9;

/// Settle steps per window of the contraction estimate (module doc).
pub const WINDOW: usize = 5;

/// Windows compared (module doc): the estimate needs `WINDOWS · WINDOW` steps of a phase.
pub const WINDOWS: usize = 4;

/// The lengths of one phase's last steps ([`SettleRule::step`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct SettleRule {
    /// The last `WINDOWS · WINDOW` steps' lengths over the diagonal, newest first; `len` of
    /// them set.
    lengths: [f64; WINDOWS * WINDOW],
    len: usize,
    /// $r_k$ after the last step.
    left: Option<f64>,
}

impl SettleRule {
    /// New targets: the steps before say nothing about the next phase's contraction.
    pub fn reset(&mut self) {
        self.len = 0;
        self.left = None;
    }

    /// Records a step that moved the vertices by `moved` on average (over the diagonal) in
    /// `iterations` iterations: whether the phase has settled (module doc). The step after a
    /// settled one begins the next phase.
    pub fn step(&mut self, moved: f64, iterations: usize) -> bool {
        self.lengths.copy_within(..WINDOWS * WINDOW - 1, 1);
        self.lengths[0] = moved;
        self.len = (self.len + 1).min(WINDOWS * WINDOW);
        self.left = self.tail();
        let settled = iterations == 0 || moved < STILL || self.left.is_some_and(|r| r < SETTLED);
        if settled {
            self.len = 0;
        }
        settled
    }

    /// $r_k$ after the last step, over the diagonal: `None` before [`WINDOWS`] windows of its
    /// phase or while they do not shrink.
    pub fn left(&self) -> Option<f64> {
        self.left
    }

    /// $r_k$ of the steps recorded (module doc).
    fn tail(&self) -> Option<f64> {
        if self.len < WINDOWS * WINDOW {
            return None;
        }
        let sums: [f64; WINDOWS] =
            std::array::from_fn(|j| self.lengths[j * WINDOW..][..WINDOW].iter().sum());
        let rho = sums.windows(2).map(|p| p[0] / p[1]).fold(0.0, f64::max);
        (rho < 1.0).then(|| sums[0] * rho / (1.0 - rho))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps shrinking by a fixed ratio settle at the first step after which the rest of the
    /// series is below [`SETTLED`], not before; a phase shorter than [`WINDOWS`] windows never
    /// does.
    #[test]
    fn a_geometric_series_settles_when_its_tail_is_small() {
        let rho: f64 = 0.9;
        let mut rule = SettleRule::default();
        let settled_at = (0..200).find(|&k| rule.step(1e-3 * rho.powi(k), 5));
        // The windows' ratio is ρ⁵; the last window, 1e-3·ρ^(k−4)·(1 + … + ρ⁴), times
        // ρ⁵/(1 − ρ⁵), is the tail after step k: 9e-3·ρ^k < 1e-4 from k = 43 on.
        let first = (0..).find(|&k| 9e-3 * rho.powi(k) < SETTLED).unwrap();
        assert_eq!(first, 43);
        assert_eq!(settled_at, Some(first));
        let left = rule.left().unwrap();
        assert!((left / (9e-3 * rho.powi(43)) - 1.0).abs() < 1e-12, "{left:e}");
        let mut rule = SettleRule::default();
        let n = WINDOWS * WINDOW;
        assert!((0..n - 1).all(|k| !rule.step(1e-8 * rho.powi(k as i32), 5)));
        assert!(rule.step(1e-8 * rho.powi(n as i32 - 1), 5));
    }

    /// Steps that do not shrink, or shrink in bursts, do not end a phase; a step that moves
    /// nothing or runs nothing does, and a reset forgets the last phase.
    #[test]
    fn only_a_lasting_contraction_or_a_still_pose_settles() {
        let mut rule = SettleRule::default();
        assert!((0..50).all(|_| !rule.step(1e-6, 5)));
        assert_eq!(rule.left(), None);
        rule.reset();
        // A test's full-mesh steps (`coarse::tests`, a failed level), whose path goes on for
        // 1.2e-3 after the last of them: one ratio of windows of 3 steps would stop there.
        let burst = [
            5.2e-4, 8.0e-4, 1.8e-4, 1.0e-4, 1.6e-4, 5.3e-4, 4.1e-4, 1.3e-4, 2.1e-4, 1.9e-5, 1.2e-4,
        ];
        assert!(burst.iter().all(|&d| !rule.step(d, 5)));
        // A fast mode dying in the first window, then a slow one (1e-5 a step, ratio 0.99):
        // a ratio across the first window (under 0.01) would stop after two windows; the
        // slowest of the three finds the slow mode's tail, 1e-5·0.99²⁰/0.01 = 8.2e-4.
        rule.reset();
        let slow = |k: i32| 1e-5 * 0.99f64.powi(k);
        let steps = (0..5).map(|k| 1e-2 * 0.01f64.powi(k) + slow(k)).chain((5..20).map(slow));
        assert!(steps.into_iter().all(|d| !rule.step(d, 5)));
        let left = rule.left().unwrap();
        assert!((left / (slow(20) / 0.01) - 1.0).abs() < 1e-9, "{left:e}");
        assert!(rule.step(0.0, 5));
        rule.reset();
        assert!(rule.step(1e-3, 0));
        rule.reset();
        assert!((0..5).all(|_| !rule.step(1e-5, 5)));
        assert!(rule.step(STILL / 2.0, 5));
    }
}
