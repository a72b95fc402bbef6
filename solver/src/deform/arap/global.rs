//! The global step (Sun et al. 2017, Eq. 4): the right-hand side $b_F - L_{FH}\,x_H$ for the
//! current rotations, and the solve of $L_{FF}\,x_F = b_F - L_{FH}\,x_H$: the back-substitution
//! with the factor computed once (`precompute`), or, on a dense mesh with a coarser level at
//! hand ([`GlobalStep::TwoGrid`]), conjugate gradients with a two-grid cycle on that level
//! started from the current pose ([`crate::linalg::two_grid`]), which need no factorization of
//! the mesh's size and never raise the energy.

use super::{Arap, Cells, SolveStats, ms};
use crate::geometry::level::LevelEmbedding;
use crate::geometry::mesh::sub;
use crate::linalg::linsolve::SpdFactor;
use crate::linalg::rotation::{add_mat, mul_vec, scale_mat};
use crate::linalg::two_grid::TwoGridCg;
use faer::MatMut;
use rayon::prelude::*;
use std::time::Instant;

/// How the global step solves ([`super::Arap::with_constraints`]).
#[derive(Clone, Copy, Debug)]
pub(crate) enum GlobalStep<'a> {
    /// With the sparse Cholesky factor of $L_{FF}$.
    Factor,
    /// With two-grid conjugate gradients on this coarser mesh of the same surface, every
    /// vertex of the mesh embedded on one of its triangles (module doc).
    TwoGrid(&'a LevelEmbedding),
    /// Two-grid on the level that [`super::RotationStep::Auto`] would build (one level for
    /// both steps), with the factor where there is none (`precompute.rs`, `rotation_level`).
    Auto,
}

/// The global step's solver of $L_{FF}X = B$ (module doc).
#[derive(Debug)]
pub(super) enum GlobalSolve {
    Factor(Box<SpdFactor>),
    TwoGrid {
        solver: Box<TwoGridCg>,
        /// The start, then the solution, by free row.
        x: Vec<[f64; 3]>,
        /// Conjugate-gradient iterations since it was made.
        iterations: usize,
    },
}

impl Arap {
    /// The rhs and the global solve for the current rotations, timed into `stats`.
    pub(super) fn global_step(&mut self, stats: &mut SolveStats) {
        let t2 = Instant::now();
        self.assemble_rhs();
        let t3 = Instant::now();
        stats.rhs_ms += ms(t2, t3);
        self.solve_rhs();
        for (r, &v) in self.inner.free_vertices.iter().enumerate() {
            self.current[v as usize] = self.solved_row(r);
        }
        stats.solve_ms += ms(t3, Instant::now());
        stats.iterations += 1;
    }

    /// Right-hand side of the global step for the free rows: $b_F - L_{FH} x_H$, written in
    /// parallel straight into the three columns the solve reads (`rhs`). The constant
    /// rest-edge combinations are precomputed.
    pub(super) fn assemble_rhs(&mut self) {
        let p = &self.rest;
        let x = &self.current;
        let rot = &self.rotations;
        let free = &self.inner.free_vertices;
        let coupling = &self.coupling;
        let cells = &self.cells;
        let membrane = self.membrane.as_deref();
        let row = |r: usize| -> [f64; 3] {
            let i = free[r] as usize;
            let mut b = [0.0; 3];
            match cells {
                Cells::SpokesAndRims { ring, rhs_coef, .. } => {
                    let (lo, hi) = (ring.offsets[i], ring.offsets[i + 1]);
                    for (&j, &u) in ring.items[lo..hi].iter().zip(&rhs_coef[lo..hi]) {
                        let rv = mul_vec(&rot[j as usize], u);
                        b = [b[0] + rv[0], b[1] + rv[1], b[2] + rv[2]];
                    }
                }
                Cells::Spokes { neighbours } => {
                    for &(j, w) in neighbours.row(i) {
                        let j = j as usize;
                        let rr = scale_mat(&add_mat(&rot[i], &rot[j]), 0.5 * w);
                        let rv = mul_vec(&rr, sub(p[i], p[j]));
                        b = [b[0] + rv[0], b[1] + rv[1], b[2] + rv[2]];
                    }
                }
            }
            if let Some(m) = membrane {
                let t = m.rhs(i);
                b = [b[0] + t[0], b[1] + t[1], b[2] + t[2]];
            }
            add_coupling(b, coupling.row(r), x)
        };
        let task = self.task;
        let (bx, rest) = self.rhs.split_at_mut(free.len());
        let (by, bz) = rest.split_at_mut(free.len());
        let blocks =
            bx.par_chunks_mut(task).zip(by.par_chunks_mut(task)).zip(bz.par_chunks_mut(task));
        blocks.enumerate().for_each(|(c, ((bx, by), bz))| {
            for (l, ((x, y), z)) in bx.iter_mut().zip(by).zip(bz).enumerate() {
                [*x, *y, *z] = row(c * task + l);
            }
        });
        if let Some(soft) = self.soft.as_deref() {
            let n = free.len();
            for (&(r, _, _, lambda), t) in soft.terms.iter().zip(&soft.targets) {
                let r = r as usize;
                self.rhs[r] += lambda * t[0];
                self.rhs[n + r] += lambda * t[1];
                self.rhs[2 * n + r] += lambda * t[2];
            }
        }
    }

    /// Solves $L_{FF} X = $ `rhs` (the global step's solve, module doc): the factor in place,
    /// two-grid conjugate gradients from the current pose into their `x` ([`Arap::solved_row`]
    /// reads either).
    pub(super) fn solve_rhs(&mut self) {
        let n = self.inner.free_vertices.len();
        match self.global.as_mut() {
            None => {}
            Some(GlobalSolve::Factor(f)) => {
                f.solve_in_place(MatMut::from_column_major_slice_mut(&mut self.rhs, n, 3));
            }
            Some(GlobalSolve::TwoGrid { solver, x, iterations }) => {
                let (free, current) = (&self.inner.free_vertices, &self.current);
                x.par_iter_mut().zip(&free[..]).for_each(|(x, &v)| *x = current[v as usize]);
                let (bx, rest) = self.rhs.split_at_mut(n);
                let (by, bz) = rest.split_at_mut(n);
                let b = |r: usize| [bx[r], by[r], bz[r]];
                *iterations += solver.solve(b, x).iterations;
            }
        }
    }

    /// After [`Arap::solve_rhs`], free row `r`'s new position.
    pub(super) fn solved_row(&self, r: usize) -> [f64; 3] {
        match &self.global {
            Some(GlobalSolve::TwoGrid { x, .. }) => x[r],
            _ => {
                let n = self.inner.free_vertices.len();
                [self.rhs[r], self.rhs[n + r], self.rhs[2 * n + r]]
            }
        }
    }
}

#[inline]
fn add_coupling(mut b: [f64; 3], row: &[(u32, f64)], x: &[[f64; 3]]) -> [f64; 3] {
    for &(h, w) in row {
        let xh = x[h as usize];
        b = [b[0] + w * xh[0], b[1] + w * xh[1], b[2] + w * xh[2]];
    }
    b
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::deform::arap::smooth_rotations::tests::{assert_descends, cap_turned, config};
    use crate::deform::arap::{ArapConfig, RotationStep};
    use crate::deform::constraints::Constraints;
    use crate::geometry::shapes::{bumpy_bar, midpoint_level, subdivide};

    /// On the bar one midpoint subdivision above its level, the global step by two-grid
    /// conjugate gradients on the level reaches the minimum of the factored step on plain
    /// ARAP and on smooth rotations, the energy never rising, with a factor of the level's
    /// size only. Fails when the solve stops short of its start's descent (a wrong
    /// preconditioner) or when the cycle's correction is dropped (the iteration cap).
    #[test]
    fn two_grid_global_step_reaches_the_factored_minimum() {
        let (coarse, _) = bumpy_bar(2);
        let fine = subdivide(&coarse);
        let level = midpoint_level(&coarse);
        let h = crate::geometry::shapes::cap_handles(&fine);
        let targets = cap_turned(&fine, &h);
        let diagonal = fine.bbox_diagonal();
        for cfg in [ArapConfig::default(), config(0.05)] {
            let cfg = ArapConfig { tolerance: 1e-10, max_iterations: 3000, ..cfg };
            let run = |global: GlobalStep<'_>| {
                let rotation = RotationStep::Level(&level);
                let constraints = Constraints::new(&fine, &h);
                let a =
                    Arap::with_constraints(&fine, constraints, &cfg, 0.0, None, rotation, global);
                let mut a = a.unwrap();
                let stats = a.solve(&targets).unwrap();
                assert_descends(&stats, &format!("{global:?}"));
                assert!(stats.converged, "{global:?}: {} iterations", stats.iterations);
                (a, stats)
            };
            let (two_grid, st_two_grid) = run(GlobalStep::TwoGrid(&level));
            let (factored, st_factored) = run(GlobalStep::Factor);
            let (e2, e1) = (st_two_grid.energy(), st_factored.energy());
            assert!((e2 - e1).abs() <= 1e-6 * e1, "{:?}: {e2} against {e1}", cfg.energy);
            let far = two_grid
                .positions()
                .iter()
                .zip(factored.positions())
                .map(|(p, q)| crate::geometry::mesh::norm2(sub(*p, *q)).sqrt())
                .fold(0.0, f64::max);
            assert!(far <= 1e-3 * diagonal, "{:?}: {far} apart", cfg.energy);
            assert!(two_grid.factor_nonzeros() < factored.factor_nonzeros());
            let cg = two_grid.two_grid_iterations().unwrap();
            assert!(
                cg <= 4 * st_two_grid.iterations,
                "{cg} CG iterations in {} global steps",
                st_two_grid.iterations
            );
            assert!(st_two_grid.iterations <= 2 * st_factored.iterations);
        }
    }
}
