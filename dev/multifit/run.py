"""Dev: score the multi frames with the Python description (compiled=False)."""
import sys, json, time
import numpy as np
from skin_driver.core.estimation.dataset import load_dataset
from skin_driver.core.estimation.prepared import prepared_estimator
from skin_driver.tools.evaluate.scoring import MethodRun, score_presses

out = {}
for path in sys.argv[1:]:
    data = load_dataset(path)
    est, notes = prepared_estimator(data, 'taxel_fit')
    est = est.with_compiled(False)
    d = data.select(data.scored_frames())
    t = time.perf_counter()
    import math, os
    from skin_driver.core.estimation import jointfit
    contacts = []
    for i in range(d.frames):
        jointfit.TRUTH.clear()
        if os.environ.get('MF_TRUTH'):
            for q in d.presses(i):
                sh = q['shift_m'] / d.pitch_m
                az = math.radians(q['azimuth_deg']) if q['alpha_deg'] > 0 else 0.0
                jointfit.TRUTH.append((q['y_m'] / d.pitch_m, q['x_m'] / d.pitch_m, sh * math.sin(az), sh * math.cos(az)))
        contacts.append(est.process(d.top[i], d.bottom[i]))
    us = (time.perf_counter() - t) / d.frames * 1e6
    s = score_presses(d, MethodRun('taxel_fit', est.calibration, contacts, us))
    print(path.split('/')[-1], 'found %.3f mean %.2f valid %.3f weaker %.2f  %.0f us' % (
        s['found_share'], s['mean_error_deg'], s['valid_share'], s['weaker_mean_error_deg'], us), flush=True)
