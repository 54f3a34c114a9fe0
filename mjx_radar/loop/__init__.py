"""A planner driving the environment: the closed loop of paper Algorithm 1 (SPEC §8)."""
