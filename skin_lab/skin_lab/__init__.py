"""
The lab beside the driver: what judges the estimator, never what a robot runs.

The benchmark (:mod:`skin_lab.bench`, ``make bench``), the evaluator (:mod:`skin_lab.evaluate`,
``python -m skin_lab.evaluate``), the oracle and the direction's floor (:mod:`skin_lab.oracle`,
:mod:`skin_lab.floor`), the experiments' scenes (:mod:`skin_lab.experiments`) and the demo
(:mod:`skin_lab.demo`, ``make demo``). It imports the driver's core, simulator and estimator
alike; the driver never imports it.
"""
