"""The closed loop of paper Algorithm 1 and initial placement, pure JAX (SPEC §8)."""
