//! Campbell data ([`campbell`]): the eigen-analysis of [`LinearModel::modes`] repeated over spin
//! speed, each speed linearised from the previous one's equilibrium, the modes tracked across
//! speeds by the modal assurance criterion (MAC) of their shapes in the kinetic-energy inner
//! product, the grid refined by halving wherever a track's MAC falls below 0.9, with the
//! engine-order lines `f = n·rpm/60` and their crossings with the modes: the resonance speeds
//! of torsional practice, where order n excites a mode. A crossing is where the mode's
//! eigen-order `f·60/rpm` equals n; it is bracketed between the refined tracking steps and
//! located by bisection on the eigen-order of the crossing's own mode, each probe speed
//! linearised afresh and its mode picked by MAC with the bracket's shapes.

use super::{C64, Damping, LinResult, LinearModel, ModalCombination, ModalDamping, Spin};
use crate::model::excitation::rpm_to_rad_s;
use crate::model::mechanism::Mechanism;
use nalgebra::DMatrix;
use std::f64::consts::PI;

/// One tracked mode over the speeds of a Campbell diagram.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct CampbellTrack {
    /// The most frequent label along the track (joint with the largest coordinate share).
    pub label: String,
    /// The label at each speed.
    pub labels: Vec<String>,
    /// Damped natural frequency |Im λ|/2π at each speed, Hz.
    pub frequency_hz: Vec<f64>,
    /// Undamped natural frequency ω_n/2π at each speed, Hz.
    pub natural_frequency_hz: Vec<f64>,
    /// Damping ratio at each speed.
    pub damping_ratio: Vec<f64>,
    /// The track's place in frequency order at each speed (1 = the lowest frequency there): the
    /// mode number of a table sorted by frequency speed by speed, while the track itself follows
    /// one mode shape.
    pub rank: Vec<usize>,
}

/// An engine-order line `f = n·rpm/60`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct OrderLine {
    /// The order n.
    pub order: f64,
    /// Its frequency at each speed, Hz.
    pub frequency_hz: Vec<f64>,
}

/// Where an order line crosses a mode: a resonance speed.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Crossing {
    /// The order n of the line.
    pub order: f64,
    /// Index of the mode's track in [`Campbell::tracks`].
    pub track: usize,
    /// Spin speed of the crossing, rpm.
    pub rpm: f64,
    /// The mode's damped frequency there (= n·rpm/60), Hz.
    pub frequency_hz: f64,
    /// The mode's label at the crossing.
    pub label: String,
    /// The mode's place in frequency order at the crossing (1 = lowest), the other tracks'
    /// frequencies interpolated linearly between the grid speeds.
    pub rank: usize,
}

/// Campbell data: natural frequencies against spin speed, with order lines.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Campbell {
    /// Spin speeds, rpm.
    pub rpm: Vec<f64>,
    /// The n − 1 vibration modes, tracked across speeds, in order of frequency at the first
    /// speed.
    pub tracks: Vec<CampbellTrack>,
    /// The order lines.
    pub order_lines: Vec<OrderLine>,
    /// Every crossing of an order line with a track inside the speed range, by speed.
    pub crossings: Vec<Crossing>,
}

/// Relative speed tolerance of a located crossing (the bisection stops below it).
pub const CROSSING_RTOL: f64 = 1e-9;

/// The smallest kinetic-energy MAC between a track's shape at one accepted speed and its mode
/// at the next: below it the step is halved, so that every track follows one continuous branch
/// of eigenvectors (distinct undamped modes are orthogonal in this measure, so a mode that is
/// not the track's scores near 0, and 0.9 leaves room for the shape's own turning).
const TRACK_MAC: f64 = 0.9;

/// How often a grid interval may be halved for tracking (1/1024 of it at most).
const MAX_HALVINGS: u32 = 10;

/// Modal assurance criterion of two complex shapes in the kinetic-energy inner product
/// `⟨a, b⟩ = aᴴ M b` (shapes in the speeds u, M the mass matrix there), in [0, 1].
fn mac(mass: &DMatrix<f64>, a: &[C64], b: &[C64]) -> f64 {
    let inner = |x: &[C64], y: &[C64]| -> C64 {
        let mut sum = C64::new(0.0, 0.0);
        for (i, xi) in x.iter().enumerate() {
            let mut row = C64::new(0.0, 0.0);
            for (j, yj) in y.iter().enumerate() {
                row += mass[(i, j)] * yj;
            }
            sum += xi.conj() * row;
        }
        sum
    };
    let (ab, aa, bb) = (inner(a, b), inner(a, a).re, inner(b, b).re);
    if aa <= 0.0 || bb <= 0.0 { 0.0 } else { ab.norm_sqr() / (aa * bb) }
}

/// One track's mode at one speed.
#[derive(Debug, Clone)]
struct TrackMode {
    label: String,
    frequency_hz: f64,
    natural_frequency_hz: f64,
    damping_ratio: f64,
    shape_u: Vec<C64>,
}

/// An accepted speed of the tracking: its equilibrium (the next speed's start) and each track's
/// mode, in track order.
#[derive(Debug, Clone)]
struct Step {
    rpm: f64,
    equilibrium: Vec<f64>,
    modes: Vec<TrackMode>,
}

impl Step {
    /// Track `t`'s eigen-order f·60/rpm (+∞ at standstill for a mode of non-zero frequency,
    /// which every order line starts below; NaN for a zero-frequency mode there).
    fn eigen_order(&self, t: usize) -> f64 {
        let f = self.modes[t].frequency_hz;
        if self.rpm > 0.0 {
            f * 60.0 / self.rpm
        } else if f > 0.0 {
            f64::INFINITY
        } else {
            f64::NAN
        }
    }
}

/// What tracking and locating need to linearise at a speed.
struct Tracker<'a> {
    mech: &'a Mechanism,
    spin_joint: &'a str,
    spin: Spin,
    damping: Damping,
    modal: Option<(&'a ModalDamping, ModalCombination)>,
}

impl Tracker<'_> {
    /// The equilibrium, mass matrix and vibration modes at `rpm`, linearised from `guess`.
    fn sample(&self, rpm: f64, guess: Option<&[f64]>) -> LinResult<(Vec<f64>, DMatrix<f64>, Vec<TrackMode>)> {
        let model = LinearModel::new(self.mech, self.spin_joint, rpm_to_rad_s(rpm), guess)?;
        let model = match self.modal {
            Some((z, how)) => model.with_modal_damping_combined(self.spin, z, how)?,
            None => model,
        };
        let modes = model
            .modes(self.spin, self.damping)?
            .modes
            .into_iter()
            .map(|m| TrackMode {
                label: m.label,
                frequency_hz: m.frequency_hz,
                natural_frequency_hz: m.natural_frequency_rad_s / (2.0 * PI),
                damping_ratio: m.damping_ratio,
                shape_u: m.shape_u,
            })
            .collect();
        Ok((model.op.q.clone(), model.mass.clone(), modes))
    }

    /// The first speed: its modes in order of natural frequency make the tracks.
    fn first(&self, rpm: f64, guess: Option<&[f64]>) -> LinResult<Step> {
        let (equilibrium, _, mut modes) = self.sample(rpm, guess)?;
        modes.sort_by(|a, b| a.natural_frequency_hz.total_cmp(&b.natural_frequency_hz));
        Ok(Step { rpm, equilibrium, modes })
    }

    /// The tracks from `prev` to `rpm`: each track takes the mode of largest MAC with its shape
    /// (greedy, largest first). When a track's best is below [`TRACK_MAC`] (and its mode is not
    /// one of a repeated pair, whose shapes are not unique), the step is halved, up to
    /// [`MAX_HALVINGS`] times (not from standstill); `on_step` sees every accepted step, the intermediate ones too.
    fn advance(
        &self,
        prev: &Step,
        rpm: f64,
        halvings: u32,
        on_step: &mut dyn FnMut(&Step, &Step) -> LinResult<()>,
    ) -> LinResult<Step> {
        let (equilibrium, mass, modes) = self.sample(rpm, Some(&prev.equilibrium))?;
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (t, track) in prev.modes.iter().enumerate() {
            for (m, mode) in modes.iter().enumerate() {
                pairs.push((mac(&mass, &track.shape_u, &mode.shape_u), t, m));
            }
        }
        pairs.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut taken: Vec<Option<(usize, f64)>> = vec![None; prev.modes.len()];
        let mut m_done = vec![false; modes.len()];
        for (value, t, m) in pairs {
            if taken[t].is_some() || m_done[m] {
                continue;
            }
            taken[t] = Some((m, value));
            m_done[m] = true;
        }
        let repeated = |m: usize| {
            let f = modes[m].frequency_hz;
            modes.iter().enumerate().any(|(k, o)| k != m && (o.frequency_hz - f).abs() <= 1e-6 * f.abs().max(1e-12))
        };
        let unsure = taken.iter().any(|x| x.is_none_or(|(m, value)| value < TRACK_MAC && !repeated(m)));
        // From standstill no halving: a zero-frequency mode there (a pendulum without
        // centrifugal stiffness) has no shape to continue, and speeds near zero have no
        // well-conditioned equilibrium to halve towards.
        if unsure && halvings < MAX_HALVINGS && prev.rpm > 0.0 {
            let mid = self.advance(prev, 0.5 * (prev.rpm + rpm), halvings + 1, on_step)?;
            return self.advance(&mid, rpm, halvings + 1, on_step);
        }
        let modes = taken
            .iter()
            .map(|x| {
                x.map(|(m, _)| modes[m].clone())
                    .ok_or_else(|| super::LinearError::Invalid(format!("a mode was lost at {rpm} rpm")))
            })
            .collect::<LinResult<Vec<TrackMode>>>()?;
        let step = Step { rpm, equilibrium, modes };
        on_step(prev, &step)?;
        Ok(step)
    }

    /// Track `t`'s crossings with the order lines between two accepted steps (a sign change of
    /// eigen-order − n), each located by bisection on the track's own mode.
    fn crossings(&self, orders: &[f64], t: usize, a: &Step, b: &Step, out: &mut Vec<Crossing>) -> LinResult<()> {
        for &n in orders {
            let (g0, g1) = (a.eigen_order(t) - n, b.eigen_order(t) - n);
            if !(g0.is_finite() || g0 == f64::INFINITY) || !g1.is_finite() || g0 == 0.0 || g0.signum() == g1.signum() {
                continue;
            }
            let (rpm, frequency_hz, label) = if g1 == 0.0 {
                (b.rpm, b.modes[t].frequency_hz, b.modes[t].label.clone())
            } else {
                self.locate(n, t, a, b, g0 > 0.0)?
            };
            out.push(Crossing { order: n, track: t, rpm, frequency_hz, label, rank: 0 });
        }
        Ok(())
    }

    /// Bisection on `eigen-order − n` of track `t` between the accepted steps `a` (where the
    /// eigen-order is above n when `above`) and `b`, to [`CROSSING_RTOL`] in speed. Each probe is
    /// linearised from `a`'s equilibrium and takes the mode of largest MAC with the shape at the
    /// nearer end of the bracket, which moves with it: (rpm, frequency in Hz, label).
    fn locate(&self, n: f64, t: usize, a: &Step, b: &Step, above: bool) -> LinResult<(f64, f64, String)> {
        let (mut lo, mut hi) = (a.rpm, b.rpm);
        let (mut shape_lo, mut shape_hi) = (a.modes[t].shape_u.clone(), b.modes[t].shape_u.clone());
        let mut label = b.modes[t].label.clone();
        for _ in 0..200 {
            if hi - lo <= CROSSING_RTOL * hi {
                break;
            }
            let mid = 0.5 * (lo + hi);
            let (_, mass, modes) = self.sample(mid, Some(&a.equilibrium))?;
            let score = |m: &TrackMode| mac(&mass, &shape_lo, &m.shape_u).max(mac(&mass, &shape_hi, &m.shape_u));
            let best = modes
                .into_iter()
                .max_by(|x, y| score(x).total_cmp(&score(y)))
                .ok_or_else(|| super::LinearError::Invalid(format!("no vibration mode at {mid} rpm")))?;
            let eo = best.frequency_hz * 60.0 / mid;
            label = best.label.clone();
            if ((eo - n) > 0.0) == above {
                lo = mid;
                shape_lo = best.shape_u;
            } else {
                hi = mid;
                shape_hi = best.shape_u;
            }
        }
        // The bracket's midpoint, with the line's frequency there (the mode's equals it to the
        // bracket's width).
        let r = 0.5 * (lo + hi);
        Ok((r, n * r / 60.0, label))
    }
}

/// Campbell data of `mech` spinning on `spin_joint` over `rpm` (each speed linearised from the
/// previous speed's equilibrium, the first from `guess`), with the order lines of `orders`.
///
/// Tracking: at the first speed the modes are sorted by natural frequency; at each next speed
/// each track takes the mode whose shape has the largest MAC, in the kinetic-energy inner
/// product, with the track's previous shape (greedy, largest MAC first). Where a track's best
/// MAC falls below 0.9 (modes veering, or a coarse grid) the step is halved until it does not,
/// so the tracks follow continuous branches of eigenvectors and do not depend on the grid;
/// repeated roots (identical pendulums) have no unique shapes and are tracked by order only.
/// Crossings are found between these refined steps and located on the crossing track's own
/// mode ([`CROSSING_RTOL`]).
///
/// With `modal` the mechanism's dampers are replaced by modal damping
/// ([`LinearModel::with_modal_damping`], modes taken with the same `spin`) at every speed, and the
/// frequencies are the damped ones whatever `damping` says.
#[allow(clippy::too_many_arguments)]
pub fn campbell(
    mech: &Mechanism,
    spin_joint: &str,
    rpm: &[f64],
    orders: &[f64],
    spin: Spin,
    damping: Damping,
    modal: Option<&ModalDamping>,
    guess: Option<&[f64]>,
) -> LinResult<Campbell> {
    let modal = modal.map(|z| (z, ModalCombination::Replace));
    campbell_with(mech, spin_joint, rpm, orders, &CampbellOptions { spin, damping, modal, guess, deadline: None })
}

/// How [`campbell_with`] linearises and when it stops.
#[derive(Debug, Clone, Copy)]
pub struct CampbellOptions<'a> {
    /// The spin held or free in the modes.
    pub spin: Spin,
    /// Damped or undamped frequencies (damped whenever `modal` is given).
    pub damping: Damping,
    /// Modal damping and how it meets the mechanism's dampers
    /// ([`LinearModel::with_modal_damping_combined`]).
    pub modal: Option<(&'a ModalDamping, ModalCombination)>,
    /// A starting guess of the operating point at the first speed.
    pub guess: Option<&'a [f64]>,
    /// The watchdog's stop time: past it the diagram stops with
    /// [`LinearError::Watchdog`](super::LinearError::Watchdog) at the next speed.
    pub deadline: Option<crate::deadline::Deadline>,
}

/// [`campbell`] with every option: modal damping replacing the dampers or added to them, and a
/// deadline.
pub fn campbell_with(
    mech: &Mechanism,
    spin_joint: &str,
    rpm: &[f64],
    orders: &[f64],
    opts: &CampbellOptions<'_>,
) -> LinResult<Campbell> {
    let CampbellOptions { spin, damping, modal, guess, deadline } = *opts;
    let damping = if modal.is_some() { Damping::Damped } else { damping };
    let tracker = Tracker { mech, spin_joint, spin, damping, modal };
    let Some(&r0) = rpm.first() else {
        return Ok(Campbell { rpm: Vec::new(), tracks: Vec::new(), order_lines: Vec::new(), crossings: Vec::new() });
    };
    let mut step = tracker.first(r0, guess)?;
    let mut tracks: Vec<CampbellTrack> = step
        .modes
        .iter()
        .map(|m| CampbellTrack {
            label: String::new(),
            labels: vec![m.label.clone()],
            frequency_hz: vec![m.frequency_hz],
            natural_frequency_hz: vec![m.natural_frequency_hz],
            damping_ratio: vec![m.damping_ratio],
            rank: Vec::new(),
        })
        .collect();
    let mut crossings = Vec::new();
    // A line through a mode exactly at the first speed.
    for t in 0..tracks.len() {
        for &n in orders {
            if step.eigen_order(t) == n {
                let m = &step.modes[t];
                crossings.push(Crossing {
                    order: n,
                    track: t,
                    rpm: r0,
                    frequency_hz: m.frequency_hz,
                    label: m.label.clone(),
                    rank: 0,
                });
            }
        }
    }
    for (i, &r) in rpm.iter().enumerate().skip(1) {
        if let Some(d) = deadline.filter(|d| d.passed()) {
            return Err(super::LinearError::Watchdog {
                reached: format!("at {} rpm after {i} of {} speeds", rpm[i - 1], rpm.len()),
                budget_s: d.budget_s,
            });
        }
        let mut on_step = |a: &Step, b: &Step| -> LinResult<()> {
            for t in 0..a.modes.len() {
                tracker.crossings(orders, t, a, b, &mut crossings)?;
            }
            Ok(())
        };
        step = tracker.advance(&step, r, 0, &mut on_step)?;
        for (tr, m) in tracks.iter_mut().zip(&step.modes) {
            tr.labels.push(m.label.clone());
            tr.frequency_hz.push(m.frequency_hz);
            tr.natural_frequency_hz.push(m.natural_frequency_hz);
            tr.damping_ratio.push(m.damping_ratio);
        }
    }
    for tr in &mut tracks {
        let mut best = (0, String::new());
        for l in &tr.labels {
            let c = tr.labels.iter().filter(|x| *x == l).count();
            if c > best.0 {
                best = (c, l.clone());
            }
        }
        tr.label = best.1;
    }
    let order_lines = orders
        .iter()
        .map(|&n| OrderLine { order: n, frequency_hz: rpm.iter().map(|&r| n * r / 60.0).collect() })
        .collect();
    crossings.sort_by(|a, b| a.rpm.total_cmp(&b.rpm).then(a.order.total_cmp(&b.order)));
    for i in 0..rpm.len() {
        let mut by_f: Vec<usize> = (0..tracks.len()).collect();
        by_f.sort_by(|&a, &b| tracks[a].frequency_hz[i].total_cmp(&tracks[b].frequency_hz[i]).then(a.cmp(&b)));
        for (k, &t) in by_f.iter().enumerate() {
            tracks[t].rank.push(k + 1);
        }
    }
    for c in &mut crossings {
        let at = |tr: &CampbellTrack| interpolate(rpm, &tr.frequency_hz, c.rpm);
        c.rank = 1 + tracks.iter().enumerate().filter(|(t, tr)| *t != c.track && at(tr) < c.frequency_hz).count();
    }
    Ok(Campbell { rpm: rpm.to_vec(), tracks, order_lines, crossings })
}

/// `y(x)` by linear interpolation on the increasing grid `xs` (clamped at its ends).
fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    match xs.iter().position(|&v| v >= x) {
        None => ys.last().copied().unwrap_or(f64::NAN),
        Some(0) => ys[0],
        Some(i) => {
            let u = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
            ys[i - 1] + u * (ys[i] - ys[i - 1])
        }
    }
}
