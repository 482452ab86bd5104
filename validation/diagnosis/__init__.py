"""Diagnosis: why a comparison disagrees (residual spectra and modes, symmetry, attribution)."""
