"""Sample data: a virtual test rig and the sample runs it writes."""
