//! The general route on the paper's rotor with its pendulum split in two: how many +1 points
//! off a fold (symmetry-breaking branch points) the order branch over 3.0–3.2 at 1000 rpm has,
//! the independent check of the unison-loss curve's least torque.

use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{BifurcationClass, BifurcationKind, Branch, ContinuationOptions, Hbm, HbmOptions};
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

/// The one fold of the order branch `b` (a short branch near where the unison-loss boundary
/// meets the jump boundary) and whether the branch point nearest it comes before it along the
/// branch; `what` names the branch in failure messages. The branch's step must separate the two.
pub fn fold_and_side_of_branch_point(b: &Branch, what: &str) -> (f64, bool) {
    assert_eq!(b.folds.len(), 1, "{what}: {:?}", b.folds);
    let fold = &b.folds[0];
    let bp = b
        .bifurcations
        .iter()
        .filter(|x| x.class == BifurcationClass::BranchPoint)
        .min_by(|x, y| (x.order - fold.order).abs().total_cmp(&(y.order - fold.order).abs()))
        .unwrap_or_else(|| panic!("{what}: no branch point"));
    println!("{what}: fold {} after {}, branch point {} after {}", fold.order, fold.after, bp.order, bp.after);
    assert_ne!(bp.after, fold.after, "{what}: the step does not separate them");
    (fold.order, bp.after < fold.after)
}
