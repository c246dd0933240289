//! Sines and cosines of many angles at once: [`sin_cos_many`].
//!
//! Method: on x86-64 with AVX2 and FMA (detected at run time), four angles per vector.
//! Cody–Waite reduction `r = |x| − k·π/2` with π/2 split in three doubles (the first product
//! exact inside a fused multiply-add, the second carried as a double-double by Knuth's two-sum),
//! so r is known to about 2⁻¹⁰⁶ of itself; then the Taylor series of sin and cos on
//! |r| ≤ π/4 + ε, through r¹⁷ and r¹⁶ (the first omitted terms are below 10⁻¹⁹ of the result),
//! with the low part of r carried to first order and `1 − r²/2` summed in two parts as in
//! fdlibm's kernel; the quadrant k mod 4 picks and signs the results. Angles beyond
//! [`KERNEL_LIMIT`], infinities and NaNs take `f64::sin_cos` (the whole vector), and so does
//! every angle on other machines. Accuracy against `f64::sin_cos`: see the tests.

/// Angles of larger magnitude (rad) take `f64::sin_cos`: the kernel's quadrant index must stay
/// an exact small integer, and the reduction's third part of π/2 its error far below an ulp.
pub const KERNEL_LIMIT: f64 = 1.0e6;

/// `(sin x_i, cos x_i)` into `sin[i]`, `cos[i]` for every angle `x_i` of `x` (rad); the three
/// slices have one length.
///
/// NOTE: hand-written rather than a crate's: `wide`'s `f64x4::sin_cos` chooses its instructions
/// when the crate is compiled, which for this project's baseline x86-64 build is two SSE2 lanes
/// with unfused multiply-adds and a scalar rounding, and libm has no vector entry point here; the
/// time per angle of each is measured in BENCHMARKS.md ("Whole process, the 60 s sweep of 32
/// pendulums: where the time went").
pub fn sin_cos_many(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    assert!(x.len() == sin.len() && x.len() == cos.len(), "sin_cos_many: slices of different lengths");
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the features the function is compiled for were just detected.
        unsafe { avx2::sin_cos_many(x, sin, cos) };
        return;
    }
    for ((x, s), c) in x.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
        (*s, *c) = x.sin_cos();
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::KERNEL_LIMIT;
    use std::arch::x86_64::*;

    /// π/2 as the unevaluated sum `P1 + P2 + P3` (each the double nearest the remainder).
    const P1: f64 = std::f64::consts::FRAC_PI_2;
    const P2: f64 = 6.123233995736766e-17;
    const P3: f64 = -1.4973849048591698e-33;

    /// 1/k! (exact factorials, one rounding each).
    const fn inv_fact(k: u32) -> f64 {
        let mut f = 1.0;
        let mut i = 2;
        while i <= k {
            f *= i as f64;
            i += 1;
        }
        1.0 / f
    }

    /// Four lanes at a time; the last partial vector is padded with zeros.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn sin_cos_many(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
        let n = x.len();
        let mut i = 0;
        while i + 4 <= n {
            // SAFETY: i + 4 ≤ n for all three slices.
            unsafe {
                let v = _mm256_loadu_pd(x.as_ptr().add(i));
                if let Some((s, c)) = sin_cos4(v) {
                    _mm256_storeu_pd(sin.as_mut_ptr().add(i), s);
                    _mm256_storeu_pd(cos.as_mut_ptr().add(i), c);
                } else {
                    for j in i..i + 4 {
                        (sin[j], cos[j]) = x[j].sin_cos();
                    }
                }
            }
            i += 4;
        }
        if i < n {
            let mut buf = [0.0; 4];
            buf[..n - i].copy_from_slice(&x[i..]);
            let (mut s4, mut c4) = ([0.0; 4], [0.0; 4]);
            // SAFETY: the buffers have four entries.
            unsafe {
                if let Some((s, c)) = sin_cos4(_mm256_loadu_pd(buf.as_ptr())) {
                    _mm256_storeu_pd(s4.as_mut_ptr(), s);
                    _mm256_storeu_pd(c4.as_mut_ptr(), c);
                } else {
                    for j in 0..n - i {
                        (s4[j], c4[j]) = buf[j].sin_cos();
                    }
                }
            }
            sin[i..].copy_from_slice(&s4[..n - i]);
            cos[i..].copy_from_slice(&c4[..n - i]);
        }
    }

    /// `|x| − y·π/2` as a double-double `(r, rl)` (y the nearest integer to |x|·2/π).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn reduce(xa: __m256d, y: __m256d) -> (__m256d, __m256d) {
        let set = _mm256_set1_pd;
        // xa − y·P1 is exact (both are multiples of xa's and P1's last bits and |result| < 1).
        let r1 = _mm256_fnmadd_pd(y, set(P1), xa);
        // r1 − y·P2 as a double-double: the product's error by FMA, the sum's by two-sum.
        let p_hi = _mm256_mul_pd(y, set(P2));
        let p_lo = _mm256_fmsub_pd(y, set(P2), p_hi);
        let hi = _mm256_sub_pd(r1, p_hi);
        let bb = _mm256_sub_pd(hi, r1);
        let err = _mm256_add_pd(
            _mm256_sub_pd(r1, _mm256_sub_pd(hi, bb)),
            _mm256_sub_pd(_mm256_sub_pd(_mm256_setzero_pd(), p_hi), bb),
        );
        let lo = _mm256_fnmadd_pd(y, set(P3), _mm256_sub_pd(err, p_lo));
        // Renormalised (|hi| ≥ |lo| by construction).
        let r = _mm256_add_pd(hi, lo);
        let rl = _mm256_sub_pd(lo, _mm256_sub_pd(r, hi));
        (r, rl)
    }

    /// The kernel of the module doc on four angles, or `None` when one of them is beyond
    /// [`KERNEL_LIMIT`] or not finite.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn sin_cos4(x: __m256d) -> Option<(__m256d, __m256d)> {
        let set = _mm256_set1_pd;
        let sign_bit = set(-0.0);
        let xa = _mm256_andnot_pd(sign_bit, x);
        // NaN compares false: it takes the fallback too.
        let inside = _mm256_cmp_pd::<_CMP_LE_OQ>(xa, set(KERNEL_LIMIT));
        if _mm256_movemask_pd(inside) != 0b1111 {
            return None;
        }
        let y = _mm256_round_pd::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(_mm256_mul_pd(
            xa,
            set(std::f64::consts::FRAC_2_PI),
        ));
        // Within ±π/4 (every lane's quadrant 0: a rotor's pendulums swing inside it) the reduction
        // is the identity, r = |x| and its low part 0, as the general branch would find; the
        // quadrant's selection below is the identity too.
        let first = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_EQ_OQ>(y, _mm256_setzero_pd())) == 0b1111;
        let (r, rl) = if first { (xa, _mm256_setzero_pd()) } else { reduce(xa, y) };
        let z = _mm256_mul_pd(r, r);
        // sin r = r + r·z·S(z) + rl·(1 − z/2).
        let mut ps = set(inv_fact(17));
        for c in [-inv_fact(15), inv_fact(13), -inv_fact(11), inv_fact(9), -inv_fact(7), inv_fact(5), -inv_fact(3)] {
            ps = _mm256_fmadd_pd(ps, z, set(c));
        }
        let rl_cos = _mm256_mul_pd(rl, _mm256_fnmadd_pd(set(0.5), z, set(1.0)));
        let s = _mm256_add_pd(r, _mm256_fmadd_pd(_mm256_mul_pd(r, z), ps, rl_cos));
        // cos r = (1 − h) + [((1 − w) − h) − z_err/2 + z²·C(z) − r·rl], h = z/2, w = 1 − h.
        let mut pc = set(inv_fact(16));
        for c in [-inv_fact(14), inv_fact(12), -inv_fact(10), inv_fact(8), -inv_fact(6), inv_fact(4)] {
            pc = _mm256_fmadd_pd(pc, z, set(c));
        }
        let z_err = _mm256_fmsub_pd(r, r, z);
        let h = _mm256_mul_pd(set(0.5), z);
        let w = _mm256_sub_pd(set(1.0), h);
        let tail = _mm256_fnmadd_pd(
            r,
            rl,
            _mm256_fmadd_pd(
                _mm256_mul_pd(z, z),
                pc,
                _mm256_fnmadd_pd(set(0.5), z_err, _mm256_sub_pd(_mm256_sub_pd(set(1.0), w), h)),
            ),
        );
        let c = _mm256_add_pd(w, tail);
        if first {
            return Some((_mm256_xor_pd(s, _mm256_and_pd(x, sign_bit)), c));
        }

        // Quadrant q = y mod 4 from the integer y's low bits (y < 2⁵¹, so y + 2⁵² holds it in
        // the mantissa's last bits).
        let qbits = _mm256_castpd_si256(_mm256_add_pd(y, set(4503599627370496.0)));
        let odd = _mm256_castsi256_pd(_mm256_cmpeq_epi64(
            _mm256_and_si256(qbits, _mm256_set1_epi64x(1)),
            _mm256_set1_epi64x(1),
        ));
        // sin(|x|) is ±s in even quadrants and ±c in odd ones, negative in quadrants 2 and 3;
        // cos is ±c / ∓s, negative in quadrants 1 and 2.
        let sin_abs = _mm256_blendv_pd(s, c, odd);
        let cos_v = _mm256_blendv_pd(c, s, odd);
        let q2 = _mm256_slli_epi64::<62>(qbits);
        let sin_sign = _mm256_xor_si256(
            _mm256_and_si256(q2, _mm256_set1_epi64x(i64::MIN)),
            _mm256_castpd_si256(_mm256_and_pd(x, sign_bit)),
        );
        let q1 = _mm256_slli_epi64::<62>(_mm256_add_epi64(qbits, _mm256_set1_epi64x(1)));
        let cos_sign = _mm256_and_si256(q1, _mm256_set1_epi64x(i64::MIN));
        let sin_v = _mm256_xor_pd(sin_abs, _mm256_castsi256_pd(sin_sign));
        let cos_v = _mm256_xor_pd(cos_v, _mm256_castsi256_pd(cos_sign));
        Some((sin_v, cos_v))
    }
}

#[cfg(test)]
mod tests {
    use super::sin_cos_many;

    /// The largest error in ulps of the result (std's result's ulp) over `xs`.
    fn worst_ulps(xs: &[f64]) -> (f64, f64) {
        let (mut s, mut c) = (vec![0.0; xs.len()], vec![0.0; xs.len()]);
        sin_cos_many(xs, &mut s, &mut c);
        let ulp = |v: f64| {
            let a = v.abs().max(f64::MIN_POSITIVE);
            f64::from_bits(a.to_bits() + 1) - a
        };
        let (mut ws, mut wc) = (0.0f64, 0.0f64);
        for (i, &x) in xs.iter().enumerate() {
            let (es, ec) = x.sin_cos();
            ws = ws.max((s[i] - es).abs() / ulp(es));
            wc = wc.max((c[i] - ec).abs() / ulp(ec));
        }
        (ws, wc)
    }

    /// A dense sweep of ±40 rad (every quadrant many times over, with the reduction's integer
    /// up to 25): within one ulp of std's result, which is itself within an ulp of the truth,
    /// so the two can differ by one step of rounding and no more.
    #[test]
    fn dense_sweep_within_one_ulp_of_std() {
        let n = 2_000_003;
        let xs: Vec<f64> = (0..n).map(|i| -40.0 + 80.0 * i as f64 / (n - 1) as f64).collect();
        let (ws, wc) = worst_ulps(&xs);
        assert!(ws <= 1.0 && wc <= 1.0, "sin {ws} ulp, cos {wc} ulp");
    }

    /// Near the zeros of sin and cos (the doubles nearest k·π/2 and their neighbours, k up to
    /// 10⁴ and at the kernel's limit) the results are tiny and every ulp of the reduction shows:
    /// still within one ulp of std's.
    #[test]
    fn near_multiples_of_half_pi_within_one_ulp() {
        let mut xs = Vec::new();
        for k in (1..10_000).chain(600_000..600_050) {
            let x0 = k as f64 * std::f64::consts::FRAC_PI_2;
            for d in -3i64..=3 {
                let x = f64::from_bits((x0.to_bits() as i64 + d) as u64);
                xs.push(x);
                xs.push(-x);
            }
        }
        let (ws, wc) = worst_ulps(&xs);
        assert!(ws <= 1.0 && wc <= 1.0, "sin {ws} ulp, cos {wc} ulp");
    }

    /// An angle within ±π/4 gives the same bits whether its vector takes the first quadrant's
    /// shortcut or, beside a larger angle, the general reduction.
    #[test]
    fn first_quadrant_shortcut_is_the_general_branch() {
        let small: Vec<f64> = (0..4000).map(|i| -0.785 + 1.57 * i as f64 / 3999.0).collect();
        let (mut s1, mut c1) = (vec![0.0; 4000], vec![0.0; 4000]);
        sin_cos_many(&small, &mut s1, &mut c1);
        for (i, &x) in small.iter().enumerate() {
            let (mut s4, mut c4) = ([0.0; 4], [0.0; 4]);
            sin_cos_many(&[x, 2.0, -5.0, 100.0], &mut s4, &mut c4);
            assert_eq!((s4[0].to_bits(), c4[0].to_bits()), (s1[i].to_bits(), c1[i].to_bits()), "x = {x}");
        }
    }

    /// Small angles (where sin x ≈ x to the last bits), signed zeros, every length of the padded
    /// tail, and the fallback's cases (beyond the limit, infinite, NaN) equal to std's.
    #[test]
    fn small_angles_tails_and_fallback() {
        let small: Vec<f64> =
            (0..2000).map(|i| 1e-300 * 1.5f64.powi(i % 1700) * if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
        let (ws, wc) = worst_ulps(&small);
        assert!(ws <= 1.0 && wc <= 1.0, "sin {ws} ulp, cos {wc} ulp");
        for len in 0..9 {
            let xs: Vec<f64> = (0..len).map(|i| 0.3 * i as f64 - 1.0).collect();
            let (ws, wc) = worst_ulps(&xs);
            assert!(ws <= 1.0 && wc <= 1.0, "length {len}: sin {ws} ulp, cos {wc} ulp");
        }
        let odd = [0.0, -0.0, 2.0e6, -3.0e9, 1e300, f64::INFINITY, f64::NEG_INFINITY, f64::NAN];
        let (mut s, mut c) = ([0.0; 8], [0.0; 8]);
        sin_cos_many(&odd, &mut s, &mut c);
        for (i, x) in odd.iter().enumerate() {
            let (es, ec) = x.sin_cos();
            assert!(s[i].to_bits() == es.to_bits() || (s[i].is_nan() && es.is_nan()), "sin({x})");
            assert!(c[i].to_bits() == ec.to_bits() || (c[i].is_nan() && ec.is_nan()), "cos({x})");
        }
        let (mut s, mut c) = ([0.0; 2], [0.0; 2]);
        sin_cos_many(&[0.0, -0.0], &mut s, &mut c);
        assert_eq!((s[0].to_bits(), s[1].to_bits(), c[0], c[1]), (0.0f64.to_bits(), (-0.0f64).to_bits(), 1.0, 1.0));
    }
}

/// Time per angle of the kernel and of `f64::sin_cos` on 33 angles at a time (one 32-pendulum
/// right-hand side's worth), and how many results differ from std's at all:
/// `cargo test --release --lib sincos::timing -- --ignored --nocapture`.
#[cfg(test)]
mod timing {
    use super::sin_cos_many;
    use std::hint::black_box;
    use std::time::Instant;

    #[test]
    #[ignore = "timing; run by hand"]
    fn timing() {
        let wide: Vec<f64> = (0..33).map(|i| 0.37 * i as f64 - 6.0).collect();
        let swing: Vec<f64> = (0..33).map(|i| 0.03 * i as f64 - 0.5).collect();
        let (mut s, mut c) = (vec![0.0; 33], vec![0.0; 33]);
        let reps = 200_000;
        for (name, xs) in [("±6 rad", &wide), ("±0.5 rad", &swing), ("±6 rad", &wide), ("±0.5 rad", &swing)] {
            let t = Instant::now();
            for _ in 0..reps {
                sin_cos_many(black_box(xs), &mut s, &mut c);
                black_box((&s, &c));
            }
            let kernel = t.elapsed().as_secs_f64() / (reps * 33) as f64 * 1e9;
            let t = Instant::now();
            for _ in 0..reps {
                for ((x, s), c) in black_box(xs).iter().zip(s.iter_mut()).zip(c.iter_mut()) {
                    (*s, *c) = x.sin_cos();
                }
                black_box((&s, &c));
            }
            let std = t.elapsed().as_secs_f64() / (reps * 33) as f64 * 1e9;
            eprintln!("{name}: ns per angle: kernel {kernel:.2}, std {std:.2}");
        }
        let n = 2_000_003;
        let xs: Vec<f64> = (0..n).map(|i| -40.0 + 80.0 * i as f64 / (n - 1) as f64).collect();
        let (mut s, mut c) = (vec![0.0; n], vec![0.0; n]);
        sin_cos_many(&xs, &mut s, &mut c);
        let differ = xs.iter().enumerate().filter(|&(i, x)| x.sin_cos() != (s[i], c[i])).count();
        eprintln!("{differ} of {n} angles differ from std's in sin or cos (by one ulp at most)");
    }
}
