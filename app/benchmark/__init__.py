"""Benchmarks that print tables: the paper's instances (`planner_benchmark`, run by
`tandem bench`) and the dashboard's page load and clicks (`dashboard_benchmark`).

They sit in the app, not in the planner, because they wire the planner, the
audit and the dashboard together; they ship with the wheel because `tandem
bench` is a command of the installed program.
"""
