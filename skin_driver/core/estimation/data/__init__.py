"""Datasets and recordings of raw frames with their truth."""
