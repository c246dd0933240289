use kanedyn::cpva::CpvaParams;
use kanedyn::excitation::{Harmonic, rpm_to_rad_s};
use kanedyn::hbm::*;
use kanedyn::kane::Kane;
use std::time::Instant;

#[test]
fn scratch() {
    let p = CpvaParams::canonical();
    let mech = p.mechanism(None).unwrap();
    let kane = Kane::new(&mech).unwrap();
    let spin = mech.joint_index("spin").unwrap();
    let omega = rpm_to_rad_s(1000.0);
    for &amp in &[40.0, 500.0] {
        let h = [Harmonic { multiple: 1.0, amplitude: amp, phase: 0.0 }];
        let mut hbm = Hbm::new(&kane, spin, omega, &h, HbmOptions::default()).unwrap();
        let t0 = Instant::now();
        let s = hbm.solve(3.0, None).unwrap();
        println!("solve {:?} it {} res {:e} Tm {} ratio {:e} a1 {} a2 {} phi {}", t0.elapsed(), s.iterations, s.residual, s.mean_torque, s.top_harmonic_ratio, s.order_acceleration(0,1.0), s.order_acceleration(0,2.0), s.max_peak_amplitude());
        let t0 = Instant::now();
        let st = hbm.stability(&s).unwrap();
        println!("stab {:?} {:?}", t0.elapsed(), st);
        let t0 = Instant::now();
        let b = hbm.continue_in_order(2.9, 3.3, None, &ContinuationOptions::default()).unwrap();
        println!("branch {:?} points {} newton {} end {:?}", t0.elapsed(), b.points.len(), b.newton_iterations, b.end);
        for pt in &b.points {
            println!("n {:.5} s {:.4} dn {:+.3} a1 {:9.4} a2 {:9.4} phi {:.4} st {:?} mu {:.6} it {} hr {:.1e}", pt.order, pt.arclength, pt.order_slope, pt.accel_main, pt.accel_second, pt.pendulum_amplitude, pt.stable, pt.solution.stability.as_ref().unwrap().max_modulus, pt.solution.iterations, pt.solution.top_harmonic_ratio);
        }
        println!("folds {:#?}", b.folds);
        println!("bif {:#?}", b.bifurcations);
    }
}
