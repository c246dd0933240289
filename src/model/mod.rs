//! What the user describes, as data: vectors and inertia, shapes and bodies, joints, loads and
//! excitations, the choice of generalized speeds, and the validated [`mechanism::Mechanism`].
//!
//! Nothing here evaluates dynamics; reading files into these types is [`crate::load`]'s work and
//! turning them into equations of motion is [`crate::kane`]'s. Design notes: `docs/design/model.md`
//! (the mechanism, couplings, gears, loads) and `docs/design/paths.md` (path joints, absorbers,
//! rollers).

pub mod absorber;
pub mod body;
pub mod coupling;
pub mod excitation;
pub mod geared;
pub mod gears;
pub mod inertia;
pub mod joint;
pub mod loads;
pub mod math;
pub mod mechanism;
pub mod path;
pub mod ranges;
pub mod shape;
pub mod sincos;
pub mod speeds;
pub mod time_scales;
