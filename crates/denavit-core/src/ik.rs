//! Inverse kinematics (Newton-Raphson, damped least squares / Levenberg-Marquardt), path and batch solvers.
