"""Scenario files: sections, cross-field rules, the model, loading, the paper's benches."""
