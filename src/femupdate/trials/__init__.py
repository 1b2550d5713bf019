"""The trials of a case: measured and virtual experiments, read, checked and
processed."""
