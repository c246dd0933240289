//! Time integration (DOP853) with a streaming fixed-rate sampler (being written).
