"""Calibration: the file, the sessions that fit it from presses, tare and press rules."""
