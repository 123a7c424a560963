"""Command-line tools around the driver: recording, conversion, evaluation."""
