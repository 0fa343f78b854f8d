"""The robot behind the plan: one link protocol, its backends, the simulated Baxter."""
