"""Simulation: the integrated system, energy, the run loop, trajectories, batches, the compiled path."""
