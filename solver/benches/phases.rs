//! Criterion benches of the phases of ARAP (Sorkine & Alexa 2007; Sun et al. 2017, Eqs. 3–5):
//! the factorization of $L_{FF}$, and the three parts of one local-global iteration (local step:
//! per-cell rotation fits; right-hand side $b_F - L_{FH}p'_H$; global solve: one 3-column
//! back-substitution), on generated meshes of increasing size.
//!
//!     cargo bench -p solver --bench phases                 # full run, history in target/criterion
//!     cargo bench -p solver --bench phases -- --quick      # a few seconds per bench
//!     cargo bench -p solver --bench phases -- local_step   # one group
//!
//! Meshes: [`solver::geometry::shapes::bumpy_bar`] at icosphere levels 2–6 (162 to 40,962 vertices):
//! deterministic (the bumps are a fixed function of position, so every run sees the same mesh),
//! its two end caps as handle groups, the `x > 0` cap turned by 0.8 rad about z.
//!
//! - `factorization/symbolic+numeric`: [`SpdFactor::new`] on the free block of the
//!   spokes-and-rims cotangent Laplacian (AMD ordering, elimination tree, numeric Cholesky), as
//!   `Arap::new` does once per handle set; `factorization/numeric`: [`SpdFactor::with_pattern`]
//!   (the numeric Cholesky and the elimination-tree split on a kept analysis).
//! - `local_step`, `rhs`, `global_solve`: each phase of one iteration, timed inside
//!   [`solver::Arap::solve`] (its `SolveStats` phase timers) over solves of one iteration started
//!   from rest, and reported to criterion through `iter_custom`: the phase's own time, not the
//!   whole solve's.
//!
//! - `anderson_step`: one [`solver::linalg::anderson::Anderson::step`] (window 5, history full) on
//!   vectors of 6,000, 20,000 and 60,000 entries (a 2,000-vertex coarse level, Cheburashka's
//!   free positions, a 20,000-vertex mesh), run inside a rayon pool as `Arap` runs it. The
//!   vectors cycle through seven fixed pseudo-random pairs $(x, G(x))$.
//!
//! - `shape_f32`: [`solver::geometry::normals::VertexFaces::shape_f32`], the editor's per-frame
//!   display shape (f32 positions and vertex normals of a pose), on the bumpy bar at icosphere
//!   level 8 (655,362 vertices) turned as in the other benches.
//!
//! - `prolong`: [`solver::deform::coarse::prolong::prolong`], the coarse variant's per-frame carry of the
//!   coarse pose to every fine vertex (step 4 of its module doc), on the same level-8 bar after
//!   one solve of its turned cap (automatic coarse size).
//!
//! - `coarse_iteration`: an iteration of the coarse BS-ARAP's coarse solve on the editor's
//!   defaults (smooth rotations, the Galerkin coarse energy, [`solver::deform::coarse::galerkin`])
//!   on the level-6 bar (40,962 vertices, about 3,000 coarse): the coarse solve's own timer over
//!   10-iteration solves from rest to the turned cap (each solve's setup and first local step
//!   shared among its iterations; the prolongation not timed), in rayon pools of 1 and 2
//!   threads: what a second core buys a coarse level, where a parallel pass is tens of
//!   microseconds.
//!
//! `benches/iteration.rs` is the other harness: phase timings of a 10-iteration solve against an
//! estimate of the machine's limit (bandwidth and rotation-fit rate), on these meshes or a file.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use faer::sparse::Triplet;
use solver::deform::coarse::CoarseBsArap;
use solver::deform::constraints::Constraints;
use solver::geometry::shapes::bumpy_bar;
use solver::linalg::linsolve::{Layout, SpdFactor, SpdPattern};
use solver::linalg::rotation::{axis_angle, mul_vec};
use solver::{Arap, ArapConfig, BaseConfig, CoarseEnergy, Energy, Handles, Mesh};
use std::time::Duration;

const LEVELS: std::ops::RangeInclusive<u32> = 2..=6;

fn meshes() -> Vec<(Mesh, Handles)> {
    LEVELS.map(bumpy_bar).collect()
}

/// The bar's handle targets: the `x > 0` cap turned by 0.8 rad about z, the other at rest.
fn turned_cap(mesh: &Mesh, handles: &Handles) -> Vec<[f64; 3]> {
    let q = axis_angle([0.0, 0.0, 1.0], 0.8);
    handles
        .handle_vertices()
        .iter()
        .map(|&v| mesh.positions()[v as usize])
        .map(|p| if p[0] > 0.0 { mul_vec(&q, p) } else { p })
        .collect()
}

/// The free block $L_{FF}$ of the cotangent Laplacian (lower and upper triangle).
fn free_block(mesh: &Mesh, handles: &Handles) -> (usize, Vec<Triplet<usize, usize, f64>>) {
    let Ok(l) = solver::geometry::cotan::cotan_laplacian(mesh.positions(), mesh.triangles()) else {
        unreachable!("bumpy_bar has no degenerate face")
    };
    let c = Constraints::new(mesh, handles);
    let mut t = Vec::new();
    for j in 0..l.ncols() {
        let Some(cj) = c.free_index[j] else { continue };
        let col = l.col_range(j);
        for (&i, &v) in l.symbolic().row_idx()[col.clone()].iter().zip(&l.val()[col]) {
            if let Some(ri) = c.free_index[i] {
                t.push(Triplet::new(ri as usize, cj as usize, v));
            }
        }
    }
    (c.free_vertices.len(), t)
}

fn factorization(c: &mut Criterion) {
    let mut g = c.benchmark_group("factorization");
    g.sample_size(10);
    for (mesh, handles) in meshes() {
        let (n, t) = free_block(&mesh, &handles);
        let Ok(a) = faer::sparse::SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &t)
        else {
            unreachable!("indices are in range")
        };
        let v = mesh.n_vertices();
        g.bench_with_input(BenchmarkId::new("symbolic+numeric", v), &a, |b, a| {
            b.iter(|| SpdFactor::new(a, Layout::Simplicial).map(|f| f.factor_nonzeros()))
        });
        // The numeric factorization (and the split) on a kept analysis.
        let Ok(pattern) = SpdPattern::new(&a, Layout::Simplicial) else {
            unreachable!("L_FF is SPD")
        };
        g.bench_with_input(BenchmarkId::new("numeric", v), &a, |b, a| {
            b.iter(|| SpdFactor::with_pattern(&pattern, a).map(|f| f.factor_nonzeros()))
        });
    }
    g.finish();
}

/// The phases of one iteration, each timed by `Arap::solve`'s own timers.
fn iteration_phases(c: &mut Criterion) {
    type Phase = fn(&solver::SolveStats) -> f64;
    let phases: [(&str, Phase); 3] =
        [("local_step", |s| s.local_ms), ("rhs", |s| s.rhs_ms), ("global_solve", |s| s.solve_ms)];
    let config = ArapConfig { tolerance: 0.0, max_iterations: 1, ..Default::default() };
    let mut setups: Vec<(usize, Arap, Vec<[f64; 3]>)> = meshes()
        .into_iter()
        .map(|(mesh, handles)| {
            let targets = turned_cap(&mesh, &handles);
            let Ok(arap) = Arap::new(&mesh, &handles, &config) else {
                unreachable!("bumpy_bar is a valid ARAP problem")
            };
            (mesh.n_vertices(), arap, targets)
        })
        .collect();
    for (name, phase) in phases {
        let mut g = c.benchmark_group(name);
        g.sample_size(20);
        for (v, arap, targets) in &mut setups {
            g.bench_function(BenchmarkId::from_parameter(*v), |b| {
                b.iter_custom(|iters| {
                    let mut total = 0.0;
                    for _ in 0..iters {
                        arap.reset();
                        if let Ok(s) = arap.solve(targets) {
                            total += phase(&s);
                        }
                    }
                    Duration::from_secs_f64(total / 1e3)
                })
            });
        }
        g.finish();
    }
}

fn anderson_step(c: &mut Criterion) {
    let mut g = c.benchmark_group("anderson_step");
    let Ok(pool) = rayon::ThreadPoolBuilder::new().build() else {
        unreachable!("a rayon pool with the default threads")
    };
    for dim in [6_000usize, 20_000, 60_000] {
        let mut next = solver::testing::uniform(0x9e37_79b9_7f4a_7c15);
        let pairs: Vec<(Vec<f64>, Vec<f64>)> = (0..7)
            .map(|_| {
                let x: Vec<f64> = (0..dim).map(|_| next()).collect();
                let gx = x.iter().map(|v| 0.9 * v + 0.1 * next()).collect();
                (x, gx)
            })
            .collect();
        let mut aa = solver::linalg::anderson::Anderson::new(5, dim);
        let mut out = vec![0.0; dim];
        let mut k = 0;
        g.bench_function(BenchmarkId::from_parameter(dim), |b| {
            pool.install(|| {
                b.iter(|| {
                    let (x, gx) = &pairs[k % pairs.len()];
                    k += 1;
                    // The step extrapolates in place: each call on a fresh copy of x_k.
                    out.copy_from_slice(x);
                    aa.step(&mut out, gx);
                })
            })
        });
    }
    g.finish();
}

fn shape_f32(c: &mut Criterion) {
    let (mesh, _) = bumpy_bar(8);
    let q = axis_angle([0.0, 0.0, 1.0], 0.8);
    let pose: Vec<[f64; 3]> =
        mesh.positions().iter().map(|&p| if p[0] > 0.0 { mul_vec(&q, p) } else { p }).collect();
    let faces = solver::geometry::normals::VertexFaces::new(mesh.n_vertices(), mesh.triangles());
    let (mut positions, mut normals, mut area) = (Vec::new(), Vec::new(), Vec::new());
    let mut g = c.benchmark_group("shape_f32");
    let t = mesh.triangles();
    g.bench_function(BenchmarkId::from_parameter(mesh.n_vertices()), |b| {
        b.iter(|| faces.shape_f32(&pose, [0.0; 3], t, &mut positions, &mut normals, &mut area))
    });
    g.finish();
}

fn prolong(c: &mut Criterion) {
    let (mesh, handles) = bumpy_bar(8);
    let config = ArapConfig::default();
    let Ok(mut d) = CoarseBsArap::new(&mesh, &handles, &config, &BaseConfig::default()) else {
        unreachable!("the bumpy bar has a coarse base")
    };
    let targets = turned_cap(&mesh, &handles);
    if let Err(e) = d.solve(&targets) {
        unreachable!("the turned bar solves: {e}")
    }
    let mut out = vec![[0.0; 3]; mesh.n_vertices()];
    let mut g = c.benchmark_group("prolong");
    g.bench_function(BenchmarkId::from_parameter(mesh.n_vertices()), |b| {
        b.iter(|| solver::deform::coarse::prolong::prolong(d.prolongation(), &mut out))
    });
    g.finish();
}

fn coarse_iteration(c: &mut Criterion) {
    let (mesh, handles) = bumpy_bar(6);
    let config = ArapConfig {
        energy: Energy::SmoothRotations,
        tolerance: 0.0,
        max_iterations: 10,
        ..Default::default()
    };
    let base = BaseConfig { coarse_energy: CoarseEnergy::Galerkin, ..Default::default() };
    let Ok(mut d) = CoarseBsArap::new(&mesh, &handles, &config, &base) else {
        unreachable!("the bumpy bar has a coarse base")
    };
    let targets = turned_cap(&mesh, &handles);
    let mut g = c.benchmark_group("coarse_iteration");
    g.sample_size(20);
    for threads in [1, 2] {
        let Ok(pool) = rayon::ThreadPoolBuilder::new().num_threads(threads).build() else {
            unreachable!("a rayon pool")
        };
        g.bench_function(BenchmarkId::new("threads", threads), |b| {
            b.iter_custom(|iters| {
                // The coarse solve's own time per iteration, times the iterations criterion
                // asks for.
                let (mut ms, mut done) = (0.0, 0usize);
                while done < iters as usize {
                    d.reset();
                    match pool.install(|| d.solve(&targets)) {
                        Ok(s) if s.iterations > 0 => {
                            ms += s.local_ms;
                            done += s.iterations;
                        }
                        _ => unreachable!("the turned bar solves"),
                    }
                }
                Duration::from_secs_f64(ms / 1e3 * iters as f64 / done as f64)
            })
        });
    }
    g.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3))
}

criterion_group! { name = benches; config = config(); targets = factorization, iteration_phases, anderson_step, shape_f32, prolong, coarse_iteration }
criterion_main!(benches);
