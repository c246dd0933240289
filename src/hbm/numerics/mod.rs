//! The numerics room: the linear-algebra and root-finding kernels the harmonic balance rests
//! on, free of it: LU with partial pivoting that also solves with the transpose (`lu`, for the
//! fold curves' bordered matrices), block Gaussian elimination along the mechanism's tree with
//! Schur complements (`blocklu`, for the Jacobian and its bordered forms), and the Illinois
//! variant of regula falsi (`illinois`, for every located fold, branch point and cusp). It uses
//! no other room.

mod blocklu;
mod illinois;
mod lu;

pub(in crate::hbm) use blocklu::{BlockLu, Factor};
pub(in crate::hbm) use illinois::Illinois;
pub(in crate::hbm) use lu::DenseLu;
