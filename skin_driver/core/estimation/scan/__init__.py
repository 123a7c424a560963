"""The per-scan estimate: the pipeline, its compiled kernel and what it returns."""
