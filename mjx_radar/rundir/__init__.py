"""The result format: run directories (metrics, trajectories, metadata) written and read."""
