//! The energy $E(p', R) = \sum_i \sum_{(j,k)\in\mathcal{C}_i} w_{jk}\,\lVert (p'_j-p'_k) -
//! R_i(p_j-p_k)\rVert^2$ (Sun et al. 2017, Eq. 3): directly ([`Arap::energy`]) and from the
//! local step's sums ([`Arap::energy_from`]); with [`super::Energy::SmoothRotations`] plus
//! $\beta\sum_i\sum_j w_{ij}\lVert R_i - R_j\rVert_F^2$ (`smooth_rotations`).

use super::{Arap, Cells};
use crate::geometry::cotan::opposite_edge;
use crate::geometry::mesh::sub;
use crate::linalg::rotation::mul_vec;
use rayon::prelude::*;

impl Arap {
    /// $E = A + \sum w\lVert e\rVert^2 - 2T$ from [`Arap::local_pass`]' sums, at least 0
    /// (the expansion cancels when the pose is very close to rigid; the exact form is
    /// [`Arap::energy`]).
    /// With triangle cells, `membrane` is their $E_T$ ([`Arap::fit_membrane`]) and the cells'
    /// part is $(1-\mu)E_{SR} + 3\mu E_T$ ([`super::membrane`]).
    pub(super) fn energy_from(&self, a: f64, t: f64, membrane: Option<f64>) -> f64 {
        self.blend((a + self.rest_term - 2.0 * t).max(0.0), membrane) + self.soft_energy()
    }

    /// $(1-\mu)E_{SR} + 3\mu E_T$ for the vertex cells' `vertex_cells` and the triangle cells'
    /// `membrane` (the vertex cells' alone without triangle cells).
    fn blend(&self, vertex_cells: f64, membrane: Option<f64>) -> f64 {
        match (self.membrane.as_deref(), membrane) {
            (Some(m), Some(e)) => (1.0 - m.share) * vertex_cells + 3.0 * m.share * e,
            _ => vertex_cells,
        }
    }

    /// The soft handles' $\sum_v \lambda_v \lVert x_v - T_g(p_v)\rVert^2$ (0 without).
    fn soft_energy(&self) -> f64 {
        self.soft.as_deref().map_or(0.0, |soft| {
            let x = &self.current;
            soft.terms
                .iter()
                .zip(&soft.targets)
                .map(|(&(_, v, _, lambda), t)| {
                    let d = sub(x[v as usize], *t);
                    lambda * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
                })
                .sum()
        })
    }

    /// $E(p', R)$ for the current pose and rotations.
    pub fn energy(&self) -> f64 {
        let membrane = match (&self.cells, self.membrane.as_deref()) {
            (Cells::SpokesAndRims { tris, cot, edges, .. }, Some(m)) => {
                Some(m.energy(&self.current, tris, cot, edges))
            }
            _ => None,
        };
        self.blend(self.cell_energy(), membrane) + self.soft_energy() + self.smooth_term()
    }

    /// The cells' part of [`Arap::energy`].
    fn cell_energy(&self) -> f64 {
        let x = &self.current;
        let p = &self.rest;
        let rot = &self.rotations;
        match &self.cells {
            Cells::SpokesAndRims { tris, cot, edges, .. } => tris
                .par_iter()
                .zip(cot.par_iter().zip(edges.par_iter()))
                .with_min_len(2 * self.task)
                .map(|(t, (w, edge))| {
                    let mut e = 0.0;
                    let rs = t.map(|v| &rot[v as usize]);
                    for k in 0..3 {
                        let (a, b) = opposite_edge(*t, k);
                        let de = sub(x[a as usize], x[b as usize]);
                        let mut ek = 0.0;
                        for r in rs {
                            let d = sub(de, mul_vec(r, edge[k]));
                            ek += d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                        }
                        e += w[k] * ek;
                    }
                    e
                })
                .sum(),
            Cells::Spokes { neighbours } => (0..x.len())
                .into_par_iter()
                .with_min_len(self.task)
                .map(|i| {
                    let mut e = 0.0;
                    for &(j, w) in neighbours.row(i) {
                        let j = j as usize;
                        let d = sub(sub(x[i], x[j]), mul_vec(&rot[i], sub(p[i], p[j])));
                        e += w * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                    }
                    e
                })
                .sum(),
        }
    }
}
