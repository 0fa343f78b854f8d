"""Perception: locating parts on the bench (fiducial markers, geometry)."""
