"""ADLINK AMP-204C / AMP-208C (work in progress): interpolation geometry and group motion."""
