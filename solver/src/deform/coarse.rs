//! BS-ARAP on a coarse base: ARAP runs on a decimated copy of a smooth base surface and the
//! full-resolution details ride on it (our variant for speed; docs/DESIGN.md, "The coarse base").
//!
//! 1. $B$ = faired base of $M$ ([`crate::deform::biharmonic::faired_surface`], smoothing length $h$).
//! 2. $B_c$ = [`crate::geometry::decimate::decimate`] of $B$ to about `coarse_vertices` vertices (a subset of
//!    $B$'s vertices, handle groups kept).
//! 3. Embedding (prolongation $P$): each fine vertex $i$ gets the closest point of $B_c$ to $B_i$,
//!    as barycentric weights $w_{ik}$ on a coarse triangle $t_i$; its detail is
//!    $D_i = p_i - \sum_k w_{ik} B_{c,k}$.
//! 4. Each frame: ARAP on $B_c$ (handles = the kept handle vertices) gives $B_c'$ and $R_k$;
//!    $p'_i = \sum_k w_{ik} B'_{c,k} + \hat R_i (D_i + C_i)$ where $\hat R_i$ is the normalized
//!    blend of the corner rotations as quaternions (signs aligned) and $C_i$ the carried fine
//!    correction (step 5; zero without it). Handle vertices are set to their targets exactly,
//!    and the vertices of components without handles to their rest positions (the deformer
//!    then moves the following ones, [`crate::deform::riders`]).
//! 5. Optionally ([`BaseConfig::fine_iterations`]), a few ARAP iterations on $M$ with
//!    Anderson acceleration ([`Arap::refine`]) start from $p'$ and give the result $x$: a
//!    two-level scheme in which the coarse solve supplies the smooth part of the deformation
//!    and the fine iterations reduce what the coarse space and the detail transfer cannot
//!    represent. What they changed is kept in the detail frames,
//!    $C_i = \hat R_i^\top (x_i - \sum_k w_{ik} B'_{c,k}) - D_i$, and carried to the next
//!    frame, so that over an animation the fine iterations add up instead of starting again
//!    from the coarse pose every frame (BENCHMARKS.md measures both).
//!
//! 6. Optionally ([`BaseConfig::settle_iterations`], [`CoarseBsArap::settle`]), once the
//!    handles stop, more fine iterations refine the pose step by step, carried the same way,
//!    until they no longer lower the energy: the pose approaches converged ARAP on $M$.
//!
//! Rest pose is exact (rest targets give $B_c' = B_c$, $R = I$ and clear $C$, so $p' = p$;
//! they skip the fine iterations) and a rigid motion of all handles moves the result rigidly.
//! An iteration costs what ARAP on $B_c$ costs; the prolongation is one pass over the fine
//! vertices per frame, each fine iteration one ARAP iteration on $M$.

use crate::deform::arap::{Arap, ArapConfig, SolveStats};
use crate::deform::biharmonic::faired_surface;
use crate::deform::config::BaseConfig;
use crate::deform::constraints::Constraints;
use crate::deform::handles::Handles;
use crate::error::SolveError;
use crate::geometry::decimate::decimate;
use crate::geometry::mesh::{Mesh, add, dot, sub};
use crate::linalg::rotation::Mat3;
use rayon::prelude::*;

/// Coarse-base BS-ARAP precomputed for one mesh and one handle set.
#[derive(Debug)]
pub struct CoarseBsArap {
    arap: Arap,
    /// Per fine vertex: coarse triangle corners and barycentric weights.
    embedding: Vec<([u32; 3], [f64; 3])>,
    details: Vec<[f64; 3]>,
    base: Vec<[f64; 3]>,
    deformed_base: Vec<[f64; 3]>,
    result: Vec<[f64; 3]>,
    fine_handles: Vec<u32>,
    /// Fine vertices of components without handles, with their rest positions.
    pinned: Vec<(u32, [f64; 3])>,
    /// For each coarse handle vertex (in its handle order), the index in the fine targets.
    coarse_targets: Vec<usize>,
    quaternions: Vec<[f64; 4]>,
    /// Per fine vertex, the blended rotation of the last solve (unit quaternion).
    frames: Vec<[f64; 4]>,
    /// Per fine vertex, what the last fine iterations added to its detail, in the detail's
    /// frame (zero without fine iterations): carried to the next solve.
    correction: Vec<[f64; 3]>,
    /// ARAP on the full mesh (when fine or settle iterations are asked for).
    fine: Option<Arap>,
    fine_iterations: usize,
    settle_iterations: usize,
    /// The targets of the last solve, and whether [`CoarseBsArap::settle`] may refine its
    /// result (its coarse solve converged and it is not the rest pose).
    last_targets: Vec<[f64; 3]>,
    settle_ready: bool,
    /// The coarse energy of the last solve (what a settle step reports).
    last_energy: f64,
    phases: Vec<(&'static str, f64)>,
    /// Scratch for the next result, deformed base and frames: swapped in together after a
    /// finite prolongation, and back when the fine iterations fail, so that after an error the
    /// pose, the base and the frames all stay those of the last successful solve.
    next: Vec<[f64; 3]>,
    next_base: Vec<[f64; 3]>,
    next_frames: Vec<[f64; 4]>,
    /// Per-solve scratch: the coarse handles' targets, and the coarse pose to go back to if
    /// the prolongation or the fine iterations fail (a few thousand vertices; reused, not
    /// allocated per frame).
    coarse_target_buf: Vec<[f64; 3]>,
    coarse_before: Vec<[f64; 3]>,
}

impl CoarseBsArap {
    /// Builds the base, decimates it, embeds the fine vertices and factors coarse ARAP.
    pub fn new(
        mesh: &Mesh,
        handles: &Handles,
        config: &ArapConfig,
        coarse: &BaseConfig,
    ) -> Result<CoarseBsArap, SolveError> {
        if handles.n_vertices() != mesh.n_vertices() {
            return Err(SolveError::HandleCount {
                got: handles.n_vertices(),
                expected: mesh.n_vertices(),
            });
        }
        let diag = mesh.bbox_diagonal();
        let mut clock = Phases::default();
        let constraints = Constraints::new(mesh, handles);
        let smoothing = (coarse.smoothing.is_finite() && coarse.smoothing > 0.0)
            .then_some(coarse.smoothing * diag);
        let base = faired_surface(mesh, &constraints, mesh.positions(), smoothing)?;
        clock.lap("faired base");
        let labels = handles.labels();
        let target = coarse.coarse_vertices_for(mesh.n_vertices());
        let dec = decimate(&base, mesh.triangles(), labels, target);
        clock.lap("decimation");
        let coarse_positions: Vec<[f64; 3]> = dec.kept.iter().map(|&v| base[v as usize]).collect();
        let coarse_mesh = Mesh::new(coarse_positions, dec.triangles.clone())
            .map_err(|_| SolveError::NonFiniteResult { vertex: 0 })?;
        let coarse_handles =
            Handles::from_options(dec.kept.iter().map(|&v| labels[v as usize]).collect())?;
        // Collapsed coarse triangles (features thinner than the smoothing length flatten in
        // the faired base) take the cotangents of the same vertices on M.
        let floor = 2.0 * crate::geometry::cleanup::AREA_EPS * diag * diag;
        let rest_kept: Vec<[f64; 3]> =
            dec.kept.iter().map(|&v| mesh.positions()[v as usize]).collect();
        let arap = Arap::with_constraints(
            &coarse_mesh,
            Constraints::new(&coarse_mesh, &coarse_handles),
            config,
            floor,
            Some(&rest_kept),
        )
        .map_err(|e| match e {
            SolveError::DegenerateFace { face } => SolveError::DegenerateBase { face },
            other => other,
        })?;
        clock.lap("coarse factorization");
        let fine_handles = handles.handle_vertices();
        let coarse_targets = coarse_handles
            .handle_vertices()
            .iter()
            .map(|&j| fine_handles.binary_search(&dec.kept[j as usize]).unwrap_or(0))
            .collect();

        // Coarse vertex → faces adjacency for the local closest-point search.
        let cp = coarse_mesh.positions();
        let ct = coarse_mesh.triangles();
        let mut vf = vec![Vec::new(); cp.len()];
        for (f, t) in ct.iter().enumerate() {
            for &v in t {
                vf[v as usize].push(f as u32);
            }
        }
        let embedding: Vec<([u32; 3], [f64; 3])> = (0..mesh.n_vertices())
            .into_par_iter()
            .map(|i| {
                let r = dec.representative[i] as usize;
                // Faces within two rings of the representative.
                let mut faces: Vec<u32> = Vec::new();
                for &f in &vf[r] {
                    for &w in &ct[f as usize] {
                        faces.extend_from_slice(&vf[w as usize]);
                    }
                }
                faces.sort_unstable();
                faces.dedup();
                let q = base[i];
                let mut best = (f64::INFINITY, [r as u32; 3], [1.0, 0.0, 0.0]);
                for f in faces {
                    let t = ct[f as usize];
                    let (point, w) = closest_point_on_triangle(q, t.map(|v| cp[v as usize]));
                    let d = sub(point, q);
                    let d2 = dot(d, d);
                    if d2 < best.0 {
                        best = (d2, t, w);
                    }
                }
                (best.1, best.2)
            })
            .collect();
        let base_on_coarse: Vec<[f64; 3]> =
            embedding.iter().map(|(t, w)| blend(cp, t, w)).collect();
        let details =
            mesh.positions().iter().zip(&base_on_coarse).map(|(&p, &b)| sub(p, b)).collect();
        clock.lap("embedding");
        let fine = if coarse.fine_iterations > 0 || coarse.settle_iterations > 0 {
            let fine = Arap::with_constraints(mesh, constraints.clone(), config, 0.0, None)?;
            clock.lap("fine factorization");
            Some(fine)
        } else {
            None
        };
        let pinned = constraints
            .pinned_vertices
            .iter()
            .map(|&v| (v, mesh.positions()[v as usize]))
            .collect();
        Ok(CoarseBsArap {
            fine,
            fine_iterations: coarse.fine_iterations,
            settle_iterations: coarse.settle_iterations,
            last_targets: Vec::new(),
            settle_ready: false,
            last_energy: 0.0,
            phases: clock.phases,
            next: Vec::new(),
            next_base: Vec::new(),
            next_frames: Vec::new(),
            coarse_target_buf: Vec::new(),
            coarse_before: Vec::new(),
            pinned,
            quaternions: vec![[1.0, 0.0, 0.0, 0.0]; cp.len()],
            frames: vec![[1.0, 0.0, 0.0, 0.0]; mesh.n_vertices()],
            correction: vec![[0.0; 3]; mesh.n_vertices()],
            deformed_base: base_on_coarse.clone(),
            base: base_on_coarse,
            details,
            result: mesh.positions().to_vec(),
            embedding,
            fine_handles,
            coarse_targets,
            arap,
        })
    }

    /// Solves coarse ARAP for `targets` (`#H×3` of the fine mesh) and prolongs to the fine mesh.
    /// On error the pose, the deformed base and the detail frames of the last successful solve
    /// stay, and the next solve starts from its coarse pose.
    pub fn solve(&mut self, targets: &[[f64; 3]]) -> Result<SolveStats, SolveError> {
        if targets.len() != self.fine_handles.len() {
            return Err(SolveError::TargetCount {
                got: targets.len(),
                expected: self.fine_handles.len(),
            });
        }
        // Only some targets reach the coarse ARAP (which checks them); all are copied to p'.
        if let Some(index) = targets.iter().position(|t| !t.iter().all(|c| c.is_finite())) {
            return Err(SolveError::NonFiniteTarget { index });
        }
        self.coarse_target_buf.clear();
        self.coarse_target_buf.extend(self.coarse_targets.iter().map(|&k| targets[k]));
        self.coarse_before.clear();
        self.coarse_before.extend_from_slice(self.arap.positions());
        let stats = self.arap.solve(&self.coarse_target_buf)?;
        // Rest targets give the rest pose exactly, without iterating: nothing to settle, and
        // no correction may carry over (the prolongation below is then exactly the rest pose).
        if stats.iterations == 0 {
            self.correction.fill([0.0; 3]);
        }
        let bc = self.arap.positions();
        for (q, r) in self.quaternions.iter_mut().zip(self.arap.rotations()) {
            *q = quaternion_of(r);
        }
        let quats = &self.quaternions;
        // B'_c is finite (checked by ARAP) but the prolonged p' can still overflow: write into
        // reused buffers and swap them in only when p' is finite (the previous pose stays).
        let n = self.result.len();
        let mut next = std::mem::take(&mut self.next);
        next.resize(n, [0.0; 3]);
        self.next_base.resize(n, [0.0; 3]);
        self.next_frames.resize(n, [1.0, 0.0, 0.0, 0.0]);
        let details = self.details.par_iter().zip(self.correction.par_iter());
        self.next_base
            .par_iter_mut()
            .zip(next.par_iter_mut().zip(self.next_frames.par_iter_mut()))
            .zip(self.embedding.par_iter().zip(details))
            .for_each(|((b, (out, frame)), ((t, w), (d, c)))| {
                *b = blend(bc, t, w);
                let q0 = quats[t[0] as usize];
                let mut q = [0.0; 4];
                for k in 0..3 {
                    let qk = quats[t[k] as usize];
                    let s = if dot4(qk, q0) < 0.0 { -w[k] } else { w[k] };
                    for c in 0..4 {
                        q[c] += s * qk[c];
                    }
                }
                let n = dot4(q, q).sqrt();
                let q = if n > 0.0 { q.map(|c| c / n) } else { [1.0, 0.0, 0.0, 0.0] };
                *frame = q;
                *out = add(*b, rotate(q, add(*d, *c)));
            });
        for (&v, t) in self.fine_handles.iter().zip(targets) {
            next[v as usize] = *t;
        }
        for &(v, p) in &self.pinned {
            next[v as usize] = p;
        }
        let bad = next.par_iter().position_any(|p| !p.iter().all(|c| c.is_finite()));
        self.next = next;
        if let Some(vertex) = bad {
            self.arap.set_positions(&self.coarse_before);
            self.settle_ready = false;
            return Err(SolveError::NonFiniteResult { vertex });
        }
        self.swap_next();
        let mut stats = stats;
        if self.fine_iterations > 0 {
            match self.run_fine(targets, self.fine_iterations) {
                Ok(st) => {
                    stats.fine_iterations = st.iterations;
                    stats.fine_energy = st.energy();
                    stats.fine_ms = st.total_ms();
                    stats.fine_unconverged = !self.fine_converged(&st);
                }
                Err(e) => {
                    // The previous pose, base and frames stay, as for a failed coarse solve.
                    self.swap_next();
                    self.arap.set_positions(&self.coarse_before);
                    self.settle_ready = false;
                    return Err(e);
                }
            }
        }
        self.last_targets.clear();
        self.last_targets.extend_from_slice(targets);
        self.settle_ready = stats.converged && stats.iterations > 0;
        self.last_energy = stats.energy();
        Ok(stats)
    }

    /// Exchanges the result, the deformed base and the frames with their scratch buffers.
    fn swap_next(&mut self) {
        std::mem::swap(&mut self.result, &mut self.next);
        std::mem::swap(&mut self.deformed_base, &mut self.next_base);
        std::mem::swap(&mut self.frames, &mut self.next_frames);
    }

    /// Refines the result of the last solve, whose handles have stopped at `targets`: runs
    /// [`BaseConfig::settle_iterations`] fine iterations from it, carried like the fine
    /// iterations of a solve. Call it again until the returned statistics say converged (the
    /// fine iterations no longer lower the energy by the tolerance per iteration): the pose
    /// approaches converged ARAP on the full mesh, the next solve goes on from it. `None`:
    /// nothing to settle (no settle iterations, other targets than the last solve's, a coarse
    /// solve that did not converge, or the rest pose, which is exact). The statistics have no
    /// coarse iteration and the last solve's coarse energy.
    pub fn settle(&mut self, targets: &[[f64; 3]]) -> Result<Option<SolveStats>, SolveError> {
        if !self.settle_pending() || self.last_targets != targets {
            return Ok(None);
        }
        let st = self.run_fine(targets, self.settle_iterations)?;
        Ok(Some(SolveStats {
            converged: self.fine_converged(&st),
            initial_energy: self.last_energy,
            fine_iterations: st.iterations,
            fine_energy: st.energy(),
            fine_ms: st.total_ms(),
            ..SolveStats::default()
        }))
    }

    /// Whether [`CoarseBsArap::settle`] at the last solve's targets would refine: settle
    /// iterations are set and the last solve converged away from rest.
    pub fn settle_pending(&self) -> bool {
        self.settle_iterations > 0 && self.settle_ready
    }

    /// `n` fine iterations ([`Arap::refine`]) from the current result, which they replace; what
    /// they changed is kept in the detail frames for the next solve (zero again when the result
    /// is the rest pose). On error the result is unchanged.
    fn run_fine(&mut self, targets: &[[f64; 3]], n: usize) -> Result<SolveStats, SolveError> {
        let Some(fine) = self.fine.as_mut() else {
            return Ok(SolveStats { converged: true, ..SolveStats::default() });
        };
        let st = fine.refine(&self.result, targets, n)?;
        self.result.copy_from_slice(fine.positions());
        self.correction
            .par_iter_mut()
            .zip(self.result.par_iter().zip(self.deformed_base.par_iter()))
            .zip(self.frames.par_iter().zip(self.details.par_iter()))
            .for_each(|((c, (x, b)), (q, d))| {
                let conj = [q[0], -q[1], -q[2], -q[3]];
                *c = sub(rotate(conj, sub(*x, *b)), *d);
            });
        Ok(st)
    }

    /// Whether fine iterations no longer lower the energy by the tolerance per iteration (then
    /// running them again at the same targets would change nothing). Without a tolerance
    /// (other stopping rules) or with a non-finite energy there is nothing to wait for: true.
    fn fine_converged(&self, st: &SolveStats) -> bool {
        let tol = self.arap.config().tolerance;
        let (e0, e1) = (st.initial_energy, st.energy());
        let per_iteration = (e0 - e1) / (e0 * st.iterations.max(1) as f64);
        tol <= 0.0 || e0 <= f64::MIN_POSITIVE || per_iteration.is_nan() || per_iteration < tol
    }

    /// The result of the last solve, `#V×3`.
    pub fn positions(&self) -> &[[f64; 3]] {
        &self.result
    }

    /// The base at rest as seen by the fine vertices (their points on $B_c$), `#V×3`.
    pub fn base(&self) -> &[[f64; 3]] {
        &self.base
    }

    /// The deformed base at the fine vertices, `#V×3`.
    pub fn deformed_base(&self) -> &[[f64; 3]] {
        &self.deformed_base
    }

    /// Details $D_i$, `#V×3`.
    pub fn details(&self) -> &[[f64; 3]] {
        &self.details
    }

    /// Milliseconds of each precomputation phase (faired base, decimation, coarse
    /// factorization, embedding, and the fine factorization with fine or settle iterations).
    pub fn precompute_phases(&self) -> &[(&'static str, f64)] {
        &self.phases
    }

    /// Vertices of the coarse base.
    pub fn coarse_vertices(&self) -> usize {
        self.arap.rest().len()
    }

    /// The ARAP solver on the coarse base.
    pub fn base_arap(&self) -> &Arap {
        &self.arap
    }

    /// Mutable access to the coarse solver (stopping rule).
    pub fn base_arap_mut(&mut self) -> &mut Arap {
        &mut self.arap
    }

    /// Restarts the next solve from rest.
    pub fn reset(&mut self) {
        self.arap.reset();
        self.correction.fill([0.0; 3]);
        self.last_targets.clear();
        self.settle_ready = false;
        if let Some(fine) = self.fine.as_mut() {
            fine.reset();
        }
    }
}

/// Wall-clock laps of the precomputation.
struct Phases {
    last: std::time::Instant,
    phases: Vec<(&'static str, f64)>,
}

impl Default for Phases {
    fn default() -> Self {
        Phases { last: std::time::Instant::now(), phases: Vec::new() }
    }
}

impl Phases {
    fn lap(&mut self, name: &'static str) {
        let now = std::time::Instant::now();
        self.phases.push((name, (now - self.last).as_secs_f64() * 1e3));
        self.last = now;
    }
}

#[inline]
fn blend(p: &[[f64; 3]], t: &[u32; 3], w: &[f64; 3]) -> [f64; 3] {
    let [a, b, c] = t.map(|v| p[v as usize]);
    std::array::from_fn(|d| w[0] * a[d] + w[1] * b[d] + w[2] * c[d])
}

#[inline]
fn dot4(a: [f64; 4], b: [f64; 4]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

/// Unit quaternion `[w, x, y, z]` of a row-major rotation matrix (glam's `DQuat::from_mat3`,
/// which takes columns, then normalized). Its sign is arbitrary: blending and [`rotate`] give
/// the same result for $q$ and $-q$.
pub fn quaternion_of(r: &Mat3) -> [f64; 4] {
    let q = glam::DQuat::from_mat3(&glam::DMat3::from_cols_array_2d(r).transpose()).normalize();
    [q.w, q.x, q.y, q.z]
}

/// $q\,v\,q^{-1}$ for a unit quaternion.
#[inline]
pub fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let u = [q[1], q[2], q[3]];
    let t = crate::geometry::mesh::cross(u, v).map(|c| 2.0 * c);
    let ut = crate::geometry::mesh::cross(u, t);
    std::array::from_fn(|d| v[d] + q[0] * t[d] + ut[d])
}

/// Closest point of triangle `(a, b, c)` to `p` and its barycentric weights (Ericson,
/// Real-Time Collision Detection, §5.1.5: Voronoi regions of vertices, edges, face).
pub fn closest_point_on_triangle(p: [f64; 3], [a, b, c]: [[f64; 3]; 3]) -> ([f64; 3], [f64; 3]) {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (add(a, ab.map(|x| x * v)), [1.0 - v, v, 0.0]);
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (add(a, ac.map(|x| x * w)), [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (add(b, sub(c, b).map(|x| x * w)), [0.0, 1.0 - w, w]);
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (add(a, add(ab.map(|x| x * v), ac.map(|x| x * w))), [1.0 - v - w, v, w])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::rotation::axis_angle;

    /// The automatic coarse size is min(3000, 0.3 n) (at least 16), and it is what the base
    /// is decimated to when no size is set; a set size is kept.
    #[test]
    fn automatic_coarse_size() {
        assert_eq!(BaseConfig::auto_coarse_vertices(6669), 2000);
        assert_eq!(BaseConfig::auto_coarse_vertices(43243), 3000);
        assert_eq!(BaseConfig::auto_coarse_vertices(20), 16);
        let (mesh, handles) = crate::geometry::shapes::bumpy_bar(3);
        let n = mesh.n_vertices();
        let config = ArapConfig::default();
        let auto = CoarseBsArap::new(&mesh, &handles, &config, &BaseConfig::default()).unwrap();
        let expected = BaseConfig::auto_coarse_vertices(n);
        assert!(expected < n / 2);
        assert!(auto.coarse_vertices().abs_diff(expected) <= expected / 20, "{expected}");
        let set = BaseConfig { coarse_vertices: Some(n / 8), ..Default::default() };
        let explicit = CoarseBsArap::new(&mesh, &handles, &config, &set).unwrap();
        assert!(explicit.coarse_vertices().abs_diff(n / 8) <= n / 160, "{}", n / 8);
    }

    #[test]
    fn quaternions_round_trip() {
        for (axis, angle) in
            [([1.0, 0.0, 0.0], 0.3), ([0.2, -1.0, 0.5], 2.9), ([0.0, 0.0, 1.0], 3.0)]
        {
            let r = axis_angle(axis, angle);
            let q = quaternion_of(&r);
            let v = [0.3, -0.7, 1.1];
            let a = rotate(q, v);
            let b = crate::linalg::rotation::mul_vec(&r, v);
            for d in 0..3 {
                assert!((a[d] - b[d]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn closest_point_regions() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let (p, w) = closest_point_on_triangle([0.2, 0.3, 5.0], t);
        assert!((p[0] - 0.2).abs() < 1e-15 && (p[1] - 0.3).abs() < 1e-15 && p[2] == 0.0);
        assert!((w[0] - 0.5).abs() < 1e-15);
        assert_eq!(closest_point_on_triangle([-1.0, -1.0, 0.0], t).1, [1.0, 0.0, 0.0]);
        let (_, w) = closest_point_on_triangle([2.0, 2.0, 0.0], t);
        assert!((w[1] - 0.5).abs() < 1e-15 && (w[2] - 0.5).abs() < 1e-15);
    }
}
