"""The run of a plan: typed events, the walker, slots, narration, surprises, repair."""
