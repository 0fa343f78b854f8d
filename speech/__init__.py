"""Speech: the robot's side of the dialogue with the human teammate."""
