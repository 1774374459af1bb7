"""Batched simulation: kinematics, sensors, collisions and the episode loop."""
