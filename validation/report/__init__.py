"""Reports: the page builder, the plots, the mechanism sketch, the run and prediction reports."""
