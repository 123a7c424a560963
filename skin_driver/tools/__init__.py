"""Command-line tools around the driver: the simulated skin, recording, conversion, bring-up."""
