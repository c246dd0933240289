//! Signal processing: STFT order tracking and angle-domain order tracking (being written).
