"""Model: planar constraint-based kinematics and inverse dynamics."""
