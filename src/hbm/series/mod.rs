//! The series room: one periodic steady state as truncated Fourier series
//! `p_k = a_k0 + Σ_{h=1..H} a_kh cos hω₀t + b_kh sin hω₀t` and what is read from it. It holds
//! the real FFTs of alternating frequency/time and the trigonometric interpolation (`aft`), the
//! solution record [`HbmSolution`] with its read-outs (harmonic amplitudes, synthesis, true
//! peaks by Clenshaw's recurrence and Newton's method, element torques; `solution`), the joint
//! reactions and mesh torques as order harmonics (`reaction`), and the Floquet record a
//! solution carries (`floquet`). It uses no other room.

mod aft;
mod floquet;
mod reaction;
mod solution;

pub(in crate::hbm) use aft::{Aft, Upsampler, cos_sin};
pub(in crate::hbm) use floquet::PairSense;
pub use floquet::{FloquetBlock, Stability};
pub use reaction::{MeshTorqueHarmonics, ReactionHarmonics};
pub use solution::HbmSolution;
