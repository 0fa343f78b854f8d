"""Studies: simulated participants over conditions (`engine.py`) and their tables
and figure (`results.py`)."""
