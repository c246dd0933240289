use kanedyn::kane::Kane;
use kanedyn::mechanism::Mechanism;
use std::hint::black_box;
fn main() {
    let which = std::env::args().nth(1).unwrap_or_default();
    let mech = Mechanism::from_file(std::path::Path::new("examples/cpva.ron")).unwrap();
    let exc = mech.loads.joint_torques[0].excitation.clone();
    let mut k = Kane::new(&mech).unwrap();
    let cf = kanedyn::cpva::CpvaParams::canonical().closed_form();
    let mut x = [1234.5, 0.4, 104.9, 108.2];
    let mut xd = [0.0; 4];
    let mut acc = 0.0;
    let iters: usize = std::env::args().nth(2).map_or(10_000_000, |s| s.parse().unwrap());
    for i in 0..iters {
        let t = i as f64 * 1e-7;
        x[1] = 0.4 + 1e-9 * i as f64;
        if which == "cf" { cf.rhs1(exc.torque(black_box(t)), black_box(&x), &mut xd); } else { k.rhs(black_box(t), black_box(&x), &mut xd).unwrap(); }
        acc += xd[2];
    }
    println!("{acc}");
}
