//! Phase timings of one ARAP iteration and an estimate of the machine's limit for it.
//!
//!     cargo bench -p solver --bench iteration [-- MESH SELECTION]
//!
//! Without arguments: icosphere levels 2–6 (seeded bumps, two end-cap handle groups). With a
//! mesh and a selection (e.g. `../shared/meshes/armadillo.obj bench/handles/armadillo.json`
//! from the repository root, or `../../shared/...` from `solver/`): that mesh. For each mesh it
//! prints the factorization time, ms per iteration split into local step / rhs / solve /
//! energy (median of 5 solves of 10 fixed iterations), and the limit estimate
//!
//!     limit = bytes of the Cholesky factor read per 3-column solve / memory bandwidth
//!           + #V rotation fits / measured warm fit rate (all threads)
//!
//! with the bandwidth and the fit rate measured here, then the global solve alone with 1, 2 and
//! 3 right-hand-side columns on one thread and as the iteration runs it (median of 15 solves).
//! No assertions: timings are for reading.
//! The criterion benches of the same phases, with history, are in `benches/phases.rs`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use rayon::prelude::*;
use solver::geometry::shapes::bumpy_bar;
use solver::linalg::rotation::{
    LANES, Mat3, axis_angle, fit_rotation, fit_rotations_near, mul_mat, mul_vec,
};
use solver::{Arap, ArapConfig, Handles, Mesh};
use std::time::Instant;

/// Read bandwidth in GB/s: summing a 256 MiB array, on all threads (rayon).
fn bandwidth_gbs() -> f64 {
    let n = 32 << 20;
    let v: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let mut best = f64::INFINITY;
    let mut sink = 0.0;
    for _ in 0..5 {
        let t = Instant::now();
        sink += v.par_chunks(1 << 16).map(|c| c.iter().sum::<f64>()).sum::<f64>();
        best = best.min(t.elapsed().as_secs_f64());
    }
    std::hint::black_box(sink);
    (n * 8) as f64 / best / 1e9
}

/// Rotation fits per second on all threads, on covariances of nearly flat cells: cold
/// ([`fit_rotation`], one at a time) and warm ([`fit_rotations_near`], [`LANES`] at a time from
/// guesses 0.01 rad off, as the local step calls it).
fn fit_rates() -> (f64, f64) {
    let mut rnd = solver::testing::uniform(0x2545f4914f6cdd1du64);
    let cases: Vec<(Mat3, Mat3)> = (0..200_000)
        .map(|_| {
            let q = axis_angle([rnd(), rnd(), rnd()], 3.0 * rnd());
            let mut s = [[0.0; 3]; 3];
            for _ in 0..6 {
                let e = [rnd(), rnd(), 0.05 * rnd()];
                let f = mul_vec(&q, [e[0] + 0.1 * rnd(), e[1] + 0.1 * rnd(), e[2]]);
                solver::linalg::rotation::add_outer(&mut s, 0.5 + 0.5 * rnd().abs(), e, f);
            }
            let guess = mul_mat(&axis_angle([rnd(), rnd(), rnd()], 0.01), &fit_rotation(&s));
            (s, guess)
        })
        .collect();
    type Fits<'a> = &'a (dyn Fn(&[(Mat3, Mat3)]) -> f64 + Sync);
    let rate = |fits: Fits| {
        let mut best = f64::INFINITY;
        for _ in 0..5 {
            let t = Instant::now();
            let r: f64 = cases.par_chunks(LANES).map(fits).sum();
            std::hint::black_box(r);
            best = best.min(t.elapsed().as_secs_f64());
        }
        cases.len() as f64 / best
    };
    let cold = rate(&|c| c.iter().map(|(s, _)| fit_rotation(s)[0][0]).sum());
    let warm = rate(&|c| {
        let s: [Mat3; LANES] = std::array::from_fn(|l| c[l].0);
        let mut r: [Mat3; LANES] = std::array::from_fn(|l| c[l].1);
        fit_rotations_near(&s, &mut r) + r.iter().map(|r| r[0][0]).sum::<f64>()
    });
    (cold, warm)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn report(name: &str, mesh: &Mesh, handles: &Handles, bw: f64, rate: f64) {
    let cfg = ArapConfig { tolerance: 0.0, max_iterations: 10, ..Default::default() };
    let t = Instant::now();
    let mut arap = Arap::new(mesh, handles, &cfg).unwrap();
    let factor_ms = t.elapsed().as_secs_f64() * 1e3;
    let hv = handles.handle_vertices();
    let q = axis_angle([0.0, 0.0, 1.0], 0.3);
    let targets: Vec<[f64; 3]> = hv
        .iter()
        .map(|&v| {
            let p = mesh.positions()[v as usize];
            if handles.labels()[v as usize] == Some(0) { mul_vec(&q, p) } else { p }
        })
        .collect();
    let (mut l, mut r, mut s, mut e, mut tot) = (vec![], vec![], vec![], vec![], vec![]);
    for _ in 0..5 {
        arap.reset();
        let st = arap.solve(&targets).unwrap();
        let k = st.iterations as f64;
        l.push(st.local_ms / k);
        r.push(st.rhs_ms / k);
        s.push(st.solve_ms / k);
        e.push(st.energy_ms / k);
        tot.push(st.total_ms() / k);
    }
    let nnz = arap.factor_nonzeros();
    // Forward and backward substitution each read the factor once: values (f64) and row
    // indices (usize).
    let bytes = 2.0 * nnz as f64 * 16.0;
    let solve_limit = bytes / (bw * 1e9) * 1e3;
    let fit_limit = mesh.n_vertices() as f64 / rate * 1e3;
    let tot = median(tot);
    println!(
        "{name:<28} V={:>6} factor {:>7.1} ms nnz(L)={:>8} | ms/iter {:>7.3} = local {:>6.3} + rhs {:>6.3} + solve {:>6.3} + energy {:>6.3} | limit {:>6.3} (solve {:.3} + fits {:.3}) → {:.1}× the limit",
        mesh.n_vertices(),
        factor_ms,
        nnz,
        tot,
        median(l),
        median(r),
        median(s),
        median(e),
        solve_limit + fit_limit,
        solve_limit,
        fit_limit,
        tot / (solve_limit + fit_limit),
    );
    solve_columns(&mut arap);
}

/// The global solve alone with 1, 2 and 3 right-hand-side columns on one thread, and the 3
/// columns as the iteration runs them (split 2 + 1 over two threads when there are two):
/// what the split costs against its parts (median of 15 solves).
fn solve_columns(arap: &mut Arap) {
    let Some(f) = arap.global_factor() else { return };
    let n = f.n();
    let mut time = |k: usize, one_thread: bool| {
        let mut b = faer::Mat::<f64>::from_fn(n, k, |i, j| ((i * 7 + j) % 13) as f64 - 6.0);
        let mut run = || {
            (0..15)
                .map(|_| {
                    let t = Instant::now();
                    f.solve_in_place(b.as_mut());
                    t.elapsed().as_secs_f64() * 1e3
                })
                .collect::<Vec<f64>>()
        };
        let times = if one_thread {
            rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(run)
        } else {
            run()
        };
        median(times)
    };
    let (t1, t2, t3) = (time(1, true), time(2, true), time(3, true));
    let split = time(3, false);
    println!(
        "{:<28} solve on one thread: 1 column {t1:.3} ms, 2 columns {t2:.3}, 3 columns {t3:.3}; 3 columns as the iteration runs them {split:.3}",
        ""
    );
    if let Some(s) = f.split_sizes() {
        let all = (s.forest_entries[0] + s.forest_entries[1] + s.top_entries) as f64;
        println!(
            "{:<28} tree split: forests of {} and {} stored entries, top {} ({:.1} %) in {} columns",
            "",
            s.forest_entries[0],
            s.forest_entries[1],
            s.top_entries,
            100.0 * s.top_entries as f64 / all,
            s.top_columns
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let bw = bandwidth_gbs();
    let (cold, rate) = fit_rates();
    let threads = rayon::current_num_threads() as f64;
    println!(
        "threads {threads}, read bandwidth {bw:.1} GB/s, rotation fits cold {:.2} M/s ({:.3} µs each per thread), warm {:.2} M/s ({:.3} µs)",
        cold / 1e6,
        threads / cold * 1e6,
        rate / 1e6,
        threads / rate * 1e6
    );
    if let [mesh, sel] = &args[..] {
        let loaded = solver::io::load_mesh(std::path::Path::new(mesh)).unwrap();
        let h = solver::deform::selection::load_selection_for(std::path::Path::new(sel), &loaded)
            .unwrap();
        let m = loaded.mesh;
        report(mesh, &m, &h, bw, rate);
    } else {
        for level in 2..=6 {
            let (m, h) = bumpy_bar(level);
            report(&format!("icosphere level {level}"), &m, &h, bw, rate);
        }
    }
}
