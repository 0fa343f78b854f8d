"""Outcome sources: clicks, scripts, random, the camera and the voice."""
