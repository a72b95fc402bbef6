//! How well every bone fits every vertex, from two kinds of products (the normal equations of
//! the weight step, Le & Deng 2012, §4.1).
//!
//! With $\tilde r_v = (r_v, 1)$ and $M^t_j = [R^t_j \mid T^t_j]$ (3×4), vertex $v$'s design
//! matrix $A_v$ (`3T×B`) has column $j$ = $(M^0_j \tilde r_v, \dots, M^{T-1}_j \tilde r_v)$ and
//! its target is the trajectory $b_v = (p^0_v, \dots, p^{T-1}_v)$. Then
//! $$ (A_v^\top A_v)_{jk} = \tilde r_v^\top Q_{jk}\, \tilde r_v, \qquad
//!    Q_{jk} = \sum_t M^{t\top}_j M^t_k \quad (4\times4, \text{ independent of } v)$$
//! $$ h_{vj} = (A_v^\top b_v)_j = \tilde r_v \cdot \big(\textstyle\sum_t M^{t\top}_j p^t_v\big)
//!    = \tilde r_v \cdot (P W)_{v,\,4j..4j+4}$$
//! where $P$ (`#V×3T`) holds the trajectories and $W$ (`3T×4B`) the stacked $M^t_j$: one dense
//! product (faer's matmul, by blocks of rows), $2\,V\,3T\,4B$ flops. A bone's squared error on
//! its own is $E_{vj} = \tilde r_v^\top Q_{jj} \tilde r_v - 2 h_{vj} + \lVert b_v\rVert^2$.
//!
//! Inputs: the centred [`Data`], transforms `[t][j]`, optionally a subset of vertices.
//! Outputs: `h` (`#rows×B`, row-major), `Q` (`B×B` of 4×4).

use faer::{Accum, Mat, MatRef, Par};
use rayon::prelude::*;

use super::{Affine, Data};

/// Rows per block of the product.
const ROWS: usize = 1024;
/// Frames per block of the product: a block of $P$ is `ROWS×3·FRAMES` f64 (6 MB) and one of
/// $W$ `3·FRAMES×4B`, whatever the recording's length (a block of every frame held a copy of
/// the recording's f64 trajectories per thread, and $W$ 3.2 GB at 33k frames and 1,024 bones).
const FRAMES: usize = 256;

/// $Q_{jk} = \sum_t M^{t\top}_j M^t_k$, row-major `B×B` of 4×4 (symmetric: $Q_{kj} = Q_{jk}^\top$).
pub(super) fn pair_products(m: &[Vec<Affine>]) -> Vec<[[f64; 4]; 4]> {
    let nb = m.first().map_or(0, Vec::len);
    let mut q = vec![[[0.0; 4]; 4]; nb * nb];
    q.par_chunks_mut(nb.max(1)).enumerate().for_each(|(j, row)| {
        for (k, qjk) in row.iter_mut().enumerate() {
            for frame in m {
                let (a, b) = (&frame[j], &frame[k]);
                for x in 0..4 {
                    for y in 0..4 {
                        qjk[x][y] += a[0][x] * b[0][y] + a[1][x] * b[1][y] + a[2][x] * b[2][y];
                    }
                }
            }
        }
    });
    q
}

/// $\tilde r^\top Q \tilde r$.
#[inline]
pub(super) fn quadratic(q: &[[f64; 4]; 4], r: &[f64; 4]) -> f64 {
    let mut s = 0.0;
    for x in 0..4 {
        s += r[x] * (q[x][0] * r[0] + q[x][1] * r[1] + q[x][2] * r[2] + q[x][3] * r[3]);
    }
    s
}

/// $\lVert b_v \rVert^2 = \sum_t \lVert p^t_v\rVert^2$ of every vertex.
pub(super) fn trajectory_norms(data: &Data) -> Vec<f64> {
    (0..data.n_vertices())
        .into_par_iter()
        .map(|v| {
            (0..data.n_frames())
                .map(|t| {
                    let p = data.p(t, v);
                    p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
                })
                .sum()
        })
        .collect()
}

/// $h_{vj}$ for the vertices `rows` (all when `None`), row-major `#rows×B`.
pub(super) fn projections(data: &Data, rows: Option<&[u32]>, m: &[Vec<Affine>]) -> Vec<f64> {
    let n_t = data.n_frames();
    let nb = m.first().map_or(0, Vec::len);
    let n_rows = rows.map_or(data.n_vertices(), <[u32]>::len);
    let mut h = vec![0.0; n_rows * nb];
    if nb == 0 {
        return h;
    }
    h.par_chunks_mut(ROWS * nb).enumerate().for_each(|(c, out)| {
        let first = c * ROWS;
        let count = out.len() / nb;
        let vertex = |i: usize| rows.map_or(first + i, |r| r[first + i] as usize);
        let mut x = Mat::<f64>::zeros(count, 4 * nb);
        let mut p = Vec::new();
        for t0 in (0..n_t).step_by(FRAMES) {
            let nt = FRAMES.min(n_t - t0);
            p.clear();
            p.resize(count * 3 * nt, 0.0);
            for i in 0..count {
                let v = vertex(i);
                let row = &mut p[i * 3 * nt..(i + 1) * 3 * nt];
                for t in 0..nt {
                    row[3 * t..3 * t + 3].copy_from_slice(&data.p(t0 + t, v));
                }
            }
            let pb = MatRef::from_row_major_slice(&p, count, 3 * nt);
            // W's rows of these frames: W[(3t+a), (4j+b)] = M^t_j[a][b].
            let w = Mat::<f64>::from_fn(3 * nt, 4 * nb, |i, k| m[t0 + i / 3][k / 4][i % 3][k % 4]);
            faer::linalg::matmul::matmul(x.as_mut(), Accum::Add, pb, w.as_ref(), 1.0, Par::Seq);
        }
        for i in 0..count {
            let r = data.rest_h(vertex(i));
            for j in 0..nb {
                out[i * nb + j] = (0..4).map(|b| r[b] * x[(i, 4 * j + b)]).sum();
            }
        }
    });
    h
}

#[cfg(test)]
mod tests {
    use super::super::{Data, apply};
    use super::*;

    #[test]
    fn products_match_the_direct_sums() {
        let rest: Vec<[f64; 3]> =
            (0..7).map(|i| [i as f64 * 0.3, (i * i) as f64 * 0.1 - 1.0, 0.5 - i as f64]).collect();
        let frames: Vec<Vec<[f64; 3]>> = (0..3)
            .map(|t| rest.iter().map(|r| [r[0] + t as f64, r[1] * 0.9, r[2] - 0.2]).collect())
            .collect();
        let data = Data { rest: rest.clone(), frames: &frames, center: [0.1, -0.2, 0.3] };
        let m: Vec<Vec<Affine>> = (0..3)
            .map(|t| {
                (0..2)
                    .map(|j| {
                        let s = (t * 2 + j) as f64;
                        [[1.0, 0.1 * s, 0.0, s], [0.0, 1.0, 0.2, -s], [0.3, 0.0, 1.0, 0.5]]
                    })
                    .collect()
            })
            .collect();
        let h = projections(&data, None, &m);
        let q = pair_products(&m);
        let sub = projections(&data, Some(&[5, 2]), &m);
        for v in 0..7 {
            let r = data.rest_h(v);
            for j in 0..2 {
                let direct: f64 = (0..3)
                    .map(|t| {
                        let (a, p) = (apply(&m[t][j], &r), data.p(t, v));
                        a[0] * p[0] + a[1] * p[1] + a[2] * p[2]
                    })
                    .sum();
                assert!((h[v * 2 + j] - direct).abs() < 1e-12, "{v} {j}");
                for k in 0..2 {
                    let direct: f64 = (0..3)
                        .map(|t| {
                            let (a, b) = (apply(&m[t][j], &r), apply(&m[t][k], &r));
                            a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
                        })
                        .sum();
                    assert!((quadratic(&q[j * 2 + k], &r) - direct).abs() < 1e-12);
                }
            }
        }
        assert_eq!(&sub[..2], &h[10..12]);
        assert_eq!(&sub[2..], &h[4..6]);
    }

    /// Over more frames than a block of the product holds, the blocks add up to the sums.
    #[test]
    fn frame_blocks_add_up() {
        let rest: Vec<[f64; 3]> = (0..5).map(|i| [i as f64, 1.0 - i as f64, 0.5]).collect();
        let n_t = 2 * FRAMES + 37;
        let frames: Vec<Vec<[f64; 3]>> = (0..n_t)
            .map(|t| rest.iter().map(|r| [r[0] + (t as f64).sin(), r[1], r[2] * 0.99]).collect())
            .collect();
        let data = Data { rest, frames: &frames, center: [0.0; 3] };
        let m: Vec<Vec<Affine>> = (0..n_t)
            .map(|t| {
                let s = (t as f64 * 0.01).cos();
                vec![[[1.0, 0.0, 0.0, s], [0.0, s, 0.0, 0.0], [0.0, 0.0, 1.0, -s]]]
            })
            .collect();
        let h = projections(&data, None, &m);
        for (v, hv) in h.iter().enumerate() {
            let r = data.rest_h(v);
            let direct: f64 = (0..n_t)
                .map(|t| {
                    let (a, p) = (apply(&m[t][0], &r), data.p(t, v));
                    a[0] * p[0] + a[1] * p[1] + a[2] * p[2]
                })
                .sum();
            assert!((hv - direct).abs() < 1e-9 * direct.abs().max(1.0), "{v}: {hv} {direct}");
        }
    }
}
