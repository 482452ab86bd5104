"""Metrics: ISO/TS 18571 ratings, waveform metrics, the ASME V&V 20 comparison and thresholds."""
