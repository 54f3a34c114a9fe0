"""Task-agnostic MPPI with adaptive importance sampling and covariance shrinkage (SPEC §7)."""
