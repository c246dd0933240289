//! The line plots' and the number format's tests.

use super::legend::legend_corner;
use super::vector::{FIELD, MARK};
use super::*;

#[test]
fn writes_an_svg_with_all_styles_and_a_log_axis() {
    let tmp = tempfile::Builder::new().prefix("kanedyn-plot-").tempdir().unwrap();
    let dir = tmp.path();
    let x: Vec<f64> = (0..50).map(|i| 2.9 + 0.008 * i as f64).collect();
    let s = |style, color, f: fn(f64) -> f64| Series {
        label: format!("{style:?}"),
        x: x.clone(),
        y: x.iter().map(|&v| f(v)).collect(),
        color,
        style,
    };
    let panel = Panel {
        title: "test".into(),
        x_label: "order n".into(),
        y_label: "rad/s²".into(),
        log_y: true,
        markers: vec![(3.11, "n_t".into())],
        series: vec![
            s(LineStyle::Solid, 0, |v| v * v),
            s(LineStyle::Dashed, 1, |v| v),
            s(LineStyle::Dotted, 2, |v| (v - 3.0).abs()),
        ],
        ..Panel::default()
    };
    let lin = Panel { log_y: false, ..panel.clone() };
    let path = dir.join("p.svg");
    write_svg(&path, &[panel, lin], 500, 350).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.starts_with("<svg"));
    assert!(text.contains("order n") && text.contains("Dashed") && text.contains("n_t"));
}

/// A curve rising into the upper right sends the legend to the empty upper left; with every
/// corner free the legend stays upper right.
#[test]
fn legend_avoids_the_curves() {
    let x: Vec<f64> = (0..100).map(|i| i as f64 / 99.0).collect();
    let rising = Series {
        label: "a".into(),
        x: x.clone(),
        y: x.iter().map(|v| v * v).collect(),
        color: 0,
        style: LineStyle::Solid,
    };
    let panel = Panel { series: vec![rising], ..Panel::default() };
    let ranges = ((0.0, 1.0), (0.0, 1.0));
    assert!(matches!(legend_corner(&panel, ranges, (0.3, 0.2)), SeriesLabelPosition::UpperLeft));
    let flat = Series { label: "b".into(), x: x.clone(), y: vec![0.5; 100], color: 1, style: LineStyle::Dashed };
    let panel = Panel { series: vec![flat], ..Panel::default() };
    assert!(matches!(legend_corner(&panel, ranges, (0.3, 0.2)), SeriesLabelPosition::UpperRight));
}

/// The rewrite divides by [`FINE`] exactly, keeps the rotation angle and the text, and drops a
/// point equal to the one before it (here 1234,500 twice after 1234,500: plotters' whole units).
#[test]
fn vector_writes_two_decimals_and_drops_repeated_points() {
    let fine = "<svg width=\"76000\" height=\"52000\" viewBox=\"0 0 76000 52000\" xmlns=\"http://www.w3.org/2000/svg\">\n\
        <polyline fill=\"none\" stroke-width=\"200\" points=\"1234,500 1234,500 -7,12345 1234,500 \"/>\n\
        <text x=\"100\" y=\"2005\" font-size=\"967.741935483871\" transform=\"rotate(270, 100, 2005)\">\n\
        x = 3 &lt; 4\n</text>\n</svg>\n";
    let v = vector(fine);
    assert!(v.starts_with("<svg width=\"760\" height=\"520\" viewBox=\"0 0 760 520\""), "{v}");
    assert!(v.contains("stroke-width=\"2\" points=\"12.34,5.00 -0.07,123.45 12.34,5.00 \""), "{v}");
    assert!(v.contains("x=\"1.00\" y=\"20.05\" font-size=\"9.68\" transform=\"rotate(270, 1.00, 20.05)\""), "{v}");
    assert!(v.contains("\nx = 3 &lt; 4\n</text>"), "{v}");
}

/// The figure's groups let a reader turn pixels back into data: each curve sits in its own
/// `kd-series` group inside a `kd-panel` group whose mapping, inverted, gives the curve's
/// first point back (linear x, logarithmic y), and no marker text is left in the file.
#[test]
fn groups_carry_the_axes_mapping() {
    let tmp = tempfile::Builder::new().prefix("kanedyn-plot-groups-").tempdir().unwrap();
    let dir = tmp.path();
    let x: Vec<f64> = (0..40).map(|i| 1.0 + 0.05 * i as f64).collect();
    let y: Vec<f64> = x.iter().map(|v| v.powi(3)).collect();
    let series = Series { label: "cubic \"c\"".into(), x: x.clone(), y: y.clone(), ..Series::default() };
    let panel =
        Panel { x_label: "x, m".into(), y_label: "y, N".into(), log_y: true, series: vec![series], ..Panel::default() };
    let path = dir.join("g.svg");
    write_svg(&path, &[panel], 500, 350).unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    assert!(!svg.contains(MARK) && !svg.contains(FIELD));
    assert_eq!(svg.matches("<g ").count(), svg.matches("</g>").count());
    let attr = |name: &str| -> Vec<f64> {
        let key = format!(" {name}=\"");
        let v = &svg[svg.find(&key).unwrap_or_else(|| panic!("{name}")) + key.len()..];
        v[..v.find('"').unwrap()].split(' ').map(|t| t.parse().unwrap()).collect()
    };
    let (pxs, pys, xs, ys) = (attr("data-px"), attr("data-py"), attr("data-x"), attr("data-y"));
    assert!(svg.contains("data-log-y=\"1\" data-x-label=\"x, m\" data-y-label=\"y, N\""));
    let series = svg.find("<g class=\"kd-series\" data-label=\"cubic &quot;c&quot;\">").expect("the curve's group");
    let pts = &svg[series..];
    let pts = &pts[pts.find("points=\"").unwrap() + 8..];
    let first: Vec<f64> = pts.split_whitespace().next().unwrap().split(',').map(|t| t.parse().unwrap()).collect();
    let xv = xs[0] + (first[0] - pxs[0]) / (pxs[1] - pxs[0]) * (xs[1] - xs[0]);
    let yv = ys[0] * (ys[1] / ys[0]).powf((first[1] - pys[0]) / (pys[1] - pys[0]));
    assert!((xv - x[0]).abs() < 1e-4, "{xv}");
    assert!((yv / y[0] - 1.0).abs() < 1e-3, "{yv}");
}

#[test]
fn tick_labels_are_short() {
    assert_eq!(tick(9.999999999999999e-6), "1e-5");
    assert_eq!(tick(2.95), "2.95");
    assert_eq!(tick(600.0), "600");
    assert_eq!(tick(0.001), "0.001");
    assert_eq!(tick(123456.0), "1.235e5");
    assert_eq!(tick(2e5), "2e5");
    assert_eq!(tick(0.0), "0");
}

#[test]
fn numbers_have_one_format() {
    assert_eq!(num(5e-4, 5), "5e-4");
    assert_eq!(num(1.0057e-1, 5), "0.10057");
    assert_eq!(num(0.38594, 4), "0.3859");
    assert_eq!(num(2.940_412, 5), "2.9404");
    assert_eq!(num(3.0, 5), "3");
    assert_eq!(num(-622.5, 5), "-622.5");
    assert_eq!(num(2.512_675_2e5, 4), "2.513e5");
    assert_eq!(num(99_999.9, 4), "1e5");
}
