//! The bi-harmonic base: interpolation of the handles and the discrete Δ²B = 0 on free vertices.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::needless_range_loop)]

use solver::deform::constraints::Constraints;
use solver::geometry::cotan::cotan_laplacian;
use solver::geometry::mass::{MassKind, lumped_mass};
use solver::geometry::shapes::icosphere;
use solver::{ArapConfig, BsArap, Handles};

/// y = L x for the sparse L, per coordinate.
fn apply(l: &faer::sparse::SparseColMat<usize, f64>, x: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut y = vec![[0.0; 3]; x.len()];
    let l = l.as_ref();
    for j in 0..x.len() {
        for (i, v) in l.symbolic().row_idx_of_col(j).zip(l.val_of_col(j)) {
            for d in 0..3 {
                y[i][d] += v * x[j][d];
            }
        }
    }
    y
}

#[test]
fn base_interpolates_handles_and_is_biharmonic() {
    let s = icosphere(3);
    let p: Vec<[f64; 3]> = s
        .positions()
        .iter()
        .map(|&[x, y, z]| {
            let r = 1.0 + 0.08 * (9.0 * x).sin() * (8.0 * z).cos();
            [1.5 * x * r, y * r, z * r]
        })
        .collect();
    let m = s.with_positions(p).unwrap();
    let labels: Vec<i64> = m
        .positions()
        .iter()
        .map(|p| {
            if p[0] > 1.2 {
                0
            } else if p[1] < -0.8 {
                1
            } else {
                -1
            }
        })
        .collect();
    let h = Handles::from_labels(&labels, m.n_vertices()).unwrap();
    let bs = BsArap::new(&m, &h, &ArapConfig::default()).unwrap();
    let b = bs.base();
    for &v in h.handle_vertices() {
        assert_eq!(b[v as usize], m.positions()[v as usize], "B must interpolate handle {v}");
        assert_eq!(bs.details()[v as usize], [0.0; 3]);
    }
    // Residual of Q B on free rows, relative to the right-hand side Q_FH B_H.
    let l = cotan_laplacian(m.positions(), m.triangles()).unwrap();
    let a = lumped_mass(m.positions(), m.triangles(), MassKind::Voronoi);
    let c = Constraints::new(&m, &h);
    let qb = {
        let lb = apply(&l, b);
        let scaled: Vec<[f64; 3]> = lb.iter().zip(&a).map(|(v, ai)| v.map(|x| x / ai)).collect();
        apply(&l, &scaled)
    };
    let bh: Vec<[f64; 3]> =
        b.iter().enumerate().map(|(v, &p)| if c.is_fixed(v) { p } else { [0.0; 3] }).collect();
    let rhs = {
        let lb = apply(&l, &bh);
        let scaled: Vec<[f64; 3]> = lb.iter().zip(&a).map(|(v, ai)| v.map(|x| x / ai)).collect();
        apply(&l, &scaled)
    };
    let norm = |v: &[[f64; 3]], free: &[u32]| {
        free.iter().map(|&i| v[i as usize].iter().map(|x| x * x).sum::<f64>()).sum::<f64>().sqrt()
    };
    let res = norm(&qb, &c.free_vertices);
    let r = norm(&rhs, &c.free_vertices);
    assert!(r > 0.0);
    assert!(res <= 1e-9 * r, "bi-harmonic residual {res:e} vs rhs {r:e}");
    // B is smoother than M: its details are not zero on free vertices.
    let dmax =
        bs.details().iter().map(|d| d.iter().map(|x| x * x).sum::<f64>()).fold(0.0, f64::max);
    assert!(dmax > 1e-6);
}
