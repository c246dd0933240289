//! Campbell data ([`campbell`]): the eigen-analysis of [`LinearModel::modes`] repeated over spin
//! speed, each speed linearised from the previous one's equilibrium, the modes tracked across
//! speeds by the modal assurance criterion (MAC) of their coordinate shapes, with the
//! engine-order lines `f = n·rpm/60` and their crossings with the modes: the resonance speeds
//! of torsional practice, where order n excites a mode. A crossing is where the mode's
//! eigen-order `f·60/rpm` equals n; it is bracketed on the speed grid and located by bisection
//! on the eigen-order, each probe speed linearised afresh and its mode picked by MAC with the
//! track's shape at the bracket.

use super::{C64, Damping, LinResult, LinearModel, ModalDamping, Spin};
use crate::model::excitation::rpm_to_rad_s;
use crate::model::mechanism::Mechanism;
use std::f64::consts::PI;

/// One tracked mode over the speeds of a Campbell diagram.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
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
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct OrderLine {
    /// The order n.
    pub order: f64,
    /// Its frequency at each speed, Hz.
    pub frequency_hz: Vec<f64>,
}

/// Where an order line crosses a mode: a resonance speed.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
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
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
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

/// Modal assurance criterion of two complex shapes, in [0, 1].
fn mac(a: &[C64], b: &[C64]) -> f64 {
    let dot: C64 = a.iter().zip(b).map(|(x, y)| x.conj() * y).sum();
    let na: f64 = a.iter().map(|x| x.norm_sqr()).sum();
    let nb: f64 = b.iter().map(|x| x.norm_sqr()).sum();
    if na == 0.0 || nb == 0.0 { 0.0 } else { dot.norm_sqr() / (na * nb) }
}

/// Campbell data of `mech` spinning on `spin_joint` over `rpm` (each speed linearised from the
/// previous speed's equilibrium, the first from `guess`), with the order lines of `orders`.
///
/// Tracking: at the first speed the modes are sorted by natural frequency; at each next speed
/// each track takes the mode whose coordinate shape q has the largest MAC with the track's
/// previous shape (greedy, largest MAC first). This follows a mode through a crossing with
/// another as long as the shapes stay distinct; repeated roots (identical pendulums) have no
/// unique shapes and are tracked by order only.
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
    let damping = if modal.is_some() { Damping::Damped } else { damping };
    let mut guess: Option<Vec<f64>> = guess.map(<[f64]>::to_vec);
    let mut tracks: Vec<CampbellTrack> = Vec::new();
    let mut last: Vec<Vec<C64>> = Vec::new();
    // Per speed: the equilibrium (a start for the bisection) and each track's shape.
    let mut equilibria: Vec<Vec<f64>> = Vec::with_capacity(rpm.len());
    let mut shapes: Vec<Vec<Vec<C64>>> = Vec::with_capacity(rpm.len());
    for (i, &r) in rpm.iter().enumerate() {
        let model = LinearModel::new(mech, spin_joint, rpm_to_rad_s(r), guess.as_deref())?;
        guess = Some(model.op.q.clone());
        let model = match modal {
            Some(z) => model.with_modal_damping(spin, z)?,
            None => model,
        };
        equilibria.push(model.op.q.clone());
        let mut modal = model.modes(spin, damping)?;
        if i == 0 {
            modal.modes.sort_by(|a, b| a.natural_frequency_rad_s.total_cmp(&b.natural_frequency_rad_s));
            for m in &modal.modes {
                tracks.push(CampbellTrack {
                    label: String::new(),
                    labels: vec![m.label.clone()],
                    frequency_hz: vec![m.frequency_hz],
                    natural_frequency_hz: vec![m.natural_frequency_rad_s / (2.0 * PI)],
                    damping_ratio: vec![m.damping_ratio],
                    rank: Vec::new(),
                });
                last.push(m.shape_q.clone());
            }
            shapes.push(last.clone());
            continue;
        }
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (t, shape) in last.iter().enumerate() {
            for (m, mode) in modal.modes.iter().enumerate() {
                pairs.push((mac(shape, &mode.shape_q), t, m));
            }
        }
        pairs.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut t_done = vec![false; tracks.len()];
        let mut m_done = vec![false; modal.modes.len()];
        for (_, t, m) in pairs {
            if t_done[t] || m_done[m] {
                continue;
            }
            t_done[t] = true;
            m_done[m] = true;
            let mode = &modal.modes[m];
            let tr = &mut tracks[t];
            tr.labels.push(mode.label.clone());
            tr.frequency_hz.push(mode.frequency_hz);
            tr.natural_frequency_hz.push(mode.natural_frequency_rad_s / (2.0 * PI));
            tr.damping_ratio.push(mode.damping_ratio);
            last[t] = mode.shape_q.clone();
        }
        shapes.push(last.clone());
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
    let mut crossings = Vec::new();
    let ctx = Bisection { mech, spin_joint, spin, damping, modal };
    for (t, tr) in tracks.iter().enumerate() {
        // Eigen-order at each grid speed; +∞ at standstill for a mode of non-zero frequency
        // (every order line starts below it there).
        let eo: Vec<f64> = rpm
            .iter()
            .zip(&tr.frequency_hz)
            .map(|(&r, &f)| {
                if r > 0.0 {
                    f * 60.0 / r
                } else if f > 0.0 {
                    f64::INFINITY
                } else {
                    f64::NAN
                }
            })
            .collect();
        for &n in orders {
            for i in 0..rpm.len().saturating_sub(1) {
                let (g0, g1) = (eo[i] - n, eo[i + 1] - n);
                if !(g0.is_finite() || g0 == f64::INFINITY) || !g1.is_finite() {
                    continue;
                }
                // A crossing inside (i, i+1], or exactly at the first grid speed.
                let at_start = i == 0 && g0 == 0.0;
                if !(at_start || (g0 != 0.0 && g0.signum() != g1.signum())) {
                    continue;
                }
                let (r, f, label) = if at_start {
                    (rpm[0], tr.frequency_hz[0], tr.labels[0].clone())
                } else if g1 == 0.0 {
                    (rpm[i + 1], tr.frequency_hz[i + 1], tr.labels[i + 1].clone())
                } else {
                    let at = (equilibria[i].as_slice(), shapes[i][t].as_slice());
                    ctx.locate(n, (rpm[i], g0 > 0.0), rpm[i + 1], at, tr.labels[i + 1].clone())?
                };
                crossings.push(Crossing { order: n, track: t, rpm: r, frequency_hz: f, label, rank: 0 });
            }
        }
    }
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

/// What the bisection for a crossing needs to linearise at a probe speed.
struct Bisection<'a> {
    mech: &'a Mechanism,
    spin_joint: &'a str,
    spin: Spin,
    damping: Damping,
    modal: Option<&'a ModalDamping>,
}

impl Bisection<'_> {
    /// The mode nearest (by MAC) to `shape` at `r` rpm, linearised from `guess`: its eigen-order
    /// (damped frequency over speed) and label.
    fn mode_at(&self, r: f64, guess: &[f64], shape: &[C64]) -> LinResult<(f64, String)> {
        let model = LinearModel::new(self.mech, self.spin_joint, rpm_to_rad_s(r), Some(guess))?;
        let model = match self.modal {
            Some(z) => model.with_modal_damping(self.spin, z)?,
            None => model,
        };
        let modal = model.modes(self.spin, self.damping)?;
        let best = modal
            .modes
            .iter()
            .max_by(|a, b| mac(shape, &a.shape_q).total_cmp(&mac(shape, &b.shape_q)))
            .ok_or_else(|| super::LinearError::Invalid(format!("no vibration mode at {r} rpm")))?;
        Ok((best.frequency_hz * 60.0 / r, best.label.clone()))
    }

    /// Bisection on `eigen-order − n` between `lo` rpm (where the eigen-order is above n when
    /// `above`) and `hi` rpm, to [`CROSSING_RTOL`] in speed: (rpm, frequency in Hz, label; the
    /// label is `label` when the bracket needed no probe).
    fn locate(
        &self,
        n: f64,
        (mut lo, above): (f64, bool),
        mut hi: f64,
        (guess, shape): (&[f64], &[C64]),
        mut label: String,
    ) -> LinResult<(f64, f64, String)> {
        for _ in 0..200 {
            if hi - lo <= CROSSING_RTOL * hi {
                break;
            }
            let mid = 0.5 * (lo + hi);
            let (eo, l) = self.mode_at(mid, guess, shape)?;
            label = l;
            if ((eo - n) > 0.0) == above {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        // The bracket's midpoint, with the line's frequency there (the mode's equals it to the
        // bracket's width).
        let r = 0.5 * (lo + hi);
        Ok((r, n * r / 60.0, label))
    }
}
