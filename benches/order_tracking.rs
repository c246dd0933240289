//! Timing of order tracking on the paper's sweep signal: 240 s at 2 kHz, n 2.9 → 3.3 at
//! 1000 rpm, two multiples (n and 2n), by the STFT (953 windows) and in the angle domain (993
//! blocks); the best of 20 runs of each, since the machine may be shared. The signal is the
//! synthetic one of tests/it/order_tracking.rs (`tests/it/support/swept_signal.rs`).
//!
//! ```text
//! cargo bench --bench order_tracking
//! ```

#[path = "../tests/it/support/swept_signal.rs"]
mod swept_signal;

use kanedyn::signal::{AngleOptions, StftOptions, angle_domain_order_traces, stft_order_traces};
use std::time::Instant;
use swept_signal::{FS, swept_signal};

fn main() {
    let (order, omega, x, theta) = swept_signal(|_| 5.0, |_| 1.5);
    let n_at = |t: f64| order.at(t);
    let (mut best_s, mut best_a) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..20 {
        let t0 = Instant::now();
        let s = stft_order_traces(&x, FS, omega, &n_at, &[1.0, 2.0], &StftOptions::default()).unwrap();
        let t1 = Instant::now();
        let a = angle_domain_order_traces(&x, &theta, FS, &n_at, &[1.0, 2.0], &AngleOptions::default()).unwrap();
        let t2 = Instant::now();
        assert_eq!((s[0].len(), a[0].len()), (953, 993), "windows and blocks of the 240 s signal");
        best_s = best_s.min((t1 - t0).as_secs_f64() * 1e3);
        best_a = best_a.min((t2 - t1).as_secs_f64() * 1e3);
    }
    println!("order_tracking (best of 20): STFT 953 windows: {best_s:.2} ms; angle domain 993 blocks: {best_a:.2} ms");
}
