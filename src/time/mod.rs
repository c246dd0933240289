//! The time domain: DOP853 integration of `ẋ = [W⁻¹u; M⁻¹F]` with a fixed-rate sampler
//! ([`integrate`]), the probes that turn sampled states into named signals and the one
//! `simulate` ([`probe`]), and steady-state detection by windows ([`steady`]).

pub mod drive;
mod driver;
pub mod integrate;
pub mod probe;
mod solver;
pub mod steady;
