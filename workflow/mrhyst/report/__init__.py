"""The report: what it collects, the figure style, notebook cleaning."""
