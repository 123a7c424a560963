"""
Estimation: raw counts of both layers to contacts with location, force and direction.

Works from measurements alone: it never imports :mod:`..sim`, and the presses it renders (the
``model_fit`` method's fit, the direction calibration's :mod:`.calibration.rendered`) are rendered
through the taxel model learned from the skin's own calibration presses.
"""
