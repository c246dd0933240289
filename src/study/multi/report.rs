//! The multi-order analysis's figure (the steady response per order over the speeds, locked and
//! linear references, and the elements) and its summary section.

use super::{MultiOrderResult, SpeedResult, table};
use crate::error::Result;
use crate::plot::{LineStyle, Panel, PointLabel, Series, num};
use crate::study::elements::{element_table, labelled_element_table};
use crate::study::sweep::order_name;
use crate::study::{MultiOrderSpec, Study, cell};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Writes the CSV ([`table`]) and the figure (the paper's Fig. 5: [`response_panel`], then
/// [`element_panels`]), and returns the summary section with the files written.
pub(super) fn render(
    study: &Study,
    spec: &MultiOrderSpec,
    result: &MultiOrderResult,
    dir: &Path,
) -> Result<(String, Vec<PathBuf>)> {
    let csv = table(study, spec, result).write_csv(dir)?;
    let mut panels = vec![response_panel(study, spec, result)];
    panels.extend(element_panels(study, spec, result));
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &panels, 640, 480)?;

    Ok((summary(spec, result), vec![csv, svg]))
}

/// Figure 5: each order against the speed, the mechanism solid, the locked twin dotted, the
/// linear model dashed (the harmonic balance's state where there are no time runs), with the
/// jumps between speeds labelled.
fn response_panel(study: &Study, spec: &MultiOrderSpec, result: &MultiOrderResult) -> Panel {
    let has_locked = study.locked.is_some();
    let rpm: Vec<f64> = result.speeds.iter().map(|s| s.rpm).collect();
    let mut series = Vec::new();
    for (k, m) in spec.multiples.iter().enumerate() {
        let ys = |f: &dyn Fn(&SpeedResult) -> f64| result.speeds.iter().map(f).collect::<Vec<f64>>();
        let mut add =
            |label: String, y: Vec<f64>, style| series.push(Series { label, x: rpm.clone(), y, color: k, style });
        if spec.time_domain {
            add(format!("{} ({}n)", order_name(*m), fmt_mult(*m)), ys(&|s| s.amplitude(k)), LineStyle::Solid);
            if has_locked {
                add(format!("{}, locked", order_name(*m)), ys(&|s| s.locked_amplitude(k)), LineStyle::Dotted);
            }
        }
        // Without time runs the torque ramp's harmonic-balance state is the nonlinear line.
        let hbm_lines = spec.hbm && !spec.time_domain;
        if hbm_lines {
            add(
                format!("{} ({}n), HBM", order_name(*m), fmt_mult(*m)),
                ys(&|s| s.hbm_amplitude(k, false)),
                LineStyle::Solid,
            );
            if has_locked {
                add(format!("{}, HBM locked", order_name(*m)), ys(&|s| s.hbm_amplitude(k, true)), LineStyle::Dotted);
            }
        }
        if spec.linear {
            add(format!("{}, linear", order_name(*m)), ys(&|s| s.linear_amplitude(k, false)), LineStyle::Dashed);
            if !spec.time_domain && has_locked {
                let style = if hbm_lines { LineStyle::Points } else { LineStyle::Dotted };
                add(format!("{}, linear locked", order_name(*m)), ys(&|s| s.linear_amplitude(k, true)), style);
            }
        }
    }
    let top = series.iter().flat_map(|s| s.y.iter().copied()).filter(|v| v.is_finite()).fold(0.0, f64::max);
    let labels = jump_labels(spec, result);
    Panel {
        y_range: Some((0.0, 1.1 * top.max(f64::MIN_POSITIVE))),
        title: format!("Steady multi-order response, n = {}", num(spec.order, 5)),
        x_label: "mean speed, rpm".into(),
        y_label: format!("{} angular acceleration, rad/s²", study.spec.response_body),
        log_y: false,
        series: with_sample_markers(series),
        labels,
        ..Panel::default()
    }
}

/// The elements' panels over the speeds: the torque transmitted by the shaft-like elements,
/// and the amplitude of the others.
fn element_panels(study: &Study, spec: &MultiOrderSpec, result: &MultiOrderResult) -> Vec<Panel> {
    let rpm: Vec<f64> = result.speeds.iter().map(|s| s.rpm).collect();
    let mut panels = Vec::new();
    // The elements' amplitudes at each tracked order over the speeds: from the time runs, or
    // from the torque ramp's harmonic-balance state (else the lowest state) where there are none,
    // or from the linear response in a linear-only analysis (the marine gearbox's propeller-shaft
    // torque, the question of its study).
    let linear_only = result.speeds.iter().all(|s| s.response.is_none() && s.hbm_ramp.is_none() && s.hbm.is_empty());
    fn elements_of(s: &SpeedResult, linear_only: bool) -> Option<&Vec<crate::study::elements::ElementResponse>> {
        s.response
            .as_ref()
            .map(|r| &r.elements)
            .or_else(|| s.hbm_ramp.as_ref().map(|h| &h.elements))
            .or_else(|| s.hbm.first().map(|h| &h.elements))
            .or_else(|| (linear_only && !s.linear_elements.is_empty()).then_some(&s.linear_elements))
    }
    let names: Vec<String> = result
        .speeds
        .iter()
        .find_map(|s| elements_of(s, linear_only))
        .map(|els| els.iter().map(|e| e.joint.clone()).collect())
        .unwrap_or_default();
    // What the shaft-like elements transmit, N·m (N for a slide): those with a spring or a
    // coupling (staged spring, friction, stops) carry the driveline's torque, which a driveline
    // study asks for (the truck study: "the torque in the input shaft") and their twist only
    // implies. The others (an absorber's pivot, whose damper transmits next to nothing) keep
    // their amplitude, in rad, on a panel of their own: one unit per axis.
    let mech = &study.mechanism;
    let shaft = |name: &str| {
        mech.joint_index(name).is_some_and(|j| mech.joints[j].spring.is_some() || !mech.joints[j].couplings.is_empty())
    };
    let element_value = |s: &SpeedResult, e: usize, k: usize, torque: bool| {
        let el = elements_of(s, linear_only).and_then(|els| els.get(e));
        let v = if torque {
            el.and_then(|el| el.torque.as_ref()).map(|t| &t.amplitude)
        } else {
            el.map(|el| &el.amplitude)
        };
        v.and_then(|v| v.get(k).copied()).unwrap_or(f64::NAN)
    };
    for torque in [true, false] {
        let mut element_series = Vec::new();
        for (e, name) in names.iter().enumerate().filter(|(_, n)| shaft(n) == torque) {
            for (k, m) in spec.multiples.iter().enumerate() {
                // Linear values are dashed, as on the response panel.
                element_series.push(Series {
                    label: format!("{name}, {}{}", order_name(*m), if linear_only { ", linear" } else { "" }),
                    x: rpm.clone(),
                    y: result.speeds.iter().map(|s| element_value(s, e, k, torque)).collect(),
                    color: e,
                    style: if linear_only {
                        [LineStyle::Dashed, LineStyle::Dotted][k % 2]
                    } else {
                        [LineStyle::Solid, LineStyle::Dashed, LineStyle::Dotted][k % 3]
                    },
                });
            }
        }
        if element_series.is_empty() {
            continue;
        }
        let (title, y_label) = if torque {
            ("Torque in the elements", "transmitted torque amplitude, N·m (N for slides)")
        } else {
            ("Elements", "amplitude, rad (m for slides)")
        };
        panels.push(Panel {
            title: format!("{title}, n = {}", num(spec.order, 5)),
            x_label: "mean speed, rpm".into(),
            y_label: y_label.into(),
            log_y: true,
            series: with_sample_markers(element_series),
            ..Panel::default()
        });
    }
    panels
}

/// Few speeds (a list of operating points, not a fine grid): the lines between them are
/// straight guesses, so each sampled speed gets a marker (filled circles, no legend entry).
const MARKED_SPEEDS: usize = 40;

/// `series` followed by a marker series for each of them when they have at most
/// [`MARKED_SPEEDS`] points.
fn with_sample_markers(series: Vec<Series>) -> Vec<Series> {
    let marks: Vec<Series> = series
        .iter()
        .filter(|s| s.x.len() <= MARKED_SPEEDS)
        .map(|s| Series { label: String::new(), style: LineStyle::Points, ..s.clone() })
        .collect();
    series.into_iter().chain(marks).collect()
}

/// The jumps between neighbouring speeds: where the torque ramp's low-amplitude branch reaches
/// the full torques at one speed and folds before them at the next (`hbm_lower_fold`), a run
/// settles on different states on either side, so the response jumps between those speeds. Each
/// is marked at the main order's value on the upper state (time domain, else harmonic balance).
fn jump_labels(spec: &MultiOrderSpec, result: &MultiOrderResult) -> Vec<PointLabel> {
    let value = |s: &SpeedResult| {
        let v = s.amplitude(0);
        if v.is_finite() { v } else { s.hbm.last().and_then(|h| h.amplitudes.first().copied()).unwrap_or(f64::NAN) }
    };
    if !spec.hbm || spec.multiples.is_empty() {
        return Vec::new();
    }
    result
        .speeds
        .windows(2)
        .filter(|w| w[0].hbm_lower_fold.is_some() != w[1].hbm_lower_fold.is_some())
        .filter_map(|w| {
            let upper = if w[0].hbm_lower_fold.is_some() { &w[0] } else { &w[1] };
            let y = value(upper);
            y.is_finite().then(|| PointLabel {
                x: upper.rpm,
                y,
                text: format!("jump between {} and {} rpm", num(w[0].rpm, 5), num(w[1].rpm, 5)),
                marker: true,
            })
        })
        .collect()
}

/// The factor between the linear and the nonlinear main-order amplitude from which the summary
/// says that the linear model does not hold (a factor 1.5 is far outside the linear model's own
/// error on a mechanism whose nonlinearity is weak: the paper's rotor off resonance agrees to
/// a few per cent).
const LINEAR_GAP: f64 = 1.5;

/// A paragraph when the linear model's main-order amplitude and the nonlinear one (time
/// domain, else the torque ramp's harmonic-balance state) differ by more than [`LINEAR_GAP`]
/// at some speed: where, by how much, and why (empty otherwise).
fn linear_gap(spec: &MultiOrderSpec, r: &MultiOrderResult) -> String {
    if !spec.linear || spec.multiples.is_empty() {
        return String::new();
    }
    let (route, nonlinear): (&str, &dyn Fn(&SpeedResult) -> f64) = if spec.time_domain {
        ("time-domain", &|s| s.amplitude(0))
    } else if spec.hbm {
        ("harmonic-balance", &|s| s.hbm_amplitude(0, false))
    } else {
        return String::new();
    };
    let factors: Vec<(f64, f64, f64, f64)> = r
        .speeds
        .iter()
        .filter_map(|s| {
            let (lin, nl) = (s.linear_amplitude(0, false), nonlinear(s));
            (lin.is_finite() && nl.is_finite() && lin > 0.0 && nl > 0.0)
                .then(|| (s.rpm, lin, nl, (lin / nl).max(nl / lin)))
        })
        .collect();
    let apart = factors.iter().filter(|f| f.3 > LINEAR_GAP).count();
    let Some(&(rpm, lin, nl, worst)) = factors.iter().max_by(|a, b| a.3.total_cmp(&b.3)).filter(|f| f.3 > LINEAR_GAP)
    else {
        return String::new();
    };
    let word = if lin > nl { "larger" } else { "smaller" };
    format!(
        "**Linear against nonlinear.** The linear model's {} amplitude is {} {word} than the {route} one at {} \
         rpm ({} against {} rad/s²), and differs from it by more than {LINEAR_GAP}× at {apart} of the {} speeds. \
         The linear model is the mechanism linearised at its operating point: friction, staged springs, stops \
         and the absorbers' amplitude-dependent tuning act in the nonlinear columns only, which are the ones to \
         read at those speeds.\n\n",
        order_name(spec.multiples[0]),
        format_args!("{}×", num(worst, 3)),
        num(rpm, 5),
        num(lin, 4),
        num(nl, 4),
        r.speeds.len(),
    )
}

pub(super) fn fmt_mult(m: f64) -> String {
    crate::study::sweep::fmt_num(m)
}

/// A number in exponent form for a summary table, or "not measured" when it is not finite (a
/// run that failed before it could be measured).
fn sci(v: f64, precision: usize) -> String {
    if v.is_finite() { format!("{v:.precision$e}") } else { "not measured".into() }
}

fn summary(spec: &MultiOrderSpec, r: &MultiOrderResult) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "## Multi-order response `{}`: n = {}, steady states\n", spec.name, spec.order);
    md += &damping_and_gravity(spec, r);
    md += &engine_table(r);
    md += &share_table(spec);
    md += &speed_table(spec, r);
    md += &linear_gap(spec, r);
    md += &linear_element_peaks(r);
    // Element by element over the last window: every absorber and spring, not only the largest.
    let steady = r
        .speeds
        .iter()
        .flat_map(|s| s.response.iter().flat_map(move |resp| resp.elements.iter().map(move |e| (s.rpm, e))));
    md += &element_table(steady, &spec.multiples);
    if spec.hbm {
        md += &hbm_table(spec, r);
    }
    md
}

/// With gravity, what its linear column is; with modal damping, where it acts.
fn damping_and_gravity(spec: &MultiOrderSpec, r: &MultiOrderResult) -> String {
    let mut md = String::new();
    let gravity = r.speeds.iter().any(|s| s.linear_gravity.is_some());
    if gravity {
        let _ = writeln!(
            md,
            "The mechanism has gravity: only the linear part runs. Gravity forces the rotation at order 1 \
             (exactly, at the nominal rotation); its response through the same linear transfer is the column \
             \"order 1 gravity linear\" (CSV `linear_gravity_order1_rad_s2`) and is added as a phasor to a \
             tracked multiple at order 1. The gravity × deflection terms, second order, are neglected.\n"
        );
    }
    if let Some((z, how)) = spec.modal().filter(|_| spec.linear) {
        let _ = writeln!(
            md,
            "Modal damping of the linear columns: {} ({}; modes with the spin free at each speed). The time \
             runs and the harmonic balance keep the mechanism's own dampers.\n",
            z.describe(),
            how.describe()
        );
    }
    md
}

/// The table of speeds (thinned on a fine grid): per tracked multiple the time-domain amplitude
/// with the locked twin's and their ratio and the linear ones, gravity's linear line, and the
/// runs' convergence, largest angle, time and mean-speed correction.
fn speed_table(spec: &MultiOrderSpec, r: &MultiOrderResult) -> String {
    let mut md = String::new();
    let gravity = r.speeds.iter().any(|s| s.linear_gravity.is_some());
    let mut head = "| rpm |".to_string();
    let mut rule = "|---|".to_string();
    for m in &spec.multiples {
        let tag = fmt_mult(*m);
        if spec.time_domain {
            let _ = write!(head, " {tag}n (rad/s²) | {tag}n locked | {tag}n ratio |");
            rule += "---|---|---|";
        }
        if spec.linear {
            let _ = write!(head, " {tag}n linear | {tag}n linear ratio |");
            rule += "---|---|";
        }
    }
    if gravity {
        head += " order 1 gravity linear (rad/s²) | order 1 gravity linear locked |";
        rule += "---|---|";
    }
    if spec.time_domain {
        head +=
            " last-two-window change | max abs relative angle (rad) | simulated (s) | mean-speed correction (rad/s) |";
        rule += "---|---|---|---|";
    }
    let shown = thinned(r.speeds.len());
    if shown.1 > 1 {
        let _ = writeln!(md, "Every {}th of the {} speeds (each one is in the CSV):\n", shown.1, r.speeds.len());
    }
    let _ = writeln!(md, "{head}\n{rule}");
    for s in r.speeds.iter().enumerate().filter(|(i, _)| shown.0(*i)).map(|(_, s)| s) {
        let mut row = format!("| {} |", s.rpm);
        for k in 0..spec.multiples.len() {
            if spec.time_domain {
                let (a, l) = (s.amplitude(k), s.locked_amplitude(k));
                let _ = write!(row, " {} | {} | {} |", cell(a, 4), cell(l, 4), cell(s.ratio(k), 3));
            }
            if spec.linear {
                let a = s.linear_amplitude(k, false);
                let _ = write!(row, " {} | {} |", cell(a, 4), cell(s.linear_ratio(k), 3));
            }
        }
        if gravity {
            let g = |v: Option<f64>| {
                v.map_or("undefined".into(), |v| if v.is_finite() { format!("{v:.4e}") } else { "undefined".into() })
            };
            let _ = write!(row, " {} | {} |", g(s.linear_gravity), g(s.linear_gravity_locked));
        }
        if let Some(resp) = &s.response {
            // A run that stopped before two windows were compared has no change (NaN): it
            // used to print "NaN (locked 1.7e-14)" next to its Failures entry.
            let _ = write!(
                row,
                " {}{} | {} | {} | {} |",
                sci(resp.change, 1),
                s.locked.as_ref().map_or(String::new(), |l| format!(" (locked {})", sci(l.change, 1))),
                cell(resp.max_relative_angle, 4),
                cell(resp.time_s, 0),
                sci(resp.speed_correction, 2)
            );
        }
        let _ = writeln!(md, "{row}");
    }
    md.push('\n');
    md
}

/// The harmonic balance at the operating order: every branch's states per speed, the match with
/// the time domain, the low-amplitude branch, and the torque ramp's states ([`ramp_table`]).
fn hbm_table(spec: &MultiOrderSpec, r: &MultiOrderResult) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "Harmonic balance (H = 10) at the operating order, every branch:\n");
    let _ = writeln!(
        md,
        "| rpm | states (main, second rad/s²; stability) | time domain vs nearest stable HBM | low-amplitude branch |"
    );
    let _ = writeln!(md, "|---|---|---|---|");
    for s in &r.speeds {
        let states: Vec<String> = s
            .hbm
            .iter()
            .map(|h| {
                let st = match h.stable {
                    Some(true) => "stable",
                    Some(false) => "unstable",
                    None => "?",
                };
                let amps: Vec<String> = h.amplitudes.iter().map(|a| cell(*a, 3)).collect();
                format!("({}; {st})", amps.join(", "))
            })
            .collect();
        let m = s.hbm_match().map_or("–".into(), |(_, d)| format!("{} relative", sci(d, 2)));
        let low = s.hbm_lower_fold.map_or("reaches the full torques".into(), |f| {
            format!("ends at {} × the torques (fold): only the upper state remains", cell(f, 4))
        });
        let _ = writeln!(md, "| {} | {} | {m} | {low} |", s.rpm, states.join(" "));
    }
    md.push('\n');
    // Every state's elements, the upper state's too where the low branch folds and no ramp
    // state carries them.
    let rows = r.speeds.iter().flat_map(|s| {
        s.hbm.iter().enumerate().flat_map(move |(k, h)| {
            let st = match h.stable {
                Some(true) => "stable",
                Some(false) => "unstable",
                None => "?",
            };
            h.elements.iter().map(move |e| (format!("{} (state {}, {st})", s.rpm, k + 1), e))
        })
    });
    let t = labelled_element_table("rpm (state)", rows, &spec.multiples);
    if !t.is_empty() {
        let _ =
            writeln!(md, "Elements on every state (numbered as listed above; CSV columns `hbm_state<k>_<joint>_…`):\n");
        md += &t;
    }
    let _ = writeln!(
        md,
        "The low-amplitude branch is continued in the torque scale s (all harmonics times s) from s = 0.01 \
         at the operating order; where it folds below s = 1 a run at these torques cannot settle on it \
         and jumps to the upper state (the paper's Fig. 5 at 600 rpm).\n"
    );
    md += &ramp_table(spec, r);
    md
}

/// Which rows of an n-speed table the summary shows, and the stride: every one up to 60 speeds,
/// else every ⌈n/40⌉th and the last (a fine speed grid stays readable; the CSV has them all).
fn thinned(n: usize) -> (impl Fn(usize) -> bool, usize) {
    let stride = if n > 60 { n.div_ceil(40) } else { 1 };
    (move |i: usize| i.is_multiple_of(stride) || i + 1 == n, stride)
}

/// The largest linear torque of each reported element over the speeds, at its grid speed and
/// refined between the grid speeds by the parabola through the largest value and its two
/// neighbours (a resonance's peak on a fine grid); empty without linear elements.
fn linear_element_peaks(r: &MultiOrderResult) -> String {
    let Some(first) = r.speeds.iter().find(|s| !s.linear_elements.is_empty()) else { return String::new() };
    let mut md = String::from(
        "Linear response of the elements: the largest torque of each element's spring and damper over the \
         speeds (superposed harmonics), at its grid speed and refined by a parabola through its neighbours:\n\n\
         | element | peak torque (N·m; N) | at rpm | refined peak | at rpm |\n|---|---|---|---|---|\n",
    );
    for (e, el) in first.linear_elements.iter().enumerate() {
        let values: Vec<(f64, f64)> = r
            .speeds
            .iter()
            .map(|s| (s.rpm, s.linear_elements.get(e).and_then(|x| x.torque.as_ref()).map_or(f64::NAN, |t| t.peak)))
            .collect();
        let Some((i, &(rpm, top))) =
            values.iter().enumerate().filter(|(_, v)| v.1.is_finite()).max_by(|a, b| a.1.1.total_cmp(&b.1.1))
        else {
            continue;
        };
        let refined =
            (i > 0 && i + 1 < values.len()).then(|| parabola_vertex(values[i - 1], values[i], values[i + 1])).flatten();
        let (rr, rt) = refined.map_or(("–".into(), "–".into()), |(x, y)| (format!("{x:.4}"), format!("{y:.5e}")));
        let _ = writeln!(md, "| `{}` | {top:.5e} | {rpm} | {rt} | {rr} |", el.joint);
    }
    md.push('\n');
    md
}

/// The maximum of the parabola through three points (x ascending, the middle one the largest):
/// `(x, y)` at its vertex, None when the points do not bend down.
fn parabola_vertex((x0, y0): (f64, f64), (x1, y1): (f64, f64), (x2, y2): (f64, f64)) -> Option<(f64, f64)> {
    let (h0, h2) = (x0 - x1, x2 - x1);
    // y = y1 + b t + a t², t = x − x1, through the two neighbours.
    let a = ((y2 - y1) / h2 - (y0 - y1) / h0) / (h2 - h0);
    let b = (y0 - y1) / h0 - a * h0;
    let t = -b / (2.0 * a);
    (a < 0.0 && (h0..=h2).contains(&t)).then(|| (x1 + t, y1 - b * b / (4.0 * a)))
}

/// With an engine: its order torques T_k at each speed (N·m, before any joint's share), the
/// excitation every other table answers.
fn engine_table(r: &MultiOrderResult) -> String {
    let orders = super::engine_orders(r);
    let mut md = String::new();
    if orders.is_empty() {
        return md;
    }
    let _ =
        writeln!(md, "The engine's order torques T_k at each speed (N·m, from its cylinder pressure and inertia):\n");
    let head: String = orders.iter().map(|o| format!(" T order {} (N·m) |", fmt_mult(*o))).collect();
    let _ = writeln!(md, "| rpm |{head}\n|---|{}", "---|".repeat(orders.len()));
    let shown = thinned(r.speeds.len());
    for s in r.speeds.iter().enumerate().filter(|(i, _)| shown.0(*i)).map(|(_, s)| s) {
        let cells: String = orders.iter().map(|&o| format!(" {} |", cell(s.engine_torque(o), 4))).collect();
        let _ = writeln!(md, "| {} |{cells}", s.rpm);
    }
    md.push('\n');
    md
}

/// With amplitude laws in speed: each excited joint's share at each speed (its `scale` times its
/// law's factor), the multiplier on every harmonic there.
fn share_table(spec: &MultiOrderSpec) -> String {
    let mut md = String::new();
    if spec.excite.iter().all(|e| e.law.is_constant()) {
        return md;
    }
    let _ =
        writeln!(md, "Excitation shares at each speed (scale × the joint's law in speed; every harmonic times it):\n");
    let head: String = spec.excite.iter().map(|e| format!(" `{}` |", e.joint)).collect();
    let _ = writeln!(md, "| rpm |{head}\n|---|{}", "---|".repeat(spec.excite.len()));
    let shown = thinned(spec.speeds.len());
    for p in spec.speeds.iter().enumerate().filter(|(i, _)| shown.0(*i)).map(|(_, p)| p) {
        let cells: String = crate::study::excite_at_rpm(&spec.excite, p.rpm)
            .iter()
            .map(|e| format!(" {} |", cell(e.scale, 6)))
            .collect();
        let _ = writeln!(md, "| {} |{cells}", p.rpm);
    }
    md.push('\n');
    md
}

/// The torque ramp's harmonic-balance states with and without the absorber (the locked twin),
/// and their elements.
fn ramp_table(spec: &MultiOrderSpec, r: &MultiOrderResult) -> String {
    let mut md = String::new();
    let locked = r.speeds.iter().any(|s| s.hbm_locked.is_some() || s.hbm_locked_fold.is_some());
    let _ = writeln!(
        md,
        "The state a slow run-up of the torques reaches (the low-amplitude branch at s = 1){}:\n",
        if locked { ", with the absorbers free and locked" } else { "" }
    );
    let mut head = "| rpm |".to_string();
    let mut rule = "|---|".to_string();
    for m in &spec.multiples {
        let tag = fmt_mult(*m);
        head += &format!(" {tag}n HBM (rad/s²) |");
        rule += "---|";
        if locked {
            head += &format!(" {tag}n HBM locked | {tag}n ratio |");
            rule += "---|---|";
        }
    }
    let _ = writeln!(md, "{head}\n{rule}");
    let fold = |f: Option<f64>| f.map_or("–".to_string(), |f| format!("fold at s = {}", cell(f, 4)));
    for s in &r.speeds {
        let mut row = format!("| {} |", s.rpm);
        for k in 0..spec.multiples.len() {
            let a = if s.hbm_ramp.is_some() { cell(s.hbm_amplitude(k, false), 4) } else { fold(s.hbm_lower_fold) };
            let _ = write!(row, " {a} |");
            if locked {
                let l =
                    if s.hbm_locked.is_some() { cell(s.hbm_amplitude(k, true), 4) } else { fold(s.hbm_locked_fold) };
                let _ = write!(row, " {l} | {} |", cell(s.hbm_ratio(k), 3));
            }
        }
        let _ = writeln!(md, "{row}");
    }
    md.push('\n');
    for (what, locked) in [("absorbers free", false), ("absorbers locked", true)] {
        let rows = r.speeds.iter().flat_map(move |s| {
            let st = if locked { s.hbm_locked.as_ref() } else { s.hbm_ramp.as_ref() };
            st.into_iter().flat_map(move |h| h.elements.iter().map(move |e| (s.rpm, e)))
        });
        let t = element_table(rows, &spec.multiples);
        if !t.is_empty() {
            let _ = writeln!(md, "Elements on that state, {what}:\n");
            md += &t;
        }
    }
    md
}
