//! The general route on the paper's rotor with its pendulum split in two: how many +1 points
//! off a fold (symmetry-breaking branch points) the order branch over 3.0–3.2 at 1000 rpm has,
//! the independent check of the unison-loss curve's least torque.

use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{BifurcationKind, ContinuationOptions, Hbm, HbmOptions};
use kanedyn::kane::Kane;

/// The number of +1 points off a fold on the two pendulums' branch at `torque` N·m, with the
/// branch's bifurcations in words for a failure message.
pub fn plus_one_points(torque: f64) -> (usize, String) {
    let mech = CpvaParams::canonical().with_pendulums(2).mechanism(None).unwrap();
    let kane = Kane::new(&mech).unwrap();
    let forcing = super::cpva_hbm::single(torque);
    let mut two = Hbm::new(&kane, 0, super::cpva_hbm::omega(), &forcing, HbmOptions::default()).unwrap();
    let b = two.continue_in_order(3.0, 3.2, None, &ContinuationOptions::default()).unwrap();
    let plus = b
        .bifurcations
        .iter()
        .filter(|x| x.kind == BifurcationKind::PlusOne && !b.folds.iter().any(|f| f.after == x.after))
        .count();
    (plus, format!("{:?}", b.bifurcations))
}
