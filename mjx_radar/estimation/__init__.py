"""Range sensing, the cubature Kalman filter and Fisher information (SPEC §1, §4, §5)."""
