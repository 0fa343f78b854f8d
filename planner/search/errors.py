"""The search's failures, in a module that loads no solver.

`tandem sessions` and the CLI's exit codes name these errors without loading
clingo: the search itself (`planner.search.hcp`) raises them.
"""


class DeadEnd(Exception):
    """No conditional plan: the start state cannot reach the goal under every outcome."""
