"""Filters: the cubature Kalman filter (covariance and square-root forms), the per-target bank, the
IMM, the measurement model as filter functions, the ground prior."""
