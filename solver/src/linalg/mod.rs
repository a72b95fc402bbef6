//! Linear algebra the solvers share: sparse SPD factorizations kept for reuse, Anderson
//! acceleration of fixed-point iterations, the closest rotation to a 3×3 covariance, the best
//! rigid motion between point sets, and the four-lane arithmetic that fit runs on.

pub mod anderson;
pub(crate) mod lanes;
pub mod linsolve;
pub mod rigid;
pub mod rotation;
