//! The time domain: DOP853 integration of `ẋ = [W⁻¹u; M⁻¹F]` with a fixed-rate sampler
//! ([`integrate`]), the probes that turn sampled states into named signals and the one
//! `simulate` ([`probe`]), and steady-state detection by windows ([`steady`]). Beside them: the
//! drive laws of driven runs (torques locked to a crank angle, a prescribed speed:
//! [`drive_laws`]), the DOP853 stepping loop (`dop853.rs`, its step in `dp8.rs`), the Radau IIA
//! loop (`radau.rs`), the state and right-hand-side plumbing both loops share (`system.rs`), and
//! what one integration run takes and gives (`run.rs`, re-exported by [`integrate`]). Design
//! notes: `docs/design/time.md`.

mod dop853;
mod dp8;
pub mod drive_laws;
pub mod integrate;
pub mod probe;
mod radau;
mod run;
pub mod steady;
mod system;
