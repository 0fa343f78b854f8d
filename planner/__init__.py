"""Tandem planner: scenarios, the ASP domain and the hybrid conditional planner."""
