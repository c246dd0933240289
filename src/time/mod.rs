//! The time domain: DOP853 integration of `ẋ = [W⁻¹u; M⁻¹F]` with a fixed-rate sampler
//! ([`integrate`]), and the probes that turn sampled states into named signals ([`probe`]).

pub mod integrate;
pub mod probe;
