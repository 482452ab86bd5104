"""Benchmarks: speed against error for each choice (`rigval bench`) and their page."""
