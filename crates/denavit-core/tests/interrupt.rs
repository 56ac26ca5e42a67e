//! `parallel::interrupt`: every batch and solve stops at its next check, and runs again once cleared.
//! Process-wide, so this binary holds one test alone.
#![allow(clippy::unwrap_used)]

use denavit_core::ik::{IkOptions, ik};
use denavit_core::kinematics::fk_batch;
use denavit_core::parallel::{clear_interrupt, interrupt, with_threads};
use denavit_core::spatial::trans;
use denavit_core::{Error, builtin_planar2};

#[test]
fn an_interrupt_stops_batches_and_solves_until_cleared() {
    let m = builtin_planar2(1.0, 1.0);
    let n = 100_000;
    let qs = vec![0.3; 2 * n];
    let mut out = vec![0.0; 16 * n];
    let far = trans(3.0, 0.0, 0.0);
    interrupt();
    for threads in [Some(1), Some(2), None] {
        let r = with_threads(threads, || fk_batch(&m, &qs, &mut out)).unwrap();
        assert_eq!(r, Err(Error::Interrupted), "threads {threads:?}");
    }
    let opts = IkOptions { restarts: 1_000_000, ..IkOptions::default() };
    assert_eq!(ik(&m, &far, &[0.0, 0.5], &opts), Err(Error::Interrupted));
    clear_interrupt();
    with_threads(Some(2), || fk_batch(&m, &qs, &mut out)).unwrap().unwrap();
    assert!(out.iter().all(|v| v.is_finite()));
    let near = denavit_core::kinematics::fk(&m, &[0.3, 1.2]).unwrap();
    assert!(ik(&m, &near, &[0.0, 0.5], &IkOptions::default()).unwrap().success);
}
