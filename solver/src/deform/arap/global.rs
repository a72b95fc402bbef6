//! The global step (Sun et al. 2017, Eq. 4): the right-hand side $b_F - L_{FH}\,x_H$ for the
//! current rotations, and the back-substitution $L_{FF}\,x_F = b_F - L_{FH}\,x_H$ with the
//! factor computed once (`precompute`).

use super::{Arap, Cells, SolveStats, ms};
use crate::geometry::mesh::sub;
use crate::linalg::rotation::{add_mat, mul_vec, scale_mat};
use faer::MatMut;
use rayon::prelude::*;
use std::time::Instant;

impl Arap {
    /// The rhs and the global solve for the current rotations, timed into `stats`.
    pub(super) fn global_step(&mut self, stats: &mut SolveStats) {
        let t2 = Instant::now();
        self.assemble_rhs();
        let t3 = Instant::now();
        stats.rhs_ms += ms(t2, t3);
        self.solve_rhs();
        for (r, &v) in self.inner.free_vertices.iter().enumerate() {
            self.current[v as usize] = self.rhs_row(r);
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

    /// Solves $L_{FF} X = $ `rhs` in place (the global step's back-substitution).
    pub(super) fn solve_rhs(&mut self) {
        if let Some(f) = self.factor.as_mut() {
            let n = self.inner.free_vertices.len();
            f.solve_in_place(MatMut::from_column_major_slice_mut(&mut self.rhs, n, 3));
        }
    }

    /// Row `r` of `rhs`: after [`Arap::solve_rhs`], free vertex `r`'s new position.
    pub(super) fn rhs_row(&self, r: usize) -> [f64; 3] {
        let n = self.inner.free_vertices.len();
        [self.rhs[r], self.rhs[n + r], self.rhs[2 * n + r]]
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
