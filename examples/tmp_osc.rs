use kanedyn::time::integrate::{IntegrateOptions, Method, integrate};
fn main() {
    let (k1, k2, c1, c2) = (25.0, 2.0e6, 0.1, 100.0);
    let rhs = move |_: f64, x: &[f64], dx: &mut [f64]| {
        dx[0] = x[2];
        dx[1] = x[3];
        dx[2] = -k1 * x[0] - k2 * (x[0] - x[1]) - c1 * x[2] - c2 * (x[2] - x[3]);
        dx[3] = -k1 * x[1] - k2 * (x[1] - x[0]) - c1 * x[3] - c2 * (x[3] - x[2]);
        Ok(())
    };
    for t1 in [0.1, 0.5, 1.0, 2.0, 5.0] {
        for rtol in [1e-9, 1e-6] {
            let opts = IntegrateOptions {
                rtol,
                atol: rtol,
                sample_rate_hz: None,
                method: Method::Radau5,
                ..Default::default()
            };
            let out = integrate(rhs, &[1.0, 0.0, 0.0, 0.0], 0.0, t1, &opts, |_| {}).unwrap();
            println!("t1 {t1} rtol {rtol:e}: {}", out.stats);
        }
    }
}
