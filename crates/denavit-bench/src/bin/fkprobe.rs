#![allow(clippy::unwrap_used)]
use denavit_core::{
    Convention, JointKind, Table,
    kinematics::tool_pose_batch,
    spatial::{Pose, rx, trans},
};
use nalgebra::DMatrix;
use std::f64::consts::FRAC_PI_2;
fn main() {
    #[rustfmt::skip]
    let p = DMatrix::from_row_slice(6, 4, &[
        0.0, 0.0, 0.0, 0.0,
        FRAC_PI_2, 0.0, -FRAC_PI_2, 0.1485,
        0.0, -0.406, 0.0, 0.0,
        0.0, -0.386, FRAC_PI_2, 0.002,
        -FRAC_PI_2, 0.0, 0.0, 0.128,
        FRAC_PI_2, 0.0, 0.0, 0.0,
    ]);
    let tool = if std::env::args().nth(1).is_some() { Pose::identity() } else { trans(0.01, 0.02, 0.1) * rx(0.3) };
    let m = Table::new(Convention::Mdh, p, vec![JointKind::Revolute; 6], Pose::identity(), tool).unwrap().to_model("t").unwrap();
    let n: usize = std::env::var("N").map_or(100_000, |v| v.parse().unwrap());
    let mut s = 1u64;
    let qs: Vec<f64> = (0..n * 6)
        .map(|_| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 6.28
        })
        .collect();
    let mut out = vec![0.0; 16 * n];
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let mut ts = vec![];
    for _ in 0..201 {
        let t = std::time::Instant::now();
        one.install(|| tool_pose_batch(&m, &qs, &mut out).unwrap());
        ts.push(t.elapsed().as_secs_f64());
    }
    ts.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let sum: f64 = out.iter().sum();
    println!("N {n} per 1e5: median {:.3} ms  min {:.3} ms  (checksum {sum:.17e})", ts[100] * 1e8 / n as f64, ts[0] * 1e8 / n as f64);
}
