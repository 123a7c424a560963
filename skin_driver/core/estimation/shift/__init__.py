"""Estimators of the shift between the layers of a contact, selectable by name."""
