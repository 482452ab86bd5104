"""Processing: raw channels to physical, aligned and angle-domain signals."""
