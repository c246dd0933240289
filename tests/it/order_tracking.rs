//! Order tracking against synthetic signals whose order amplitudes are known exactly: fixed and
//! swept orders, a fluctuating rotor speed, and the two methods against each other.
//!
//! The study's accuracy budget for order traces is 0.5 % (Figures 3–5 are read to a few per cent).
//! The expected errors are far smaller, so the tests hold the code to 6e-4 (`TOL`): the Hann 5-bin sum is exact on a bin and
//! 2.6e-4 low half a bin off; the sweep moves the line by at most 0.11 Hz (2n) within a 2 s window,
//! a fifth of a bin; cubic resampling lowers order 6.6 by ~1.8e-4 (rms gain of the interpolant). Each test prints its worst error.

use crate::support::swept_signal;
use approx::{abs_diff_eq, assert_abs_diff_eq};

use kanedyn::model::excitation::{Order, rpm_to_rad_s};
use kanedyn::signal::{
    AngleOptions, OrderTrace, SignalError, StftOptions, angle_domain_order_traces, resample_at_constant_angle,
    stft_order_traces,
};
use std::f64::consts::PI;
use swept_signal::{FS, swept_signal, times};

/// The study's accuracy budget for order traces, 0.5 %.
const BUDGET: f64 = 5e-3;
/// What the analysis predicts, and what the tests hold the code to: 2.6e-4 (Hann 5-bin sum half a
/// bin off) + 1.8e-4 (Catmull–Rom gain at order 6.6) with margin. A linear resampler (−0.99 % at
/// order 6.6) or a wrong calibration fails this.
const TOL: f64 = 6e-4;

/// Largest relative error of `trace` against `truth(order n)` over all windows.
fn worst_error(trace: &OrderTrace, truth: impl Fn(f64) -> f64) -> f64 {
    trace.order.iter().zip(&trace.amplitude).map(|(&n, &a)| (a / truth(n) - 1.0).abs()).fold(0.0, f64::max)
}

const _: () = assert!(TOL < BUDGET);

/// (a) A fixed order 3 at 1000 rpm (on a bin: 50 Hz, 0.5 Hz bins) and order 3.11 (51.83 Hz, a third
/// of a bin off), amplitude 7.3 with a DC offset of 2.5: both methods recover 7.3 to 0.5 %.
#[test]
fn fixed_order_both_methods() {
    let omega = rpm_to_rad_s(1000.0);
    let t = times(20.0);
    let theta: Vec<f64> = t.iter().map(|&t| omega * t).collect();
    for n in [3.0, 3.11] {
        let x: Vec<f64> = theta.iter().map(|&th| 2.5 + 7.3 * (n * th + 0.3).sin()).collect();
        let stft = stft_order_traces(&x, FS, omega, &|_| n, &[1.0], &StftOptions::default()).unwrap();
        let angle = angle_domain_order_traces(&x, &theta, FS, &|_| n, &[1.0], &AngleOptions::default()).unwrap();
        // 20 s: (20 − 2)/0.25 + 1 = 73 windows; 333 revs: (333 − 32)/4 + 1 = 76 blocks.
        assert_eq!(stft[0].len(), 73);
        assert_eq!(angle[0].len(), 76);
        let (es, ea) = (worst_error(&stft[0], |_| 7.3), worst_error(&angle[0], |_| 7.3));
        println!("fixed n = {n}: worst STFT error {es:.2e}, angle-domain {ea:.2e}");
        assert!(es < TOL && ea < TOL, "n = {n}: {es:e}, {ea:e}");
        // On a bin both methods are exact to rounding (order 3·32 = bin 96 in the angle domain).
        if n == 3.0 {
            assert!(es < 1e-9, "{es:e}");
        }
        assert_abs_diff_eq!(stft[0].freq_hz[0], n * omega / (2.0 * PI), epsilon = 1e-12);
        assert_abs_diff_eq!(angle[0].freq_hz[0] / (n * omega / (2.0 * PI)), 1.0, epsilon = 1e-9);
        // Window centre times: t_c = (start + N/2)/fs.
        assert_abs_diff_eq!(stft[0].time_s[0], 1.0, epsilon = 1e-12);
        assert_abs_diff_eq!(stft[0].time_s[1], 1.25, epsilon = 1e-12);
    }
}

/// (b) Constant amplitudes 5 (order n) and 1.5 (order 2n) on the 2.9 → 3.3 sweep: every window of
/// both methods within 0.5 %.
#[test]
fn swept_order_both_methods() {
    let (order, omega, x, theta) = swept_signal(|_| 5.0, |_| 1.5);
    let n_at = |t: f64| order.at(t);
    let stft = stft_order_traces(&x, FS, omega, &n_at, &[1.0, 2.0], &StftOptions::default()).unwrap();
    let angle = angle_domain_order_traces(&x, &theta, FS, &n_at, &[1.0, 2.0], &AngleOptions::default()).unwrap();
    assert_eq!(stft[0].len(), 953); // (240 − 2)/0.25 + 1
    let (s1, s2) = (worst_error(&stft[0], |_| 5.0), worst_error(&stft[1], |_| 1.5));
    let (a1, a2) = (worst_error(&angle[0], |_| 5.0), worst_error(&angle[1], |_| 1.5));
    println!("sweep: STFT worst {s1:.2e} (n), {s2:.2e} (2n); angle-domain {a1:.2e} (n), {a2:.2e} (2n)");
    for e in [s1, s2, a1, a2] {
        assert!(e < TOL, "{e:e}");
    }
    // The traces span the sweep: first window centred at 1 s (n = 2.9017), last at 239 s.
    assert_abs_diff_eq!(stft[0].order[0], order.at(1.0), epsilon = 1e-12);
    assert_abs_diff_eq!(stft[1].freq_hz[952], 2.0 * order.at(239.0) * omega / (2.0 * PI), epsilon = 1e-9);
}

/// (c) A rotor whose speed fluctuates at 3Ω (θ = Ωt + 0.01 sin 3Ωt, 3 % speed ripple) and a
/// signal periodic in angle, `2.5 + 5 sin 3θ + 1.5 sin(6θ − 0.32)`: the angle-domain method sees
/// clean orders 3 and 6 and recovers both amplitudes; it also inverts θ (block centre times).
#[test]
fn angle_domain_with_speed_fluctuation() {
    let omega = rpm_to_rad_s(1000.0);
    let t = times(30.0);
    let theta: Vec<f64> = t.iter().map(|&t| omega * t + 0.01 * (3.0 * omega * t).sin()).collect();
    let x: Vec<f64> = theta.iter().map(|&th| 2.5 + 5.0 * (3.0 * th).sin() + 1.5 * (6.0 * th - 0.32).sin()).collect();
    let angle = angle_domain_order_traces(&x, &theta, FS, &|_| 3.0, &[1.0, 2.0], &AngleOptions::default()).unwrap();
    let (e1, e2) = (worst_error(&angle[0], |_| 5.0), worst_error(&angle[1], |_| 1.5));
    println!("fluctuating speed, angle domain: worst {e1:.2e} (order 3), {e2:.2e} (order 6)");
    assert!(e1 < TOL && e2 < TOL, "{e1:e}, {e2:e}");

    // θ⁻¹: the block centre angle θ(t_c) must be θ₀ + (start + M/2)·2π/64 to interpolation accuracy.
    let r = resample_at_constant_angle(&x, &theta, FS, 64).unwrap();
    let worst_theta = r
        .time_s
        .iter()
        .enumerate()
        .map(|(j, &tj)| {
            let exact = omega * tj + 0.01 * (3.0 * omega * tj).sin();
            (exact - (r.theta0_rad + j as f64 * 2.0 * PI / 64.0)).abs()
        })
        .fold(0.0, f64::max);
    // Catmull–Rom is third order: error ≤ 0.016·h³|θ‴| = 0.016·(0.5 ms)³·0.27·Ω³ = 6.2e-7 rad
    // (order 6 then shifts phase by 4e-6 rad, harmless).
    println!("θ⁻¹ worst angle error {worst_theta:.2e} rad");
    assert!(worst_theta < 7e-7, "{worst_theta:e}");
}

/// (d) Order-dependent amplitudes, an absorber-like notch `A₁ = 0.5 + 40(n − 3.11)²` and
/// `A₂ = 1.5 + 10(n − 3.2)²`: both methods follow the truth at their own centre times, agree with
/// each other at equal orders, and `OrderTrace::min` finds the notch at n = 3.11 with A = 0.5.
#[test]
fn methods_agree_on_a_swept_notch() {
    let a1 = |n: f64| 0.5 + 40.0 * (n - 3.11) * (n - 3.11);
    let a2 = |n: f64| 1.5 + 10.0 * (n - 3.2) * (n - 3.2);
    let (order, omega, x, theta) = swept_signal(a1, a2);
    let n_at = |t: f64| order.at(t);
    let stft = stft_order_traces(&x, FS, omega, &n_at, &[1.0, 2.0], &StftOptions::default()).unwrap();
    let angle = angle_domain_order_traces(&x, &theta, FS, &n_at, &[1.0, 2.0], &AngleOptions::default()).unwrap();
    let mut worst_truth: f64 = 0.0;
    for (traces, truth) in [(&stft, [a1, a2]), (&angle, [a1, a2])] {
        worst_truth = worst_truth.max(worst_error(&traces[0], truth[0])).max(worst_error(&traces[1], truth[1]));
    }
    let mut worst_agree: f64 = 0.0;
    for m in 0..2 {
        for (&n, &a) in angle[m].order.iter().zip(&angle[m].amplitude) {
            if let Some(s) = stft[m].amplitude_at_order(n) {
                worst_agree = worst_agree.max((a / s - 1.0).abs());
            }
        }
    }
    let (ms, ma) = (stft[0].min().unwrap(), angle[0].min().unwrap());
    println!(
        "notch: worst error vs truth {worst_truth:.2e}, methods differ by ≤ {worst_agree:.2e}; \
         STFT min {:.5} at n = {:.5}, angle-domain min {:.5} at n = {:.5}",
        ms.amplitude, ms.order, ma.amplitude, ma.order
    );
    assert!(worst_truth < TOL, "{worst_truth:e}");
    assert!(worst_agree < TOL, "{worst_agree:e}");
    // The minimum window sits within one hop of the notch (hops are 4.2e-4 and ~4e-4 in order).
    for p in [ms, ma] {
        assert!(abs_diff_eq!(p.order, 3.11, epsilon = 5e-4), "{p:?}");
        assert!(abs_diff_eq!(p.amplitude / 0.5, 1.0, epsilon = TOL), "{p:?}");
    }
}

/// Bad input gives a clear error, never a panic.
#[test]
fn errors_are_reported() {
    let omega = rpm_to_rad_s(1000.0);
    let x = vec![0.0; 3000];
    let opts = StftOptions::default();
    let e = stft_order_traces(&x, FS, omega, &|_| 3.0, &[1.0], &opts).unwrap_err();
    assert_eq!(e, SignalError::TooShort { what: "signal", got: 3000, needed: 4000 });
    let x = vec![0.0; 8000];
    assert!(matches!(
        stft_order_traces(&x, 0.0, omega, &|_| 3.0, &[1.0], &opts),
        Err(SignalError::InvalidParameter { name: "fs_hz", .. })
    ));
    assert!(matches!(
        stft_order_traces(&x, -FS, omega, &|_| 3.0, &[1.0], &opts),
        Err(SignalError::InvalidParameter { name: "fs_hz", .. })
    ));
    assert_eq!(stft_order_traces(&x, FS, omega, &|_| 3.0, &[], &opts), Err(SignalError::NoMultiples));
    // Order 40 at 1000 rpm: 667 Hz is fine, but 2·667 Hz is beyond the 1000 Hz Nyquist frequency.
    let e = stft_order_traces(&x, FS, omega, &|_| 40.0, &[1.0, 2.0], &opts).unwrap_err();
    assert!(matches!(e, SignalError::OutOfBand { multiple: 2.0, .. }), "{e}");
    println!("{e}");
    assert!(matches!(
        stft_order_traces(&x, FS, omega, &|_| f64::NAN, &[1.0], &opts),
        Err(SignalError::BadOrder { .. })
    ));
    let mut bad = x.clone();
    bad[17] = f64::INFINITY;
    assert!(matches!(
        stft_order_traces(&bad, FS, omega, &|_| 3.0, &[1.0], &opts),
        Err(SignalError::NonFinite { what: "signal", index: 17, .. })
    ));

    let aopts = AngleOptions::default();
    let theta: Vec<f64> = (0..8000).map(|i| omega * i as f64 / FS).collect();
    assert_eq!(
        angle_domain_order_traces(&x, &theta[..7999], FS, &|_| 3.0, &[1.0], &aopts),
        Err(SignalError::LengthMismatch { signal: 8000, theta: 7999 })
    );
    // 4 s at 1000 rpm is 66 revs, enough for a 32-rev block; order 40 is beyond order 32 (P/2).
    let e = angle_domain_order_traces(&x, &theta, FS, &|_| 40.0, &[1.0], &aopts).unwrap_err();
    assert!(matches!(e, SignalError::OutOfBand { unit: "orders", .. }), "{e}");
    // 1 s is 16.7 revs, less than one block of 32.
    assert!(matches!(
        angle_domain_order_traces(&x[..2000], &theta[..2000], FS, &|_| 3.0, &[1.0], &aopts),
        Err(SignalError::TooShort { what: "angle-resampled signal", .. })
    ));
    let mut back = theta.clone();
    back[100] = back[99];
    assert!(matches!(
        angle_domain_order_traces(&x, &back, FS, &|_| 3.0, &[1.0], &aopts),
        Err(SignalError::NotIncreasing { index: 99, .. })
    ));
}

/// The two methods on a simulated sweep (not a synthetic signal): the canonical CPVA, 40 N·m, n
/// from 2.9 to 3.3 over 240 s at 1000 rpm (the paper's sweep), rotor acceleration and angle from the generic engine.
/// The STFT uses Ω nominal, the angle domain the simulated θ(t); the rotor speed ripples by
/// ~1e-4 of Ω, so both see the same lines. Both windows are ~2 s long (32 revs = 1.92 s).
/// The first 20 s are skipped: the start transient (pendulum free motion, decay time ~6 s) still
/// beats with the tiny second order there. Between n_t and the end of the ripple after n_r
/// (3.05 < n < 3.25) the amplitude changes by up to tens of per cent within one window, and the
/// two windows (2 s in time, 32 revolutions in angle) weigh that change differently: 10 % is
/// asserted there (4 % measured). Elsewhere, where the amplitude also changes by less than 20 %
/// per 0.01 of order, they must agree to 0.5 %, the bound.
#[test]
fn both_methods_agree_on_a_simulated_sweep() {
    use kanedyn::cpva::CpvaParams;
    use kanedyn::kane::Kane;
    use kanedyn::model::excitation::{Excitation, Harmonic};
    use kanedyn::time::integrate::{IntegrateOptions, integrate};
    let w = rpm_to_rad_s(1000.0);
    let order = Order::Sweep { from: 2.9, to: 3.3, duration_s: 240.0 };
    let exc = Excitation {
        mean: 5e-3 * w,
        rpm: 1000.0,
        order,
        harmonics: vec![Harmonic { multiple: 1.0, amplitude: 40.0, phase: 0.0 }],
        ramp_s: 2.0,
    };
    let mech = CpvaParams::canonical().mechanism(Some(exc)).unwrap();
    let mut kane = Kane::new(&mech).unwrap();
    let opts = IntegrateOptions { sample_derivatives: true, ..IntegrateOptions::default() };
    let (mut acc, mut theta) = (Vec::new(), Vec::new());
    integrate(
        |t, x, d| kane.rhs(t, x, d),
        &[0.0, 0.0, w, w],
        0.0,
        240.0,
        &opts,
        |s| {
            acc.push(s.xdot.unwrap()[2]);
            theta.push(s.x[0]);
        },
    )
    .unwrap();
    let fs = 2000.0;
    let at = |t: f64| order.at(t);
    let stft = stft_order_traces(&acc, fs, w, &at, &[1.0, 2.0], &StftOptions::default()).unwrap();
    let ang = angle_domain_order_traces(&acc, &theta, fs, &at, &[1.0, 2.0], &AngleOptions::default()).unwrap();
    let (mut worst_smooth, mut compared) = (0.0f64, 0);
    for (s, a) in stft.iter().zip(&ang) {
        for i in 0..a.len() {
            let (n, amp) = (a.order[i], a.amplitude[i]);
            if a.time_s[i] < 20.0 || a.time_s[i] > 237.0 {
                continue;
            }
            let Some(ref_amp) = s.amplitude_at_order(n) else { continue };
            // Time and angle differ by the rotor's angle ripple δθ ≈ 7e-5 rad here, which moves
            // ~n·δθ/2 ≈ 1e-4 of the main order onto its neighbours in one domain and not in the
            // other; so compare only lines at least 3 % of the main order (at 40 N·m the second
            // order is 1e-3 of the main order for most of the sweep).
            let main = stft[0].amplitude_at_order(n).unwrap_or(f64::INFINITY);
            if ref_amp < 0.03 * main {
                continue;
            }
            let rel = (amp - ref_amp).abs() / ref_amp;
            assert!(rel < 0.1, "m = {}, n = {n}: angle {amp} vs STFT {ref_amp}", s.multiple);
            // Smoothness of the true amplitude around n, judged on the STFT trace itself.
            let (lo, hi) = (s.amplitude_at_order(n - 0.005), s.amplitude_at_order(n + 0.005));
            // Away from the notch at n_t, the resonance at n_r and the ripple after the jump
            // (n in 3.05..3.25), where the amplitude changes fast within a window.
            if let (Some(lo), Some(hi)) = (lo, hi)
                && (hi / lo).ln().abs() < 0.2f64.ln_1p()
                && !(3.05..3.25).contains(&n)
            {
                worst_smooth = worst_smooth.max(rel);
                compared += 1;
            }
        }
    }
    eprintln!("smooth windows: {compared}, worst {worst_smooth:e}");
    assert!(compared > 300, "only {compared} smooth windows compared");
    assert!(worst_smooth < 0.005, "smooth regions differ by {worst_smooth}");
}

/// Issue 11: a tracked line, window or block too large to count in integers is refused with an
/// error (a study `rpm`, `order_max` or `multiple` of ~1e19 reaches these functions unchanged).
#[test]
fn overflowing_sizes_are_refused() {
    let x = vec![0.0; 16];
    let opts = StftOptions { window_s: 1.0, hop_s: 1.0, half_width_bins: 2 };
    // Used to: panic "slice index out of range" (debug: "attempt to add with overflow") in
    // HannSpectrum::band: the line at 1e20 bins saturated `as i64`, `k + half` wrapped negative
    // and the band was accepted.
    for (omega, order, multiple) in
        [(2.0 * PI, 1.0, 1e20), (2.0 * PI, 1e20, 1.0), (1e20, 1.0, 1.0), (1e200, 1e200, 1.0)]
    {
        let e = stft_order_traces(&x, 16.0, omega, &|_| order, &[multiple], &opts).unwrap_err();
        assert!(matches!(e, SignalError::OutOfBand { hi: i64::MAX, last: 7, .. }), "{e}");
    }
    // Used to: the same panic in the angle domain (order 1e20 is bin 4e20 of a 4-rev block).
    let theta: Vec<f64> = (0..64).map(|i| i as f64 * 0.5).collect();
    let aopts = AngleOptions { samples_per_rev: 4, revs_per_block: 4, hop_revs: 1.0, half_width_bins: 2 };
    let e = angle_domain_order_traces(&vec![0.0; 64], &theta, 1.0, &|_| 1.0, &[1e20], &aopts).unwrap_err();
    assert!(matches!(e, SignalError::OutOfBand { unit: "orders", hi: i64::MAX, .. }), "{e}");

    // A 1e12-sample window is refused by the MAX_POINTS cap, whatever the signal length.
    let big = StftOptions { window_s: 1e12, ..opts };
    let e = stft_order_traces(&x, 1.0, 1.0, &|_| 1.0, &[1.0], &big).unwrap_err();
    assert!(matches!(e, SignalError::InvalidParameter { name: "window_s", .. }), "{e}");
    let inf = StftOptions { window_s: 1e300, ..opts };
    let e = stft_order_traces(&x, 1e300, 1.0, &|_| 1.0, &[1.0], &inf).unwrap_err();
    assert!(matches!(e, SignalError::InvalidParameter { name: "window_s", .. }), "{e}");
    // A hop of 1e300 s is one window.
    let long_hop = StftOptions { window_s: 1.0, hop_s: 1e300, half_width_bins: 2 };
    let t = stft_order_traces(&x, 16.0, 2.0 * PI, &|_| 3.0, &[1.0], &long_hop).unwrap();
    assert_eq!(t[0].len(), 1);

    // Used to: abort the process ("memory allocation of … bytes failed"): θ spanning 1e12 rad
    // asked for 6.4e11 resampled points.
    let e = resample_at_constant_angle(&[0.0, 0.0], &[0.0, 1e12], 1.0, 4).unwrap_err();
    assert!(matches!(e, SignalError::InvalidParameter { name: "samples_per_rev", .. }), "{e}");
    // Used to: panic "attempt to add with overflow" (debug; release wrapped to an empty result):
    // the count 6e299 saturated `as usize` and `+ 1` wrapped.
    let e = resample_at_constant_angle(&[0.0, 0.0], &[0.0, 1e300], 1.0, 4).unwrap_err();
    assert!(matches!(e, SignalError::InvalidParameter { name: "samples_per_rev", .. }), "{e}");
    // θ from −1e308 to 1e308: the span itself overflows to inf.
    let e = resample_at_constant_angle(&[0.0, 0.0], &[-1e308, 1e308], 1.0, 4).unwrap_err();
    assert!(matches!(e, SignalError::InvalidParameter { name: "samples_per_rev", .. }), "{e}");
    // Used to: abort the process: 2^62 points per revolution over 1 rad.
    let e = resample_at_constant_angle(&[0.0, 0.0], &[0.0, 1.0], 1.0, 1 << 62).unwrap_err();
    assert!(matches!(e, SignalError::InvalidParameter { name: "samples_per_rev", .. }), "{e}");

    // Used to: panic "attempt to multiply with overflow" (debug; release wrapped `R·P` to 2^40
    // points and reported a short signal): 2^40 points per revolution over 1e-9 rad is 175
    // points, and R·P = (2^24 + 1)·2^40 overflows.
    let huge =
        AngleOptions { samples_per_rev: 1 << 40, revs_per_block: (1 << 24) + 1, hop_revs: 1.0, half_width_bins: 2 };
    let e = angle_domain_order_traces(&[0.0, 0.0], &[0.0, 1e-9], 1.0, &|_| 1.0, &[1.0], &huge).unwrap_err();
    assert!(matches!(e, SignalError::InvalidParameter { name: "revs_per_block", .. }), "{e}");
    // A hop of 1e300 revolutions is one block.
    let long_hop = AngleOptions { hop_revs: 1e300, ..aopts };
    let t = angle_domain_order_traces(&vec![0.0; 64], &theta, 1.0, &|_| 1.0, &[1.0], &long_hop).unwrap();
    assert_eq!(t[0].len(), 1);
}
