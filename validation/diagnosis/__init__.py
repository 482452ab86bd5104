"""Diagnosis: why a comparison disagrees (residual spectra, modes, symmetry, attribution)."""
