//! Narrow tongues found at any step (issue 26, item 2).

use crate::support::cpva_hbm;
use cpva_hbm::{omega, single};
use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{Branch, ContinuationOptions, Hbm, HbmOptions};
use kanedyn::kane::Kane;

fn branch(pendulums: usize, torque: f64, from: f64, to: f64, ds_max: Option<f64>) -> Branch {
    let p = CpvaParams::canonical().with_pendulums(pendulums);
    let kane = Kane::new(&p.mechanism(None).unwrap()).unwrap();
    let mut hbm = Hbm::new(&kane, 0, omega(), &single(torque), HbmOptions::default()).unwrap();
    let copts = match ds_max {
        Some(ds_max) => ContinuationOptions {
            ds_max,
            ds: ContinuationOptions::default().ds.min(ds_max),
            max_points: 20_000,
            ..Default::default()
        },
        None => ContinuationOptions::default(),
    };
    hbm.continue_in_order(from, to, None, &copts).unwrap()
}

#[test]
#[ignore]
fn explore_tongues() {
    let cases: Vec<(usize, f64, f64, f64)> = std::env::var("TONGUE_CASES")
        .unwrap_or("2,500,5.6,6.8".into())
        .split(';')
        .map(|c| {
            let v: Vec<f64> = c.split(',').map(|x| x.parse().unwrap()).collect();
            (v[0] as usize, v[1], v[2], v[3])
        })
        .collect();
    let steps: Vec<Option<f64>> = std::env::var("TONGUE_STEPS")
        .unwrap_or("0.1,default,0.01,0.001".into())
        .split(',')
        .map(|s| s.parse().ok())
        .collect();
    for (np, torque, a, b) in cases {
        for (from, to) in [(a, b), (b, a)] {
            for &ds in &steps {
                let t0 = std::time::Instant::now();
                let br = branch(np, torque, from, to, ds);
                let mut ev: Vec<(f64, String)> =
                    br.bifurcations.iter().map(|x| (x.order, format!("{:?}", x.class))).collect();
                ev.sort_by(|x, y| x.0.total_cmp(&y.0));
                let s: Vec<String> = ev.iter().map(|(o, c)| format!("{o:.8} {c}")).collect();
                println!(
                    "N={np} T={torque} {from}->{to} ds_max={ds:?}: {} pts {:.2}s end {:?}: {}",
                    br.points.len(),
                    t0.elapsed().as_secs_f64(),
                    br.end,
                    s.join(", ")
                );
            }
        }
    }
}
