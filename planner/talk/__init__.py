"""What the robot says: phrases, and the conversation around a task plan."""
