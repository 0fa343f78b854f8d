"""Running a session: one assembly of the executor for the command line, studies
and the dashboard (`session.py`)."""
