"""The search for a conditional plan: encodings, the solver, the DAG, symmetry, workers."""
