"""
Estimation: raw counts of both layers to contacts with location, force and direction.

Works from measurements alone: it never renders a press and never imports :mod:`..sim`.
"""
