//! Criterion benchmarks of denavit-core: `cargo bench -p denavit-bench` (benches/kinematics.rs).
