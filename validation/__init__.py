"""Validation: compare measurement and model, metrics, pass/fail, reports and the CLI."""
