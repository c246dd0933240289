//! The combustion engine: torque from cylinder pressure, the gas torque and the reciprocating-inertia torque of a
//! multi-cylinder four-stroke engine on its crankshaft, and their order series.
//!
//! One cylinder is a slider-crank of crank radius r = stroke/2 and connecting rod l (λ = r/l). With
//! the crank at θ from the cylinder's top dead centre (TDC) the piston has moved
//! `x(θ) = r(1 − cos θ) + l(1 − √(1 − λ² sin² θ))` and `x'(θ) = r sin θ (1 + λ cos θ / √(1 − λ² sin² θ))`.
//! By virtual work a gauge pressure p on the piston area A gives the crank the torque
//! `T_gas = p A x'(θ)`, and a reciprocating mass m (piston, pin, part of the rod) turning at a
//! steady Ω the torque `T_rec = −m Ω² x'(θ) x''(θ)` (the inertia force `−m ẍ` with ẍ = Ω² x'').
//! To first order in λ, T_rec = m r² Ω² (λ/4 · sin θ − ½ sin 2θ − 3λ/4 · sin 3θ): the classical
//! orders 1, 2, 3.
//!
//! Cylinder k runs the same cycle as cylinder 1 shifted by its firing offset δ_k (crank angle,
//! 0 ≤ δ_k < 720°; evenly spaced along the firing order unless given): its pressure is
//! `p(θ − δ_k)` over the 720° cycle and its throw is at `θ − δ_k` (mod 360°), θ being the crank
//! angle from cylinder 1's firing TDC. The engine torque is the sum over cylinders, periodic in 720°,
//! so its orders are multiples of ½: `T(θ) = T_m + Σ_j A_j sin(j·θ/2 + α_j)`, found by a real FFT of
//! 4096 samples per cycle ([`Engine::orders`]); the gas part is computed once, the inertia part
//! scales with Ω².
//!
//! The pressure is a table of gauge pressure over the 720° cycle from firing TDC, interpolated
//! by a periodic cubic spline (measured indicator data go here), or a smooth analytic pulse that
//! stands in for a measured cycle.

use crate::model::excitation::Harmonic;
use realfft::RealFftPlanner;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Samples of one 720° cycle for the order series: orders up to 1024 are resolved, far beyond
/// what a smooth pressure curve holds.
pub const CYCLE_SAMPLES: usize = 4096;

/// An engine as written in its RON file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Engine", deny_unknown_fields)]
pub struct EngineSpec {
    /// Name.
    pub name: String,
    /// Bore, m.
    pub bore_m: f64,
    /// Stroke, m (crank radius r = stroke/2).
    pub stroke_m: f64,
    /// Connecting-rod length between centres, m.
    pub rod_m: f64,
    /// Reciprocating mass per cylinder, kg.
    pub reciprocating_mass_kg: f64,
    /// Firing order, cylinder numbers 1..=N each once (its length is the cylinder count).
    pub firing_order: Vec<usize>,
    /// Firing offset of each cylinder in cylinder-number order, degrees of crank angle after
    /// cylinder 1's firing TDC; default: 720°/N apart along the firing order.
    #[serde(default)]
    pub offsets_deg: Option<Vec<f64>>,
    /// One cylinder's gauge pressure over its cycle.
    pub pressure: Pressure,
}

/// A cylinder's gauge pressure (above crankcase pressure) over the 720° cycle, crank angle from
/// its firing TDC.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Pressure {
    /// Measured data: `(crank angle in degrees, gauge pressure in bar)` pairs with increasing
    /// angles covering one cycle (first at or after 0°, last before 720°, at least 8 points),
    /// interpolated by a periodic cubic spline.
    Table(Vec<(f64, f64)>),
    /// A smooth stand-in for a measured cycle: `base + (peak − base)·e^{−½((θ − at)/width)²}`,
    /// θ wrapped to the 720° around firing TDC (bar and degrees).
    Pulse {
        /// Pressure outside combustion, bar.
        base_bar: f64,
        /// Peak pressure, bar.
        peak_bar: f64,
        /// Crank angle of the peak after firing TDC, degrees.
        at_deg: f64,
        /// Width (standard deviation) of the pulse, degrees.
        width_deg: f64,
    },
}

/// An engine ready to evaluate: geometry, offsets and the pressure curve.
#[derive(Debug, Clone)]
pub struct Engine {
    spec: EngineSpec,
    area_m2: f64,
    r: f64,
    lambda: f64,
    offsets_rad: Vec<f64>,
    spline: Option<PeriodicSpline>,
    /// Mean and (cos, sin) coefficients in θ/2 of the gas torque and of the inertia torque at
    /// Ω = 1 rad/s, computed once: the series at any speed combines them.
    gas: (f64, Vec<(f64, f64)>),
    inertia: (f64, Vec<(f64, f64)>),
}

/// An engine's torque as orders at one speed: `T(θ) = mean + Σ amplitude·sin(multiple·θ/2 + phase)`.
#[derive(Debug, Clone, PartialEq)]
pub struct EngineOrders {
    /// Mean torque, N·m (the indicated work per cycle over 4π; the inertia part has none).
    pub mean_nm: f64,
    /// The harmonics in multiples of order ½ (multiple j is order j/2), amplitudes N·m, phases
    /// rad: the form of an order excitation at base order ½ ([`Harmonic`]).
    pub harmonics: Vec<Harmonic>,
}

impl Engine {
    /// Checks `spec` and prepares it; an error names the field and what is wrong.
    pub fn new(spec: EngineSpec) -> Result<Self, (String, String)> {
        let bad = |f: &str, m: String| Err((f.to_string(), m));
        for (f, v) in [("bore_m", spec.bore_m), ("stroke_m", spec.stroke_m), ("rod_m", spec.rod_m)] {
            if !(v.is_finite() && v > 0.0 && v < 10.0) {
                return bad(f, format!("must be a positive length below 10 m, got {v}"));
            }
        }
        let r = 0.5 * spec.stroke_m;
        if spec.rod_m <= r {
            return bad("rod_m", format!("the rod ({} m) must be longer than the crank radius ({r} m)", spec.rod_m));
        }
        if !(spec.reciprocating_mass_kg.is_finite() && spec.reciprocating_mass_kg >= 0.0) {
            return bad("reciprocating_mass_kg", "must be finite and non-negative".into());
        }
        let n = spec.firing_order.len();
        if n == 0 || n > 64 {
            return bad("firing_order", format!("give 1 to 64 cylinders, got {n}"));
        }
        let mut seen = vec![false; n];
        for (i, &c) in spec.firing_order.iter().enumerate() {
            if c == 0 || c > n || seen[c - 1] {
                return bad(
                    &format!("firing_order[{i}]"),
                    format!("cylinder {c}: the firing order must name cylinders 1..={n} once each"),
                );
            }
            seen[c - 1] = true;
        }
        let offsets_deg: Vec<f64> = match &spec.offsets_deg {
            Some(o) => {
                if o.len() != n {
                    return bad("offsets_deg", format!("give one offset per cylinder ({n}), got {}", o.len()));
                }
                if let Some(i) = o.iter().position(|v| !(v.is_finite() && (0.0..720.0).contains(v))) {
                    return bad(&format!("offsets_deg[{i}]"), "must lie in 0 ≤ offset < 720°".into());
                }
                o.clone()
            }
            None => {
                let mut o = vec![0.0; n];
                for (i, &c) in spec.firing_order.iter().enumerate() {
                    o[c - 1] = 720.0 * i as f64 / n as f64;
                }
                o
            }
        };
        let spline = match &spec.pressure {
            Pressure::Table(points) => {
                if points.len() < 8 || points.len() > 100_000 {
                    return bad("pressure", format!("give 8 to 100000 (angle, bar) points, got {}", points.len()));
                }
                if let Some(i) = points.iter().position(|(a, p)| !(a.is_finite() && p.is_finite() && p.abs() < 1e4)) {
                    return bad(&format!("pressure[{i}]"), "angle and pressure must be finite, |p| < 10000 bar".into());
                }
                if points[0].0 < 0.0 || points[points.len() - 1].0 >= 720.0 {
                    return bad("pressure", "the angles must cover one cycle within 0 ≤ θ < 720°".into());
                }
                if let Some(i) = points.windows(2).position(|w| w[1].0 <= w[0].0) {
                    return bad(&format!("pressure[{}]", i + 1), "the angles must increase".into());
                }
                // The spline is periodic: a table whose end does not join its start would be
                // closed by a swing nobody measured (an 80-bar step across the seam used to
                // pass silently). The seam may be as steep as the table's own steepest part,
                // with a margin, plus 0.1 bar of noise.
                let (first, last) = (points[0], points[points.len() - 1]);
                let steepest =
                    points.windows(2).map(|w| (w[1].1 - w[0].1).abs() / (w[1].0 - w[0].0)).fold(0.0, f64::max);
                let gap = 720.0 - last.0 + first.0;
                let jump = (first.1 - last.1).abs();
                let factor = crate::model::ranges::PRESSURE_SEAM_FACTOR;
                if jump > factor * steepest * gap + 0.1 {
                    return bad(
                        &format!("pressure[{}]", points.len() - 1),
                        format!(
                            "the table is not periodic across the 720° → 0° seam: it steps from {} bar at {}° to {} bar \
                             at {}° + 720°, {:.3} bar/°, more than {factor} × the steepest slope inside the table \
                             ({:.3} bar/°); the periodic spline would close the gap with an invented swing. Give one \
                             whole cycle whose end joins its start",
                            last.1,
                            last.0,
                            first.1,
                            first.0,
                            jump / gap,
                            steepest
                        ),
                    );
                }
                let xs: Vec<f64> = points.iter().map(|p| p.0.to_radians()).collect();
                let ys: Vec<f64> = points.iter().map(|p| p.1 * 1e5).collect();
                Some(PeriodicSpline::new(&xs, &ys, 4.0 * PI))
            }
            Pressure::Pulse { base_bar, peak_bar, at_deg, width_deg } => {
                for (f, v) in [("base_bar", base_bar), ("peak_bar", peak_bar), ("at_deg", at_deg)] {
                    if !(v.is_finite() && v.abs() < 1e4) {
                        return bad(&format!("pressure.{f}"), "must be finite and below 10000 in size".into());
                    }
                }
                if !(width_deg.is_finite() && *width_deg > 0.0 && *width_deg <= 180.0) {
                    return bad("pressure.width_deg", "must lie in 0 < width ≤ 180°".into());
                }
                None
            }
        };
        let mut engine = Self {
            area_m2: 0.25 * PI * spec.bore_m * spec.bore_m,
            r,
            lambda: r / spec.rod_m,
            offsets_rad: offsets_deg.iter().map(|d| d.to_radians()).collect(),
            spline,
            spec,
            gas: (0.0, Vec::new()),
            inertia: (0.0, Vec::new()),
        };
        engine.gas = coefficients(|t| engine.gas_torque(t));
        engine.inertia = coefficients(|t| engine.inertia_torque(t, 1.0));
        Ok(engine)
    }

    /// The spec as given.
    pub fn spec(&self) -> &EngineSpec {
        &self.spec
    }

    /// Number of cylinders.
    pub fn cylinders(&self) -> usize {
        self.offsets_rad.len()
    }

    /// Crank radius r, m, and λ = r/l.
    pub fn crank(&self) -> (f64, f64) {
        (self.r, self.lambda)
    }

    /// Piston travel from TDC x(θ), m, and its derivatives x'(θ) (m/rad) and x''(θ) (m/rad²), at
    /// crank angle θ from the cylinder's TDC.
    pub fn piston(&self, theta: f64) -> (f64, f64, f64) {
        let (r, l) = (self.r, self.lambda);
        let (s, c) = theta.sin_cos();
        let root = (1.0 - l * l * s * s).sqrt();
        let x = r * (1.0 - c) + r / l * (1.0 - root);
        let xp = r * s * (1.0 + l * c / root);
        // d/dθ [λ s c / root] = λ (c² − s²)/root + λ³ s² c² / root³.
        let xpp = r * (c + l * (c * c - s * s) / root + l * l * l * s * s * c * c / (root * root * root));
        (x, xp, xpp)
    }

    /// One cylinder's gauge pressure at crank angle `theta` (rad) from its firing TDC, Pa.
    pub fn pressure(&self, theta: f64) -> f64 {
        let t = theta.rem_euclid(4.0 * PI);
        match (&self.spec.pressure, &self.spline) {
            (_, Some(s)) => s.eval(t),
            (Pressure::Pulse { base_bar, peak_bar, at_deg, width_deg }, None) => {
                // Wrapped to (−360°, 360°] around firing TDC, so the pulse is whole.
                let d = if t > 2.0 * PI { t - 4.0 * PI } else { t } - at_deg.to_radians();
                let z = d / width_deg.to_radians();
                1e5 * (base_bar + (peak_bar - base_bar) * (-0.5 * z * z).exp())
            }
            (Pressure::Table(_), None) => f64::NAN,
        }
    }

    /// The gas torque on the crankshaft at crank angle `theta` (rad from cylinder 1's firing TDC),
    /// N·m: `Σ_k p(θ − δ_k) A x'(θ − δ_k)`.
    pub fn gas_torque(&self, theta: f64) -> f64 {
        self.offsets_rad.iter().map(|d| self.pressure(theta - d) * self.area_m2 * self.piston(theta - d).1).sum()
    }

    /// The reciprocating-inertia torque at crank angle `theta` and steady speed `omega` (rad/s),
    /// N·m: `−Σ_k m Ω² x'x''(θ − δ_k)`.
    pub fn inertia_torque(&self, theta: f64, omega: f64) -> f64 {
        let m = self.spec.reciprocating_mass_kg;
        -m * omega
            * omega
            * self
                .offsets_rad
                .iter()
                .map(|d| {
                    let (_, xp, xpp) = self.piston(theta - d);
                    xp * xpp
                })
                .sum::<f64>()
    }

    /// The whole engine torque at crank angle `theta` and speed `omega`, N·m.
    pub fn torque(&self, theta: f64, omega: f64) -> f64 {
        self.gas_torque(theta) + self.inertia_torque(theta, omega)
    }

    /// The torque's order series at speed `omega` (rad/s), every harmonic up to order
    /// `max_order` (a balanced engine's cancelled orders appear with rounding-level amplitudes;
    /// [`EngineOrders::significant`] leaves them out).
    pub fn orders(&self, omega: f64, max_order: f64) -> EngineOrders {
        let w2 = omega * omega;
        let top = ((2.0 * max_order).floor().max(0.0) as usize).min(self.gas.1.len());
        let harmonics = (0..top)
            .map(|k| {
                let (ga, gb) = self.gas.1[k];
                let (ia, ib) = self.inertia.1[k];
                let (a, b) = (ga + w2 * ia, gb + w2 * ib);
                // a cos + b sin = A sin(jφ + α) with A = √(a² + b²), α = atan2(a, b).
                Harmonic { multiple: (k + 1) as f64, amplitude: a.hypot(b), phase: a.atan2(b) }
            })
            .collect();
        EngineOrders { mean_nm: self.gas.0 + w2 * self.inertia.0, harmonics }
    }
}

impl Engine {
    /// The oscillating part of the torque as a series whose coefficients follow the speed: the
    /// orders that are whole multiples of `base_order` (itself a positive multiple of ½) up to
    /// `max_order`, each with its gas coefficients and its inertia coefficients per Ω² kept
    /// apart, so that one series serves every speed of a run-up or a continuation. `None` when
    /// `base_order` is not a positive multiple of ½ or `max_order` is below it.
    pub fn oscillating_series(&self, base_order: f64, max_order: f64) -> Option<OscillatingSeries> {
        let step = 2.0 * base_order;
        if !(base_order.is_finite() && base_order > 0.0 && step.fract() == 0.0) {
            return None;
        }
        if !(max_order.is_finite() && max_order >= base_order) {
            return None;
        }
        let step = step as usize;
        let top = ((2.0 * max_order).floor() as usize).min(self.gas.1.len());
        let multiples: Vec<usize> = (1..=top).filter(|j| j % step == 0).collect();
        Some(OscillatingSeries {
            gas: multiples.iter().map(|&j| self.gas.1[j - 1]).collect(),
            inertia: multiples.iter().map(|&j| self.inertia.1[j - 1]).collect(),
            half_orders: multiples,
        })
    }
}

/// The oscillating engine torque at any speed from a fixed set of orders:
/// `T̃(θ, Ω) = Σ_j (a_j + Ω² c_j) cos(jθ/2) + (b_j + Ω² d_j) sin(jθ/2)`, with (a_j, b_j) the gas
/// torque's coefficients (N·m) and (c_j, d_j) the reciprocating-inertia torque's per Ω²
/// (N·m·s²/rad²): the gas torque does not depend on the speed, the inertia torque
/// `−m Ω² x'x''` scales with Ω² (see the module docs). Made by [`Engine::oscillating_series`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OscillatingSeries {
    /// The multiples j of order ½ kept (order j/2): s, 2s, 3s, … for a step s.
    half_orders: Vec<usize>,
    /// Gas coefficients (a_j, b_j) of cos(jθ/2) and sin(jθ/2), N·m.
    gas: Vec<(f64, f64)>,
    /// Inertia coefficients (c_j, d_j) per Ω², N·m·s²/rad².
    inertia: Vec<(f64, f64)>,
}

impl OscillatingSeries {
    /// The oscillating torque at crank angle `theta` (rad from cylinder 1's firing TDC) and
    /// speed `omega` (rad/s), every harmonic led by `phase` (rad), N·m: `A sin(x + α)` becomes
    /// `A sin(x + α + phase)`, the form of an `excite` share.
    pub fn torque(&self, theta: f64, omega: f64, phase: f64) -> f64 {
        let Some(&step) = self.half_orders.first() else { return 0.0 };
        let w2 = omega * omega;
        // The kept multiples are step, 2·step, …: the angles jθ/2 + phase advance by step·θ/2,
        // so one rotation per term replaces a sine and cosine each (the rounding this adds grows
        // with the term count, ~1e-14 for a hundred terms). a cos x + b sin x = A sin(x + α), so
        // leading x by the phase leads A sin(·) alike.
        let x = 0.5 * step as f64 * theta;
        let (ds, dc) = x.sin_cos();
        let (mut s, mut co) = (x + phase).sin_cos();
        let mut sum = 0.0;
        for (&(a, b), &(c, d)) in self.gas.iter().zip(&self.inertia) {
            sum += (a + w2 * c) * co + (b + w2 * d) * s;
            (s, co) = (s * dc + co * ds, co * dc - s * ds);
        }
        sum
    }

    /// The series at speed `omega` (rad/s) as harmonics of `base_order`: multiple
    /// `(j/2)/base_order`, amplitude N·m, phase rad (the form of [`Harmonic`]).
    pub fn harmonics(&self, omega: f64, base_order: f64) -> Vec<Harmonic> {
        let w2 = omega * omega;
        self.parts(base_order, |(a, b), (c, d)| (a + w2 * c, b + w2 * d))
    }

    /// The gas part (N·m) and the inertia part per Ω² (N·m·s²/rad²) as harmonics of
    /// `base_order`, for a solver whose forcing is `gas + Ω² inertia`.
    pub fn split_harmonics(&self, base_order: f64) -> (Vec<Harmonic>, Vec<Harmonic>) {
        (self.parts(base_order, |g, _| g), self.parts(base_order, |_, i| i))
    }

    fn parts(&self, base_order: f64, pick: impl Fn((f64, f64), (f64, f64)) -> (f64, f64)) -> Vec<Harmonic> {
        self.half_orders
            .iter()
            .zip(self.gas.iter().zip(&self.inertia))
            .map(|(&j, (&g, &i))| {
                let (a, b) = pick(g, i);
                Harmonic { multiple: 0.5 * j as f64 / base_order, amplitude: a.hypot(b), phase: a.atan2(b) }
            })
            .collect()
    }

    /// The orders kept, cycles per crank revolution.
    pub fn orders(&self) -> Vec<f64> {
        self.half_orders.iter().map(|&j| 0.5 * j as f64).collect()
    }
}

/// The mean and the (cos, sin) coefficients of harmonics j = 1..N/2 − 1 in φ = θ/2 of a torque
/// over the 720° cycle, by a real FFT of [`CYCLE_SAMPLES`] samples:
/// `x_i = a₀ + Σ_j (a_j cos jφ_i + b_j sin jφ_i)` gives `X_j = (N/2)(a_j − i b_j)`.
fn coefficients(torque: impl Fn(f64) -> f64) -> (f64, Vec<(f64, f64)>) {
    let n = CYCLE_SAMPLES;
    let mut input: Vec<f64> = (0..n).map(|i| torque(4.0 * PI * i as f64 / n as f64)).collect();
    let fft = RealFftPlanner::<f64>::new().plan_fft_forward(n);
    let mut spectrum = fft.make_output_vec();
    // The lengths come from the plan itself, so the transform cannot fail.
    fft.process(&mut input, &mut spectrum).expect("buffers made by the plan");
    let scale = 2.0 / n as f64;
    let coefficients = (1..n / 2).map(|j| (scale * spectrum[j].re, -scale * spectrum[j].im)).collect();
    (spectrum[0].re / n as f64, coefficients)
}

impl EngineOrders {
    /// The series' torque at crank angle `theta` (rad from cylinder 1's firing TDC), N·m.
    pub fn torque(&self, theta: f64) -> f64 {
        self.mean_nm
            + self.harmonics.iter().map(|h| h.amplitude * (h.multiple * 0.5 * theta + h.phase).sin()).sum::<f64>()
    }

    /// The series without the harmonics below `rel` of the largest (the orders a balanced
    /// engine cancels, left at rounding level by the transform).
    pub fn significant(&self, rel: f64) -> EngineOrders {
        let largest = self.harmonics.iter().fold(0.0f64, |m, h| m.max(h.amplitude));
        let harmonics = self.harmonics.iter().copied().filter(|h| h.amplitude > rel * largest).collect();
        EngineOrders { mean_nm: self.mean_nm, harmonics }
    }

    /// The amplitude of order `order` (a multiple of ½), N·m; 0 when it is absent.
    pub fn amplitude(&self, order: f64) -> f64 {
        self.harmonics.iter().find(|h| (0.5 * h.multiple - order).abs() < 1e-9).map_or(0.0, |h| h.amplitude)
    }
}

/// A periodic cubic spline through `(x_i, y_i)` with period P: second derivatives from the cyclic
/// tridiagonal system (Sherman–Morrison on the Thomas algorithm), so the curve and its first two
/// derivatives are continuous across the period's end.
#[derive(Debug, Clone)]
struct PeriodicSpline {
    x: Vec<f64>,
    y: Vec<f64>,
    m: Vec<f64>,
    period: f64,
}

impl PeriodicSpline {
    fn new(x: &[f64], y: &[f64], period: f64) -> Self {
        let n = x.len();
        // Interval i runs from x_i to x_{i+1}, the last one wraps to x_0 + P.
        let h: Vec<f64> = (0..n).map(|i| if i + 1 < n { x[i + 1] - x[i] } else { x[0] + period - x[n - 1] }).collect();
        let dy: Vec<f64> = (0..n).map(|i| (y[(i + 1) % n] - y[i]) / h[i]).collect();
        // Row i (knot i): h_{i−1} m_{i−1} + 2(h_{i−1} + h_i) m_i + h_i m_{i+1} = 6 (dy_i − dy_{i−1}).
        let prev = |i: usize| (i + n - 1) % n;
        let a: Vec<f64> = (0..n).map(|i| h[prev(i)]).collect();
        let b: Vec<f64> = (0..n).map(|i| 2.0 * (h[prev(i)] + h[i])).collect();
        let c: Vec<f64> = h.clone();
        let d: Vec<f64> = (0..n).map(|i| 6.0 * (dy[i] - dy[prev(i)])).collect();
        let m = solve_cyclic(&a, &b, &c, &d);
        Self { x: x.to_vec(), y: y.to_vec(), m, period }
    }

    fn eval(&self, t: f64) -> f64 {
        let n = self.x.len();
        let p = self.period;
        // Map into [x_0, x_0 + P).
        let t = self.x[0] + (t - self.x[0]).rem_euclid(p);
        let i = match self.x.partition_point(|&v| v <= t) {
            0 => n - 1,
            k => k - 1,
        };
        let (x0, x1) = (self.x[i], if i + 1 < n { self.x[i + 1] } else { self.x[0] + p });
        let (y0, y1) = (self.y[i], self.y[(i + 1) % n]);
        let (m0, m1) = (self.m[i], self.m[(i + 1) % n]);
        let h = x1 - x0;
        let (u, v) = ((x1 - t) / h, (t - x0) / h);
        m0 * u * u * u * h * h / 6.0
            + m1 * v * v * v * h * h / 6.0
            + (y0 - m0 * h * h / 6.0) * u
            + (y1 - m1 * h * h / 6.0) * v
    }
}

/// Solves the cyclic tridiagonal system `a_i z_{i−1} + b_i z_i + c_i z_{i+1} = d_i` (indices mod
/// n, n ≥ 3, diagonally dominant) by Sherman–Morrison on the Thomas algorithm.
fn solve_cyclic(a: &[f64], b: &[f64], c: &[f64], d: &[f64]) -> Vec<f64> {
    let n = b.len();
    let gamma = -b[0];
    let mut bb = b.to_vec();
    bb[0] -= gamma;
    bb[n - 1] -= a[0] * c[n - 1] / gamma;
    let x = thomas(a, &bb, c, d);
    let mut u = vec![0.0; n];
    u[0] = gamma;
    u[n - 1] = c[n - 1];
    let z = thomas(a, &bb, c, &u);
    let v0 = 1.0;
    let vn = a[0] / gamma;
    let factor = (x[0] * v0 + x[n - 1] * vn) / (1.0 + z[0] * v0 + z[n - 1] * vn);
    x.iter().zip(&z).map(|(xi, zi)| xi - factor * zi).collect()
}

/// The Thomas algorithm for `a_i z_{i−1} + b_i z_i + c_i z_{i+1} = d_i` (a_0 and c_{n−1} unused).
fn thomas(a: &[f64], b: &[f64], c: &[f64], d: &[f64]) -> Vec<f64> {
    let n = b.len();
    let mut cp = vec![0.0; n];
    let mut dp = vec![0.0; n];
    cp[0] = c[0] / b[0];
    dp[0] = d[0] / b[0];
    for i in 1..n {
        let den = b[i] - a[i] * cp[i - 1];
        cp[i] = c[i] / den;
        dp[i] = (d[i] - a[i] * dp[i - 1]) / den;
    }
    let mut z = vec![0.0; n];
    z[n - 1] = dp[n - 1];
    for i in (0..n - 1).rev() {
        z[i] = dp[i] - cp[i] * z[i + 1];
    }
    z
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The periodic spline reproduces a smooth periodic function to its O(h⁴) accuracy and joins
    /// smoothly across the period's end.
    #[test]
    fn the_periodic_spline_interpolates_a_periodic_function() {
        let p = 4.0 * PI;
        let f = |t: f64| (0.5 * t).sin() + 0.3 * (1.5 * t + 0.2).cos();
        let x: Vec<f64> = (0..360).map(|i| p * i as f64 / 360.0 + 0.01 * (i % 3) as f64).collect();
        let y: Vec<f64> = x.iter().map(|&t| f(t)).collect();
        let s = PeriodicSpline::new(&x, &y, p);
        let worst =
            (0..2000).map(|k| p * k as f64 / 2000.0 - 1.0).map(|t| (s.eval(t) - f(t)).abs()).fold(0.0, f64::max);
        // h ≈ 0.035 rad, |f''''| ≤ 1.6: the clamped bound (5/384) h⁴ |f''''| ≈ 3e-8.
        assert!(worst < 1e-7, "{worst:e}");
    }
}
