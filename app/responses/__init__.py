"""What answers an execution, built from a --responses spec (sources and simulators)."""
