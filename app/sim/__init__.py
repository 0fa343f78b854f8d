"""The simulated world and human that the camera and the voice observe."""
