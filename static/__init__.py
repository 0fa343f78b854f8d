"""Tandem's non-code assets, installed as the package `tandem_static`.

pyproject.toml maps the package name to this folder, so the scenarios ship in
the wheel and are read through `importlib.resources` (planner/resources.py).
"""
