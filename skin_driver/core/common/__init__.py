"""Helpers the whole core shares: input checks and atomic file writes."""
