"""The closed loop of paper Algorithm 1, initial placement and batched trial execution (SPEC §8)."""
