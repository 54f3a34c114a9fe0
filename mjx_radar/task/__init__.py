"""The radar-placement task: methods, cost terms, objective and the MPC step (SPEC §6)."""
