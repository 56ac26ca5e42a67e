//! Rigid-body dynamics: inertial parameters, recursive Newton-Euler, mass matrix, forward dynamics.
