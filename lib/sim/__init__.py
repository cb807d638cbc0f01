"""Simulators: truth trajectories and noisy sensor sessions for each sport."""
