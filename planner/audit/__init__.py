"""The independent audit: a plain-Python model of the domain re-simulates every branch."""
