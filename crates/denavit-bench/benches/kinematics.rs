//! Criterion benchmarks of the core kinematics and IK (no Python): `cargo bench -p denavit-core`.
//! The user-facing comparison with other libraries is `benchmarks/bench_kinematics.py`.
#![allow(clippy::unwrap_used)]

use criterion::{BatchSize, Criterion, black_box, criterion_group, criterion_main};
use denavit_core::{
    Convention, Data, JointKind, Table,
    ik::{IkMethod, IkOptions, IkSolver, ik_path},
    kinematics::{JacobianFrame, fk, fk_batch, jacobian},
    spatial::{Pose, nearest_rotation, trans},
};
use nalgebra::{DMatrix, Matrix3, Translation3};
use std::f64::consts::FRAC_PI_2;

/// TianSui-One, modified DH (Guo et al. Table I).
fn tiansui() -> denavit_core::Model {
    #[rustfmt::skip]
    let p = DMatrix::from_row_slice(6, 4, &[
        0.0, 0.0, 0.0, 0.0,
        FRAC_PI_2, 0.0, -FRAC_PI_2, 0.1485,
        0.0, -0.406, 0.0, 0.0,
        0.0, -0.386, FRAC_PI_2, 0.002,
        -FRAC_PI_2, 0.0, 0.0, 0.128,
        FRAC_PI_2, 0.0, 0.0, 0.0,
    ]);
    Table::new(Convention::Mdh, p, vec![JointKind::Revolute; 6], Pose::identity(), Pose::identity()).unwrap().to_model("tiansui_mdh").unwrap()
}

fn random_qs(count: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..count * 6)
        .map(|_| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2.0 * std::f64::consts::PI
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let m = tiansui();
    let q = [0.3, -0.2, 0.5, 0.1, 0.4, -0.3];
    let mut data = Data::new(&m);
    c.bench_function("fk", |b| b.iter(|| fk(&m, black_box(&q)).unwrap()));
    c.bench_function("jacobian", |b| b.iter(|| jacobian(&m, &mut data, black_box(&q), JacobianFrame::LocalWorldAligned).unwrap()));

    let qs = random_qs(100_000, 1);
    let mut out = vec![0.0; 16 * 100_000];
    let mut g = c.benchmark_group("batch");
    g.sample_size(20);
    g.bench_function("fk_batch 100k", |b| b.iter(|| fk_batch(&m, black_box(&qs), &mut out).unwrap()));
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    g.bench_function("fk_batch 100k, 1 thread", |b| b.iter(|| one.install(|| fk_batch(&m, black_box(&qs), &mut out).unwrap())));
    g.finish();

    // IK of random reachable targets from q0 = 0.3 rad, to 1e-9
    let targets: Vec<Pose> = random_qs(1000, 7).chunks(6).map(|q| fk(&m, q).unwrap()).collect();
    let mut solver = IkSolver::new(&m, IkOptions { tol_position: 1e-9, tol_rotation: 1e-9, ..Default::default() }).unwrap();
    let mut k = 0;
    c.bench_function("ik random target (lm)", |b| {
        b.iter_batched(
            || {
                k = (k + 1) % targets.len();
                targets[k]
            },
            |t| solver.solve(&t, &[0.3; 6]).unwrap(),
            BatchSize::SmallInput,
        )
    });

    // Guo et al. sec. V: 100 warm-started solves along base +Z, 1 mm steps, to 1e-10
    #[rustfmt::skip]
    let r = Matrix3::new(-0.7598, 0.4151, 0.5004, -0.4391, 0.2399, -0.8658, -0.4794, -0.8776, 0.0);
    let t0 = Pose::from_parts(Translation3::new(-0.3655, -0.3712, -0.0245), nearest_rotation(&r));
    let path: Vec<Pose> = (1..=100).map(|k| trans(0.0, 0.0, 0.001 * k as f64) * t0).collect();
    let start = [0.5000573716972164, 0.5236209148144663, 1.7452591015612922, 0.8725956819907926, -0.023984304103264006, 0.5001129722254618];
    for method in [IkMethod::Newton, IkMethod::Lm] {
        let o = IkOptions { method, ..Default::default() };
        c.bench_function(&format!("guo trajectory 100 solves ({})", method.name()), |b| b.iter(|| ik_path(&m, &path, &start, &o).unwrap()));
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
