"""Tandem application layer: wires perception, speech and the planner together."""
