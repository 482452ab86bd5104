"""Campaigns: many runs validated at once (on Dask if installed) and their summary page."""
