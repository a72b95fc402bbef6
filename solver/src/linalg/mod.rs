//! Linear algebra the solvers share: sparse SPD factorizations kept for reuse, Anderson
//! acceleration of fixed-point iterations, the closest rotation to a 3×3 covariance, the best
//! rigid motion between point sets, the four-lane arithmetic that fit runs on, and two-grid
//! conjugate gradients for a dense mesh's solves without its factorization.

pub mod anderson;
pub(crate) mod lanes;
pub mod linsolve;
pub mod rigid;
pub mod rotation;
pub mod two_grid;
