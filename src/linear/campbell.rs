//! Campbell data ([`campbell`]): the eigen-analysis of [`LinearModel::modes`] repeated over spin
//! speed, each speed linearised from the previous one's equilibrium, the modes tracked across
//! speeds by the modal assurance criterion (MAC) of their coordinate shapes, with the
//! engine-order lines `f = n·rpm/60`.

use super::{C64, Damping, LinResult, LinearModel, Spin};
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
}

/// An engine-order line `f = n·rpm/60`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct OrderLine {
    /// The order n.
    pub order: f64,
    /// Its frequency at each speed, Hz.
    pub frequency_hz: Vec<f64>,
}

/// Campbell data: natural frequencies against spin speed, with order lines.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Campbell {
    /// Spin speeds, rpm.
    pub rpm: Vec<f64>,
    /// The n − 1 vibration modes, tracked across speeds.
    pub tracks: Vec<CampbellTrack>,
    /// The order lines.
    pub order_lines: Vec<OrderLine>,
}

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
pub fn campbell(
    mech: &Mechanism,
    spin_joint: &str,
    rpm: &[f64],
    orders: &[f64],
    spin: Spin,
    damping: Damping,
    guess: Option<&[f64]>,
) -> LinResult<Campbell> {
    let mut guess: Option<Vec<f64>> = guess.map(<[f64]>::to_vec);
    let mut tracks: Vec<CampbellTrack> = Vec::new();
    let mut last: Vec<Vec<C64>> = Vec::new();
    for (i, &r) in rpm.iter().enumerate() {
        let model = LinearModel::new(mech, spin_joint, rpm_to_rad_s(r), guess.as_deref())?;
        guess = Some(model.op.q.clone());
        let modal = model.modes(spin, damping)?;
        if i == 0 {
            for m in &modal.modes {
                tracks.push(CampbellTrack {
                    label: String::new(),
                    labels: vec![m.label.clone()],
                    frequency_hz: vec![m.frequency_hz],
                    natural_frequency_hz: vec![m.natural_frequency_rad_s / (2.0 * PI)],
                    damping_ratio: vec![m.damping_ratio],
                });
                last.push(m.shape_q.clone());
            }
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
    Ok(Campbell { rpm: rpm.to_vec(), tracks, order_lines })
}
